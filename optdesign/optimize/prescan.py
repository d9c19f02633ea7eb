"""The quasi-random pre-scan of the design box, and the seeds it gives.

A scrambled Sobol sequence (scipy.stats.qmc, seeded by the stage seed) of
``optimizer.prescan`` designs (rounded up to a power of two, where the
sequence is balanced), with the box's corners and centre added when there are
few of them (at most an eighth of the scan): many indices are monotone in a
design variable and are best or worst at a corner.  The designs go through
the Evaluator in vectorized batches; the feasible ones (every constraint of
the Evaluator satisfied, every value finite) are kept in the stage's
``result.json`` so that later stages can take their best designs as seeds:
the single-objective GAs and their polish, and the weighted sum once the
extremes are known.
"""
from __future__ import annotations

import math

import numpy as np

from .polish import distinct_best, term_value
from .refine import observed

__all__ = ["prescan_designs", "run_prescan", "best_designs", "distinct_best", "BATCH", "evaluate_batches", "sobol"]

#: designs per Evaluator call
BATCH = 256


def sobol(d: int, m: int, seed: int) -> np.ndarray:
    """2^m points of the unit cube of dimension d: scipy.stats.qmc's scrambled
    Sobol sequence with ``seed`` (imported here, at the first draw: importing
    this module does not load scipy.stats)."""
    from scipy.stats import qmc

    return qmc.Sobol(d=d, scramble=True, seed=seed).random_base2(m)


def prescan_designs(xl: np.ndarray, xu: np.ndarray, n: int, seed: int) -> np.ndarray:
    """The designs of the scan (m, n_var): 2^ceil(log2 n) scrambled Sobol points,
    then the corners and the centre of the box when 2^n_var <= n / 8."""
    d = len(xl)
    m = max(0, math.ceil(math.log2(max(n, 1))))
    U = sobol(d, m, seed)
    if 2 ** d <= (2 ** m) // 8:
        corners = np.array(np.meshgrid(*[[0.0, 1.0]] * d, indexing="ij")).reshape(d, -1).T
        U = np.concatenate([U, corners, np.full((1, d), 0.5)])
    return xl + (xu - xl) * U


def evaluate_batches(evaluator, X: np.ndarray, on_batch=None) -> tuple[dict, dict, np.ndarray]:
    """(values, constraints, feasible) of designs X, in Evaluator batches;
    feasible: every constraint satisfied and every value finite."""
    names = evaluator.index_names + list(evaluator.extra)
    vals = {k: [] for k in names}
    cons = {k: [] for k in evaluator.constraint_names}
    for i in range(0, len(X), BATCH):
        with np.errstate(all="ignore"):
            r = evaluator(X[i:i + BATCH])
        for k in vals:
            vals[k].append(np.asarray(r["values"][k], dtype=float))
        for k in cons:
            cons[k].append(np.asarray(r["constraints"][k], dtype=float))
        if on_batch is not None:
            on_batch(min(i + BATCH, len(X)), len(X))
    vals = {k: np.concatenate(v) if v else np.zeros(0) for k, v in vals.items()}
    cons = {k: np.concatenate(v) if v else np.zeros(0) for k, v in cons.items()}
    feas = np.ones(len(X), dtype=bool)
    for v in cons.values():
        feas &= v <= 0
    for v in vals.values():
        feas &= np.isfinite(v)
    return vals, cons, feas


def run_prescan(evaluator, n: int, seed: int, on_batch=None) -> tuple[dict, list[dict]]:
    """(result, rows): the stage result (the feasible designs and their values)
    and one CSV row per design scanned; ``on_batch(done, total)`` before the
    first batch and after each (the designs evaluated so far: the run's progress)."""
    X = prescan_designs(evaluator.xl, evaluator.xu, n, seed)
    if on_batch is not None:
        on_batch(0, len(X))
    vals, cons, feas = evaluate_batches(evaluator, X, on_batch)
    names = evaluator.free
    rows = []
    for i in range(len(X)):
        r = {k: float(X[i, j]) for j, k in enumerate(names)}
        r.update({k: float(v[i]) for k, v in vals.items()})
        r["feasible"] = int(feas[i])
        r.update({f"g_{k}": float(v[i]) for k, v in cons.items()})
        rows.append(r)
    res = {"stage": "prescan", "kind": "prescan", "evaluations": int(len(X)), "feasible_designs": int(feas.sum()),
           "variables": list(names), "designs": X[feas].tolist(),
           "values": {k: v[feas].tolist() for k, v in vals.items()},
           "observed": observed(evaluator, X[feas], {k: v[feas] for k, v in vals.items()}, "prescan")}
    return res, rows


def best_designs(prescan: dict | None, term, k: int, min_distance: float = 0.05, xl=None, xu=None) -> np.ndarray:
    """Up to ``k`` of the scan's feasible designs best for the objective term
    ``term``, each at least ``min_distance`` (in the unit box) from the ones
    taken before it; (0, n) without a scan."""
    if not prescan or not prescan.get("designs") or k <= 0:
        return np.zeros((0, len(xl) if xl is not None else len((prescan or {}).get("variables", []))))
    X = np.asarray(prescan["designs"], dtype=float)
    if xl is not None and X.shape[1] != len(xl):
        raise ValueError(f"the pre-scan has {X.shape[1]} design variables, the problem {len(xl)}")
    vals = {name: np.asarray(v, dtype=float) for name, v in prescan["values"].items()}
    with np.errstate(all="ignore"):
        f = np.asarray(term_value(term, vals), dtype=float)
    return distinct_best(X, f, k, min_distance, xl, xu)
