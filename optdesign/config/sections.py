"""Parsing of the config's workspace and optimizer sections (see :mod:`.loader`)."""
from __future__ import annotations

from typing import Any

from ..workspace import MAX_POINTS, WorkspaceSpec, point_count
from .reader import UNITS, Reader, join, show, suggest, tname
from .schema import OptimizerSpec

__all__ = ["workspace_section", "optimizer_section", "WS_KEYS", "OPT_KEYS", "REMOVED_OPT_KEYS", "SAMPLING"]

WS_KEYS = {"type", "axes", "sampling", "step", "points_per_axis", "points", "seed", "radius",
           "center", "unit", "scramblings", "tolerance", "max_points"}
SAMPLING = {"grid", "gauss", "rqmc", "sobol", "halton", "lhs", "random", "adaptive"}
#: adaptive sampling: the default relative tolerance and node budget, the range of the tolerance
ADAPTIVE_TOLERANCE, ADAPTIVE_MAX_POINTS, TOLERANCE_RANGE = 1e-3, 200_000, (1e-10, 0.5)
#: most points a workspace sample may have
#: keys that a sampling does not take (a mistake to give)
_NOT_FOR = {
    "gauss": {"step": "a Gauss rule places points_per_axis nodes per axis",
              "points": "a Gauss rule places points_per_axis nodes per axis",
              "seed": "a Gauss rule is not random", "scramblings": "only rqmc sampling is scrambled"},
    "adaptive": {"step": "adaptive cubature places its own nodes", "points_per_axis": "adaptive cubature places its own nodes",
                 "points": "adaptive cubature places its own nodes (its budget is 'max_points')",
                 "seed": "adaptive cubature is not random"},
    "rqmc": {"step": "rqmc places 'points' Sobol points per scrambling",
             "points_per_axis": "rqmc places 'points' Sobol points per scrambling"},
}
OPT_KEYS = {"algorithm", "population", "generations", "crossover_probability", "elites", "fitness_scaling",
            "mutation_probability", "seed", "weights", "pareto",
            "extra_objectives", "singularity_threshold", "stroke_limits", "prescan", "polish",
            "checkpoint_interval", "worst_case", "constraint_margin", "extremes"}
#: keys of earlier versions that had no effect: refused in a new config, ignored in a run folder's
REMOVED_OPT_KEYS = {
    "normalization": "every term is normalized so that 0 is best, and the literal eq. 38 runs as its own stage",
    "min_transmission": "it was never applied as a constraint",
}


def _workspace_unit(r: Reader, value: Any, axes: tuple[str, ...], mech_cls) -> str | None:
    """The block's ``unit``: one every axis it applies to accepts (mm or m on
    lengths, deg or rad on angles, none on plain numbers)."""
    unit = r.unit(value, "workspace.unit")
    if unit is None:
        return None
    wants = {"m": "length", "mm": "length", "rad": "angle", "deg": "angle"}[unit]
    words = {"length": "a length", "angle": "an angle", "number": "a plain number"}
    for a in axes:
        kind = mech_cls.pose_kind(a)
        if kind != wants:
            ok = {"length": "m or mm", "angle": "rad or deg", "number": "no unit"}[kind]
            r.fail("workspace.unit", f"{unit!r} is {words[wants]} unit, but axis {a} is {words[kind]}; expected {ok}")
    return unit


