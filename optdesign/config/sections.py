"""Parsing of the config's workspace and optimizer sections (see :mod:`.loader`)."""
from __future__ import annotations

import math
from typing import Any

from ..workspace import WorkspaceSpec
from .reader import UNITS, Reader, show, tname
from .schema import OptimizerSpec

__all__ = ["workspace_section", "optimizer_section", "WS_KEYS", "OPT_KEYS", "SAMPLING"]

WS_KEYS = {"type", "axes", "sampling", "step", "points_per_axis", "points", "seed", "radius",
           "center", "unit"}
SAMPLING = {"grid", "sobol", "halton", "lhs", "random"}
OPT_KEYS = {"algorithm", "population", "generations", "crossover_probability", "elites", "fitness_scaling",
            "mutation_probability", "seed", "weights", "normalization", "pareto",
            "extra_objectives", "singularity_threshold", "stroke_limits", "min_transmission", "prescan", "polish",
            "checkpoint_interval"}


def workspace_section(r: Reader, ws: Any, mech_cls) -> WorkspaceSpec:
    path = "workspace"
    ws = r.mapping(ws, path)
    r.only(ws, path, WS_KEYS)
    wtype = r.string(ws.get("type", "box"), f"{path}.type", choices={"box", "cylinder"})
    unit = r.unit(ws.get("unit"), f"{path}.unit")
    scale = UNITS[unit]
    axes_raw = r.mapping(r.require(ws, "axes", path), f"{path}.axes")
    names = tuple(mech_cls.pose_names)
    r.only(axes_raw, f"{path}.axes", set(names))
    axes: dict[str, tuple[float, float]] = {}
    for a in names:
        apath = f"{path}.axes.{a}"
        if a not in axes_raw:
            if wtype == "cylinder" and a in names[:2]:
                continue
            r.fail(apath, "missing required axis (a value or a [lower, upper] range)")
        val = axes_raw[a]
        if isinstance(val, (list, tuple)):
            axes[a] = r.pair(val, apath, scale=scale)
        else:
            x = r.number(val, apath) * scale
            axes[a] = (x, x)
    radius = None
    center = (0.0, 0.0)
    if wtype == "cylinder":
        radius = r.number(r.require(ws, "radius", path), f"{path}.radius", positive=True) * scale
        if "center" in ws:
            c = ws["center"]
            if not isinstance(c, (list, tuple)) or len(c) != 2:
                r.fail(f"{path}.center", f"expected a list [x, y], got {tname(c)}")
            center = (r.number(c[0], f"{path}.center[0]") * scale, r.number(c[1], f"{path}.center[1]") * scale)
        for a in names[:2]:
            if a in axes_raw:
                r.fail(f"{path}.axes.{a}", "a cylinder takes its first two axes from radius and center; remove this axis")
    sampling = r.string(ws.get("sampling", "grid"), f"{path}.sampling", choices=SAMPLING)
    step = ppa = pts = None
    if sampling == "grid":
        if "step" in ws:
            step = r.number(ws["step"], f"{path}.step", positive=True) * scale
        elif "points_per_axis" in ws:
            ppa = r.integer(ws["points_per_axis"], f"{path}.points_per_axis", minimum=1, maximum=10_000)
        else:
            r.fail(f"{path}.step", "a grid needs 'step' or 'points_per_axis'")
        if step is not None:
            total = 1
            for lo, hi in axes.values():
                total *= int(math.floor((hi - lo) / step + 1e-9)) + 1
            if wtype == "cylinder":
                total *= int(2 * radius / step + 1) ** 2
            if total > 50_000_000:
                r.fail(f"{path}.step", f"step {ws['step']} gives {show(total)} grid points; expected at most 50,000,000")
    else:
        pts = r.integer(r.require(ws, "points", path), f"{path}.points", minimum=1, maximum=50_000_000)
    seed = r.integer(ws.get("seed", 0), f"{path}.seed", minimum=0)
    return WorkspaceSpec(type=wtype, axes=axes, sampling=sampling, step=step, points_per_axis=ppa,
                         points=pts, seed=seed, radius=radius, center=center, unit=unit)


