"""The integral over W of every global index of the designs a run reports
(``results.json["integrals"]``), beside the config's own quadrature.

A fixed rule (the paper's 11 x 11 grid) reproduces the paper's numbers, but
its mean is not the integral of eq. 29, and a design singular between its
points gets a finite mean there.  For the optimum, each named design and each
normalization extreme, the integral by adaptive cubature to a relative
tolerance (the config's ``checks.integral_tolerance``, default
``TOLERANCE``; :mod:`optdesign.cubature`) is recorded beside the config's
mean and its error estimate; an index whose integrand is unbounded on W is
recorded ``unbounded``, never as a finite mean.  A config whose sampling is
already adaptive gets no second record (its global indices are the integrals).
"""
from __future__ import annotations

import dataclasses
import math

from ..config.checks import ChecksSpec
from ..evaluate import error_method, evaluate, mechanism_class
from ..workspace import sample

__all__ = ["integrals_of_reported", "TOLERANCE", "MAX_POINTS",
           "adaptive_workspace", "integral_records"]

#: relative tolerance and node budget (per design) of the recorded integrals
TOLERANCE, MAX_POINTS = ChecksSpec.integral_tolerance, ChecksSpec.integral_max_points


def adaptive_workspace(config, tolerance: float, max_points: int):
    """The config's region W with ``sampling: adaptive`` at ``tolerance`` (relative) and ``max_points``."""
    spec = dataclasses.replace(config.workspace, sampling="adaptive", step=None, points_per_axis=None, points=None,
                               tolerance=float(tolerance), max_points=int(max_points))
    return sample(spec, mechanism_class(config).pose_names)


def integral_records(config, designs, tolerance: float, max_points: int) -> list[dict]:
    """For each design (full parameter mappings, SI), every index's integral
    mean over W by adaptive cubature, one design at a time (a singular design
    spends its own budget): ``{index: {"mean", "error", "status", "max"},
    "reachable_fraction", "points"}``; an ``unbounded`` index has mean and
    error None (JSON null), never a finite mean."""
    ws = adaptive_workspace(config, tolerance, max_points)
    out = []
    for d in designs:
        ev = evaluate(config, [d], ws)
        rec = {}
        for k in config.indices:
            st = str(ev.status[k][0])
            finite = st in ("converged", "not_converged")
            m, e = float(ev.summary[k]["mean"][0]), float(ev.error[k][0])
            rec[k] = {"mean": m if finite and math.isfinite(m) else None,
                      "error": e if finite and math.isfinite(e) else None,
                      "status": st, "max": float(ev.summary[k]["max"][0])}
        rec["reachable_fraction"] = float(ev.reachable_fraction[0])
        rec["points"] = int(ev.summary[next(iter(config.indices))]["count"][0])
        out.append(rec)
    return out


def _designs(results: dict, parameters) -> dict[str, dict]:
    keep = lambda d: {k: float(d[k]) for k in parameters if k in d}  # noqa: E731
    out = {"optimum": keep(results["optimum"])}
    for n, rec in (results.get("designs") or {}).items():
        out[n] = keep(rec["parameters"])
    for k, rec in (results.get("normalization") or {}).items():
        for b in ("min", "max"):
            d = rec.get(f"{b}_design")
            if isinstance(d, dict):
                out[f"{k}.{b}"] = keep(d)
    return out


def integrals_of_reported(cfg, results: dict, ws) -> dict | None:
    """``{"method", "tolerance", "max_points", "quadrature", "quadrature_error_method", "designs": {key: {"design",
    "quadrature": {index: {"mean", "error"}}, "integral": {index: {"mean", "error", "status", "max"}},
    "reachable_fraction", "points"}}}``; None when the config's sampling is adaptive."""
    from ..units import pose_display

    tol, cap = cfg.checks.integral_tolerance, cfg.checks.integral_max_points
    if ws.spec.sampling == "adaptive" or tol == 0:
        return None
    designs = _designs(results, {k: dv.value for k, dv in cfg.design_variables.items()})
    full = [{**{k: dv.value for k, dv in cfg.design_variables.items()}, **d} for d in designs.values()]
    ev = evaluate(cfg, full, ws)
    recs = integral_records(cfg, full, tol, cap)
    out = {}
    for j, (key, d) in enumerate(designs.items()):
        rec = recs[j]
        out[key] = {"design": d,
                    "quadrature": {k: {"mean": float(ev.summary[k]["mean"][j]), "error": float(ev.error[k][j])}
                                   for k in cfg.indices},
                    "integral": {k: rec[k] for k in cfg.indices},
                    "reachable_fraction": rec["reachable_fraction"], "points": rec["points"]}
    return {"method": error_method(adaptive_workspace(cfg, tol, cap)), "tolerance": tol,
            "max_points": cap, "quadrature": ws.describe({a: pose_display(cfg, a) for a in ws.names}), "quadrature_error_method": error_method(ws),
            "designs": out}