def workspace_section(r: Reader, ws: Any, mech_cls) -> WorkspaceSpec:
    path = "workspace"
    ws = r.mapping(ws, path)
    r.only(ws, path, WS_KEYS)
    wtype = r.string(ws.get("type", "box"), f"{path}.type", choices={"box", "cylinder"})
    names = tuple(mech_cls.pose_names)
    axes_raw = r.mapping(r.require(ws, "axes", path), f"{path}.axes")
    r.only(axes_raw, f"{path}.axes", set(names))
    used = names if wtype == "cylinder" else tuple(a for a in names if a in axes_raw)
    unit = _workspace_unit(r, ws.get("unit"), used, mech_cls)
    scale = UNITS[unit]
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
        if len(names) != 3:
            r.fail(f"{path}.type", f"a cylinder needs three pose axes; this mechanism has {len(names)} ({', '.join(names)})")
        radius = r.number(r.require(ws, "radius", path), f"{path}.radius", positive=True) * scale
        if "center" in ws:
            c = ws["center"]
            if not isinstance(c, (list, tuple)) or len(c) != 2:
                r.fail(f"{path}.center", f"expected a list [x, y], got {tname(c)}")
            center = (r.number(c[0], f"{path}.center[0]") * scale, r.number(c[1], f"{path}.center[1]") * scale)
        for a in names[:2]:
            if a in axes_raw:
                r.fail(f"{path}.axes.{a}", "a cylinder takes its first two axes from radius and center; remove this axis")
    elif "radius" in ws or "center" in ws:
        key = "radius" if "radius" in ws else "center"
        r.fail(f"{path}.{key}", f"'{key}' is for type: cylinder; a box takes its ranges from 'axes'")
    sampling = r.string(ws.get("sampling", "grid"), f"{path}.sampling", choices=SAMPLING)
    for key, why in _NOT_FOR.get(sampling, {}).items():
        if key in ws:
            r.fail(f"{path}.{key}", f"not used by sampling '{sampling}' ({why}); remove it")
    if "scramblings" in ws and sampling != "rqmc":
        r.fail(f"{path}.scramblings", f"only sampling 'rqmc' takes scramblings, not '{sampling}'")
    for key in ("tolerance", "max_points"):
        if key in ws and sampling != "adaptive":
            r.fail(f"{path}.{key}", f"only sampling 'adaptive' takes {key}, not '{sampling}'")
    step = ppa = pts = None
    scramblings = 8
    tolerance, max_points = None, ADAPTIVE_MAX_POINTS
    free = sum(1 for lo, hi in axes.values() if hi > lo)
    if sampling == "gauss":
        ppa = r.integer(r.require(ws, "points_per_axis", path), f"{path}.points_per_axis", minimum=2, maximum=10_000)
        total = (2 * ppa ** (free + 2)) if wtype == "cylinder" else ppa ** free
        if total > MAX_POINTS:
            r.fail(f"{path}.points_per_axis", f"{ppa} nodes per axis give {show(total)} points; expected at most {MAX_POINTS:,}")
    elif sampling == "adaptive":
        tolerance = r.number(ws.get("tolerance", ADAPTIVE_TOLERANCE), f"{path}.tolerance")
        lo, hi = TOLERANCE_RANGE
        if not lo <= tolerance <= hi:
            r.fail(f"{path}.tolerance", f"expected a relative tolerance in [{lo:g}, {hi:g}], got {show(ws['tolerance'])}")
        max_points = r.integer(ws.get("max_points", ADAPTIVE_MAX_POINTS), f"{path}.max_points", minimum=1000,
                               maximum=MAX_POINTS)
    elif sampling == "rqmc":
        pts = r.integer(r.require(ws, "points", path), f"{path}.points", minimum=2, maximum=MAX_POINTS)
        if pts & (pts - 1):
            lo2 = 1 << (pts.bit_length() - 1)
            r.fail(f"{path}.points", f"expected a power of 2 (a Sobol set is balanced in blocks of 2^m), "
                                     f"got {pts}; use {lo2} or {2 * lo2}")
        if "scramblings" in ws:
            scramblings = r.integer(ws["scramblings"], f"{path}.scramblings", minimum=2, maximum=1024)
        if pts * scramblings > MAX_POINTS:
            r.fail(f"{path}.points", f"{pts} points x {scramblings} scramblings give {show(pts * scramblings)} points; "
                                     f"expected at most {MAX_POINTS:,}")
    elif sampling == "grid":
        if "points" in ws:
            r.fail(f"{path}.points", "'points' is for sampling sobol, halton, lhs, random or rqmc; "
                                     "a grid takes 'step' or 'points_per_axis'")
        if "step" in ws and "points_per_axis" in ws:
            r.fail(f"{path}.points_per_axis", "give 'step' or 'points_per_axis', not both")
        if "step" in ws:
            step = r.number(ws["step"], f"{path}.step", positive=True) * scale
            if step <= 0:          # a subnormal step that the unit's factor took to zero
                r.fail(f"{path}.step", f"step {show(ws['step'])} is too small to be a grid step")
        elif "points_per_axis" in ws:
            ppa = r.integer(ws["points_per_axis"], f"{path}.points_per_axis", minimum=1, maximum=MAX_POINTS)
        else:
            r.fail(f"{path}.step", "a grid needs 'step' or 'points_per_axis'")
    else:
        for key in ("step", "points_per_axis"):
            if key in ws:
                r.fail(f"{path}.{key}", f"'{key}' is for sampling: grid (or gauss); {sampling} sampling takes 'points'")
        pts = r.integer(r.require(ws, "points", path), f"{path}.points", minimum=1, maximum=MAX_POINTS)
    seed = r.integer(ws.get("seed", 0), f"{path}.seed", minimum=0, maximum=2 ** 32 - 1)
    spec = WorkspaceSpec(type=wtype, axes=axes, sampling=sampling, step=step, points_per_axis=ppa,
                         points=pts, seed=seed, radius=radius, center=center, unit=unit, scramblings=scramblings,
                         tolerance=tolerance, max_points=max_points)
    n = point_count(spec, names)
    if n > MAX_POINTS:
        key = "step" if step is not None else ("points_per_axis" if ppa is not None else "points")
        what = "grid points" if sampling == "grid" else "points"
        r.fail(f"{path}.{key}", f"{key} {show(ws[key])} gives {n:,} {what}; expected at most {MAX_POINTS:,}")
    return spec


