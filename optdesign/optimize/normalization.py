"""The extremes that normalize the weighted sum (eq. 38-40), and their record.

Every stage reports the smallest and largest value of each index among its
feasible designs (``observed`` in its result.json, see :mod:`.refine`).  The
extremes are folded in the plan's order (so they do not depend on ``jobs``):
the pre-scan, then the single-objective stages (their GA and their polish)
and the seed-free multi-start (:mod:`.extremes`) --
these give the extremes the weighted sums are run with -- then every later
stage (weighted sums, Pareto fronts), whose values beyond a recorded extreme
update it (``found_by: later stage``), and last the config's named designs
that lie in the box and are feasible (``found_by: named design``).  A value
replaces a recorded extreme only if it is strictly beyond it.

With the final extremes every normalized term (sigma - min) / (max - min)
of a feasible design of the box lies in [0, 1], and the weighted sum in
[0, sum of the weights].
"""
from __future__ import annotations

import math

from .refine import merge_observed

__all__ = ["fold_extremes", "bounds_of", "normalization_record", "terms_in_range"]


def fold_extremes(stages: dict, upto_singles: bool = False) -> tuple[dict, list[dict]]:
    """(extremes, changes) from the stage results in plan order: extremes
    ``{index: {min|max: {value, design, found_by, stage}}}``; changes: what
    the stages after the single-objective ones moved (index, bound, from, to,
    stage).  ``upto_singles``: only the pre-scan and the single-objective stages."""
    ext: dict = {}
    changes: list[dict] = []
    for name, res in stages.items():
        kind = res.get("kind")
        if kind in ("prescan", "single", "extremes"):
            merge_observed(ext, res.get("observed") or {}, name)
        elif not upto_singles:
            for k, sense, old, new in merge_observed(ext, res.get("observed") or {}, name, relabel="later stage"):
                changes.append({"index": k, "bound": sense, "from": old, "to": new, "stage": name})
    return ext, changes


def bounds_of(ext: dict, names) -> tuple[dict, dict]:
    """(lo, hi): each named index's recorded minimum and maximum."""
    lo = {k: ext[k]["min"]["value"] for k in names if k in ext and "min" in ext[k]}
    hi = {k: ext[k]["max"]["value"] for k in names if k in ext and "max" in ext[k]}
    return lo, hi


def normalization_record(ext: dict, names, senses: dict, weights: dict, full_design) -> dict:
    """results.json's ``normalization``: per weighted index its ``min`` and
    ``max``, the design where each was found (all parameters, SI), how
    (``prescan``, ``ga``, ``polish``, ``later stage``, ``named design``) and in
    which stage, its sense and weight."""
    out = {}
    for k in names:
        rec = {"min": ext[k]["min"]["value"], "max": ext[k]["max"]["value"], "sense": senses[k], "weight": weights[k]}
        for b in ("min", "max"):
            r = ext[k][b]
            rec[f"{b}_design"] = full_design(r["design"])
            rec[f"{b}_found_by"] = r["found_by"]
            rec[f"{b}_stage"] = r.get("stage", "")
        out[k] = rec
    return out


def terms_in_range(values: dict, lo: dict, hi: dict, tol: float = 1e-12) -> bool:
    """Every index value within [min, max] (to ``tol`` relative): its
    normalized term is then in [0, 1]."""
    for k in lo:
        v = values.get(k)
        if v is None or not math.isfinite(v):
            return False
        span = max(abs(hi[k] - lo[k]), abs(hi[k]), abs(lo[k]), 1e-300)
        if v < lo[k] - tol * span or v > hi[k] + tol * span:
            return False
    return True
