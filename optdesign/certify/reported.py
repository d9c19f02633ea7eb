"""Certificates of every design a run reports (``results.json["certificates"]``).

The designs: ``optimum``; each normalization extreme ``<index>.min`` /
``<index>.max``; each named design (by its name); each Pareto point
``pareto_<algorithm>[i]``.  A design that occurs under several keys is
proved once.  Each entry is the certificate of :func:`.designs.certify_design`
plus ``design`` (its parameters, SI).
"""
from __future__ import annotations

import numpy as np

from .designs import DEFAULT_BUDGET, certify_design, region_of

__all__ = ["reported_designs", "certify_reported", "budget_for", "STATUSES"]

STATUSES = ("certified", "refuted", "unknown", "not_supported")


def reported_designs(results: dict, stages: dict, parameters) -> dict[str, dict]:
    """key -> design parameters (those in ``parameters``) of every reported design."""
    keep = lambda d: {k: float(d[k]) for k in parameters if k in d}  # noqa: E731
    out = {"optimum": keep(results["optimum"])}
    for k, rec in (results.get("normalization") or {}).items():
        for b in ("min", "max"):
            d = rec.get(f"{b}_design")
            if isinstance(d, dict):
                out[f"{k}.{b}"] = keep(d)
    for n, rec in (results.get("designs") or {}).items():
        if isinstance(rec, dict) and isinstance(rec.get("parameters"), dict):
            out[n] = keep(rec["parameters"])
    for name, s in stages.items():
        if isinstance(s, dict) and s.get("kind") == "pareto":
            for i, row in enumerate(s.get("front") or []):
                out[f"{name}[{i}]"] = keep(row)
    return out


def budget_for(dof_free: int, pareto: bool, base: int = DEFAULT_BUDGET) -> int:
    """Box evaluations per design: the whole ``base`` (the config's
    ``checks.certificate_budget``) for W of up to 3 free axes (where a design
    on the singularity constraint at a 0.1 % margin takes about 2e5 boxes);
    a third of it for higher dimensions, and a twentieth of that for each
    Pareto point."""
    b = base if dof_free <= 3 else base // 3
    return b // 20 if pareto else b


def certify_reported(evaluator, results: dict, stages: dict, budget: int | None = None,
                     base: int = DEFAULT_BUDGET) -> dict:
    """``{key: certificate}`` of every reported design (see module doc);
    ``budget`` fixes the box evaluations of every design, else
    :func:`budget_for` scales ``base``."""
    designs = reported_designs(results, stages, evaluator.defaults)
    region = region_of(evaluator.workspace)
    conv = "two_norm"
    if evaluator._cond is not None:
        conv = next(r.convention for r in evaluator.requests_all if r.name == evaluator._cond) or "frobenius"
    free = int(np.sum(region["hi"] > region["lo"]))
    done: dict[tuple, dict] = {}
    out = {}
    for key, d in designs.items():
        full = {**evaluator.defaults, **d}
        sig = tuple(sorted(full.items()))
        is_front = key.endswith("]")
        b = budget if budget is not None else budget_for(free, is_front, base)
        if sig not in done or (done[sig]["status"] == "unknown" and done[sig]["boxes"] < b):
            mech = evaluator.mechanism(**{**evaluator.fixed, **full})
            done[sig] = certify_design(mech, region, evaluator.threshold, conv, evaluator.stroke_limits, budget=b)
        out[key] = {k: v for k, v in done[sig].items() if k != "seconds"}   # results.json stays reproducible
        out[key]["design"] = d
        if out[key].get("witness") is not None:
            out[key]["axes"] = list(evaluator.workspace.names)
    return out


def status_counts(certificates: dict) -> dict[str, int]:
    counts = {s: 0 for s in STATUSES}
    for c in certificates.values():
        counts[c["status"]] = counts.get(c["status"], 0) + 1
    return counts