def optimizer_section(r: Reader, opt: Any, dvs: dict, indices: dict, mech_cls,
                      run_folder: bool = False) -> OptimizerSpec:
    """The optimizer settings; ``run_folder``: the config of an earlier run,
    whose removed keys (:data:`REMOVED_OPT_KEYS`) are ignored, not refused."""
    path = "optimizer"
    if opt is None:
        return OptimizerSpec(weights={k: 1.0 for k in indices})
    opt = r.mapping(opt, path)
    for key, why in REMOVED_OPT_KEYS.items():
        if key in opt:
            if not run_folder:
                r.fail(f"{path}.{key}", f"this key was removed ({why}); delete it")
            opt = {k: v for k, v in opt.items() if k != key}
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
                r.fail(join(f"{path}.weights", k), f"unknown index{suggest(k, indices)}; expected one of {', '.join(indices)}")
            weights[k] = r.number(v, f"{path}.weights.{k}", nonneg=True)
        left = [k for k in indices if k not in wm]
        if left:
            r.fail(f"{path}.weights", f"no weight for {', '.join(left)}; give every index a weight "
                                      f"(give 0 to leave one out)")
        if sum(weights.values()) <= 0:
            r.fail(f"{path}.weights", "expected at least one positive weight")
    kw["weights"] = weights
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
    if "worst_case" in opt:
        kw["worst_case"] = r.boolean(opt["worst_case"], f"{path}.worst_case")
    if "constraint_margin" in opt:
        x = r.number(opt["constraint_margin"], f"{path}.constraint_margin", nonneg=True)
        if x >= 0.5:
            r.fail(f"{path}.constraint_margin", f"expected a fraction in [0, 0.5), got {x:g}")
        kw["constraint_margin"] = x
    if "prescan" in opt:
        kw["prescan"] = r.integer(opt["prescan"], f"{path}.prescan", minimum=0, maximum=1_000_000)
    if "polish" in opt:
        kw["polish"] = r.integer(opt["polish"], f"{path}.polish", minimum=0, maximum=100)
    if "extremes" in opt and opt["extremes"] is not None:
        em = r.mapping(opt["extremes"], f"{path}.extremes")
        r.only(em, f"{path}.extremes", {"starts", "scan"})
        if "starts" in em:
            kw["extremes_starts"] = r.integer(em["starts"], f"{path}.extremes.starts", minimum=0, maximum=100)
        if "scan" in em:
            kw["extremes_scan"] = r.integer(em["scan"], f"{path}.extremes.scan", minimum=1, maximum=1_000_000)
    if "checkpoint_interval" in opt:
        kw["checkpoint_interval"] = r.number(opt["checkpoint_interval"], f"{path}.checkpoint_interval", nonneg=True)
    return OptimizerSpec(**kw)
