"""Parsing of the config's workspace and optimizer sections (see :mod:`.loader`)."""
from __future__ import annotations

from typing import Any

from ..workspace import MAX_POINTS, WorkspaceSpec, point_count
from .keys import OPTIMIZER, WORKSPACE
from .reader import UNITS, Reader, join, show, suggest, tname
from .schema import OptimizerSpec

__all__ = ["OPT_KEYS", "REMOVED_OPT_KEYS", "SAMPLING", "WS_KEYS", "optimizer_section", "workspace_section"]

WS_KEYS = WORKSPACE.allowed()
SAMPLING = set(WORKSPACE["sampling"].check.values)
#: adaptive sampling: the default relative tolerance and node budget
ADAPTIVE_TOLERANCE, ADAPTIVE_MAX_POINTS = WORKSPACE["tolerance"].default, WORKSPACE["max_points"].default
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
OPT_KEYS = OPTIMIZER.allowed()
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
    wtype = WORKSPACE["type"].read(r, ws.get("type", WORKSPACE["type"].default), f"{path}.type")
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
        radius = WORKSPACE["radius"].read(r, r.require(ws, "radius", path), f"{path}.radius") * scale
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
    sampling = WORKSPACE["sampling"].read(r, ws.get("sampling", WORKSPACE["sampling"].default), f"{path}.sampling")
    for key, why in _NOT_FOR.get(sampling, {}).items():
        if key in ws:
            r.fail(f"{path}.{key}", f"not used by sampling '{sampling}' ({why}); remove it")
    if "scramblings" in ws and sampling != "rqmc":
        r.fail(f"{path}.scramblings", f"only sampling 'rqmc' takes scramblings, not '{sampling}'")
    for key in ("tolerance", "max_points"):
        if key in ws and sampling != "adaptive":
            r.fail(f"{path}.{key}", f"only sampling 'adaptive' takes {key}, not '{sampling}'")
    step = ppa = pts = None
    scramblings = WORKSPACE["scramblings"].default
    tolerance, max_points = None, ADAPTIVE_MAX_POINTS
    free = sum(1 for lo, hi in axes.values() if hi > lo)
    if sampling == "gauss":
        ppa = r.integer(r.require(ws, "points_per_axis", path), f"{path}.points_per_axis", minimum=2, maximum=10_000)
        total = (2 * ppa ** (free + 2)) if wtype == "cylinder" else ppa ** free
        if total > MAX_POINTS:
            r.fail(f"{path}.points_per_axis", f"{ppa} nodes per axis give {show(total)} points; expected at most {MAX_POINTS:,}")
    elif sampling == "adaptive":
        tolerance = WORKSPACE["tolerance"].read(r, ws.get("tolerance", ADAPTIVE_TOLERANCE), f"{path}.tolerance")
        max_points = WORKSPACE["max_points"].read(r, ws.get("max_points", ADAPTIVE_MAX_POINTS), f"{path}.max_points")
    elif sampling == "rqmc":
        pts = r.integer(r.require(ws, "points", path), f"{path}.points", minimum=2, maximum=MAX_POINTS)
        if pts & (pts - 1):
            lo2 = 1 << (pts.bit_length() - 1)
            r.fail(f"{path}.points", f"expected a power of 2 (a Sobol set is balanced in blocks of 2^m), "
                                     f"got {pts}; use {lo2} or {2 * lo2}")
        if "scramblings" in ws:
            scramblings = WORKSPACE["scramblings"].read(r, ws["scramblings"], f"{path}.scramblings")
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
            step = WORKSPACE["step"].read(r, ws["step"], f"{path}.step") * scale
            if step <= 0:          # a subnormal step that the unit's factor took to zero
                r.fail(f"{path}.step", f"step {show(ws['step'])} is too small to be a grid step")
        elif "points_per_axis" in ws:
            ppa = WORKSPACE["points_per_axis"].read(r, ws["points_per_axis"], f"{path}.points_per_axis")
        else:
            r.fail(f"{path}.step", "a grid needs 'step' or 'points_per_axis'")
    else:
        for key in ("step", "points_per_axis"):
            if key in ws:
                r.fail(f"{path}.{key}", f"'{key}' is for sampling: grid (or gauss); {sampling} sampling takes 'points'")
        pts = WORKSPACE["points"].read(r, r.require(ws, "points", path), f"{path}.points")
    seed = WORKSPACE["seed"].read(r, ws.get("seed", WORKSPACE["seed"].default), f"{path}.seed")
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
    """The optimizer settings (the keys of :data:`.keys.OPTIMIZER`); ``run_folder``:
    the config of an earlier run, whose removed keys (:data:`REMOVED_OPT_KEYS`)
    are ignored, not refused."""
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
    kw: dict[str, Any] = OPTIMIZER.read(r, opt, path)
    population = kw.get("population", OPTIMIZER["population"].default)
    if "elites" in kw and kw["elites"] >= population:
        r.fail(f"{path}.elites", f"expected fewer elites than the population ({population}), got {kw['elites']}")
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
    for sub in ("pareto", "extremes"):       # sub-mappings; null is the same as absent
        if opt.get(sub) is not None:
            m = r.mapping(opt[sub], f"{path}.{sub}")
            r.only(m, f"{path}.{sub}", OPTIMIZER.allowed(sub))
            kw.update(OPTIMIZER.read(r, m, f"{path}.{sub}", level=sub))
    if "constraint_singularity" in opt:
        key = f"{path}.constraint_singularity"
        kw["constraint_singularity"] = OPTIMIZER["constraint_singularity"].read(r, opt["constraint_singularity"], key)
        if "constraint" not in mech_cls.supported_indices:
            r.fail(key, "the constraint-singularity value is a chain mechanism's (docs/lower-mobility.md); "
                        f"mechanism {mech_cls.name!r} has no chain legs")
    if "extra_objectives" in opt:
        kw["extra_objectives"] = OPTIMIZER["extra_objectives"].read(r, opt["extra_objectives"], f"{path}.extra_objectives",
                                                                    choices=set(mech_cls.extra_objectives))
    return OptimizerSpec(**kw)
