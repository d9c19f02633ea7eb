"""The integral over W of every global index of the designs a run reports
(``results.json["integrals"]``), beside the config's own quadrature.

A fixed rule (the paper's 11 x 11 grid) reproduces the paper's numbers, but
its mean is not the integral of eq. 29, and a design singular between its
points gets a finite mean there.  For the optimum, each named design and each
normalization extreme, the integral by adaptive cubature to a relative
tolerance (the config's ``checks.integral_tolerance``, 1e-4 by default;
:mod:`optdesign.cubature`) is recorded beside the config's
mean and its error estimate; an index whose integrand is unbounded on W is
recorded ``unbounded``, never as a finite mean.  A config whose sampling is
already adaptive gets no second record (its global indices are the integrals).
"""
from __future__ import annotations

import dataclasses
import math

from ..evaluate import Evaluator, error_method
from ..units import Units, pose_display
from ..workspace import Workspace, sample

__all__ = ["integrals_of_reported", "adaptive_workspace", "integral_records"]


def adaptive_workspace(workspace: Workspace, tolerance: float, max_points: int) -> Workspace:
    """The region W of ``workspace`` with ``sampling: adaptive`` at ``tolerance`` (relative) and ``max_points``."""
    spec = dataclasses.replace(workspace.spec, sampling="adaptive", step=None, points_per_axis=None, points=None,
                               tolerance=float(tolerance), max_points=int(max_points))
    return sample(spec, workspace.names)


def integral_records(evaluator: Evaluator, designs, tolerance: float, max_points: int) -> list[dict]:
    """For each design (full parameter mappings, SI), every index's integral
    mean over W by adaptive cubature, one design at a time (a singular design
    spends its own budget): ``{index: {"mean", "error", "status", "max"},
    "reachable_fraction", "points"}``; an ``unbounded`` index has mean and
    error None (JSON null), never a finite mean."""
    ws = adaptive_workspace(evaluator.workspace, tolerance, max_points)
    out = []
    for d in designs:
        ev = evaluator.model.evaluate([d], ws)
        rec = {}
        for k in evaluator.index_names:
            st = str(ev.status[k][0])
            finite = st in ("converged", "not_converged")
            m, e = float(ev.summary[k]["mean"][0]), float(ev.error[k][0])
            rec[k] = {"mean": m if finite and math.isfinite(m) else None,
                      "error": e if finite and math.isfinite(e) else None,
                      "status": st, "max": float(ev.summary[k]["max"][0])}
        rec["reachable_fraction"] = float(ev.reachable_fraction[0])
        rec["points"] = int(ev.summary[evaluator.index_names[0]]["count"][0])
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


def integrals_of_reported(checks, evaluator: Evaluator, units: Units, results: dict) -> dict | None:
    """``{"method", "tolerance", "max_points", "quadrature", "quadrature_error_method", "designs": {key: {"design",
    "quadrature": {index: {"mean", "error"}}, "integral": {index: {"mean", "error", "status", "max"}},
    "reachable_fraction", "points"}}}`` of the designs ``results`` reports, over the evaluator's workspace;
    None when its sampling is adaptive.  ``checks``: the tolerance and node budget (the config's
    ``checks`` section); ``units``: how the quadrature's axes are named."""
    tol, cap = checks.integral_tolerance, checks.integral_max_points
    ws = evaluator.workspace
    if ws.spec.sampling == "adaptive" or tol == 0:
        return None
    designs = _designs(results, evaluator.defaults)
    full = [{**evaluator.defaults, **d} for d in designs.values()]
    ev = evaluator.model.evaluate(full, ws)
    recs = integral_records(evaluator, full, tol, cap)
    out = {}
    for j, (key, d) in enumerate(designs.items()):
        rec = recs[j]
        out[key] = {"design": d,
                    "quadrature": {k: {"mean": float(ev.summary[k]["mean"][j]), "error": float(ev.error[k][j])}
                                   for k in evaluator.index_names},
                    "integral": {k: rec[k] for k in evaluator.index_names},
                    "reachable_fraction": rec["reachable_fraction"], "points": rec["points"]}
    return {"method": error_method(adaptive_workspace(ws, tol, cap)), "tolerance": tol,
            "max_points": cap, "quadrature": ws.describe({a: pose_display(units, a) for a in ws.names}),
            "quadrature_error_method": error_method(ws),
            "designs": out}