def optimizer_section(r: Reader, opt: Any, dvs: dict, indices: dict, mech_cls) -> OptimizerSpec:
    path = "optimizer"
    if opt is None:
        return OptimizerSpec(weights={k: 1.0 for k in indices})
    opt = r.mapping(opt, path)
    r.only(opt, path, OPT_KEYS)
    kw: dict[str, Any] = {}
    if "algorithm" in opt:
        kw["algorithm"] = r.string(opt["algorithm"], f"{path}.algorithm", choices={"paper_ga", "pymoo_ga", "de"})
    for key, lo in (("population", 4), ("generations", 1), ("elites", 0)):
        if key in opt:
            kw[key] = r.integer(opt[key], f"{path}.{key}", minimum=lo, maximum=100_000)
    if "elites" in kw and kw["elites"] >= kw.get("population", 50):
        r.fail(f"{path}.elites", f"expected fewer elites than the population ({kw.get('population', 50)}), got {kw['elites']}")
    for key in ("crossover_probability", "mutation_probability"):
        if key in opt:
            x = r.number(opt[key], f"{path}.{key}")
            if not 0 <= x <= 1:
                r.fail(f"{path}.{key}", f"expected a probability in [0, 1], got {x:g}")
            kw[key] = x
    if "seed" in opt:
        kw["seed"] = r.integer(opt["seed"], f"{path}.seed", minimum=0, maximum=2**32 - 1)
    if "fitness_scaling" in opt:
        kw["fitness_scaling"] = r.string(opt["fitness_scaling"], f"{path}.fitness_scaling", choices={"rank", "linear"})
    weights = {k: 1.0 for k in indices}
    if "weights" in opt:
        wm = r.mapping(opt["weights"], f"{path}.weights")
        for k, v in wm.items():
            if k not in indices:
                r.fail(f"{path}.weights.{k}", f"unknown index; expected one of {', '.join(indices)}")
            weights[k] = r.number(v, f"{path}.weights.{k}", nonneg=True)
        if sum(weights.values()) <= 0:
            r.fail(f"{path}.weights", "expected at least one positive weight")
    kw["weights"] = weights
    if "normalization" in opt:
        kw["normalization"] = r.string(opt["normalization"], f"{path}.normalization", choices={"sense", "paper_literal"})
    if "pareto" in opt and opt["pareto"] is not None:
        pm = r.mapping(opt["pareto"], f"{path}.pareto")
        r.only(pm, f"{path}.pareto", {"algorithms", "population", "generations"})
        if "algorithms" in pm:
            algs = pm["algorithms"]
            if not isinstance(algs, list):
                r.fail(f"{path}.pareto.algorithms", f"expected a list, got {tname(algs)}")
            kw["pareto_algorithms"] = tuple(r.string(a, f"{path}.pareto.algorithms[{i}]", choices={"nsga2", "nsga3"}) for i, a in enumerate(algs))
        if "population" in pm:
            kw["pareto_population"] = r.integer(pm["population"], f"{path}.pareto.population", minimum=4, maximum=100_000)
        if "generations" in pm:
            kw["pareto_generations"] = r.integer(pm["generations"], f"{path}.pareto.generations", minimum=1, maximum=100_000)
    if "extra_objectives" in opt:
        eo = opt["extra_objectives"]
        if not isinstance(eo, list):
            r.fail(f"{path}.extra_objectives", f"expected a list, got {tname(eo)}")
        kw["extra_objectives"] = tuple(r.string(x, f"{path}.extra_objectives[{i}]", choices=set(mech_cls.extra_objectives)) for i, x in enumerate(eo))
    if "singularity_threshold" in opt:
        kw["singularity_threshold"] = r.number(opt["singularity_threshold"], f"{path}.singularity_threshold", positive=True)
    if "stroke_limits" in opt:
        kw["stroke_limits"] = r.pair(opt["stroke_limits"], f"{path}.stroke_limits")
    if "min_transmission" in opt:
        x = r.number(opt["min_transmission"], f"{path}.min_transmission", nonneg=True)
        if x >= 1:
            r.fail(f"{path}.min_transmission", f"expected a value in [0, 1), got {x:g}")
        kw["min_transmission"] = x
    if "prescan" in opt:
        kw["prescan"] = r.integer(opt["prescan"], f"{path}.prescan", minimum=0, maximum=1_000_000)
    if "polish" in opt:
        kw["polish"] = r.integer(opt["polish"], f"{path}.polish", minimum=0, maximum=100)
    if "checkpoint_interval" in opt:
        kw["checkpoint_interval"] = r.number(opt["checkpoint_interval"], f"{path}.checkpoint_interval", nonneg=True)
    return OptimizerSpec(**kw)
