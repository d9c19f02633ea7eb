"""What a stage adds after its GA: the polish of its best designs and the
extreme index values it has seen (for the normalization).

* :func:`refine_single` -- a single-objective stage (an index's minimum or
  maximum, a weighted sum): SLSQP from several distinct starts (the GA's
  best designs and the stage's seeds), the best polished design if it is
  feasible and no worse than the GA's (snapped onto the bounds it lies
  within 1e-6 of, unit box, when that stays feasible and no worse than
  1e-9 relative), and the optimality measure there;
* :func:`refine_front` -- a Pareto stage: every front design polished by the
  Pascoletti-Serafini scalarization (it can only move towards designs that
  dominate it), then the non-dominated ones kept;
* :func:`observed` -- the smallest and largest value of every index among a
  stage's feasible designs, with the design and how it was found.
"""
from __future__ import annotations

import numpy as np
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

from .polish import distinct_best, optimality, polish_designs, polish_front_point

__all__ = ["refine_single", "refine_front", "observed", "merge_observed", "front_population", "non_dominated",
           "front_seeds"]


def non_dominated(F: np.ndarray, by: np.ndarray | None = None) -> np.ndarray:
    """Indices (sorted) of the rows of F (k, m) that no other row of F and no
    row of ``by`` (j, m) dominates (<= in every objective, < in one)."""
    F = np.asarray(F, dtype=float)
    keep = np.sort(np.asarray(NonDominatedSorting().do(F, only_non_dominated_front=True), dtype=int)) \
        if len(F) else np.zeros(0, dtype=int)
    if by is not None and len(by) and len(keep):
        B = np.asarray(by, dtype=float)
        dom = np.array([np.any(np.all(B <= f, axis=1) & np.any(B < f, axis=1)) for f in F[keep]])
        keep = keep[~dom]
    return keep


def front_seeds(problem, X, k: int) -> np.ndarray | None:
    """At most ``k`` feasible non-dominated designs among X (the pre-scan's) for
    a multi-objective ``problem``, spread evenly along the first objective:
    the designs a Pareto stage's first population starts with (None: none)."""
    if X is None or not len(X) or k <= 0:
        return None
    X = np.asarray(X, dtype=float)
    out: dict = {}
    problem._evaluate(X, out)
    ok = np.all(out["G"] <= 0, axis=1)
    if not ok.any():
        return None
    X, F = X[ok], out["F"][ok]
    nd = non_dominated(F)
    nd = nd[np.lexsort((np.arange(len(nd)), F[nd, 0]))]
    if len(nd) > k:
        nd = nd[np.unique(np.round(np.linspace(0, len(nd) - 1, k)).astype(int))]
    return X[nd]


def front_population(algorithm):
    """The feasible non-dominated designs of a multi-objective stage: its final
    population's with its ``opt`` (NSGA-III's ``opt`` keeps one design per
    reference direction that has one, fewer than its non-dominated designs)."""
    pop = algorithm.pop
    if algorithm.opt is not None and len(algorithm.opt):
        from pymoo.core.population import Population

        pop = Population.merge(algorithm.opt, pop)
    pop = pop[pop.get("CV")[:, 0] <= 0]
    if not len(pop):
        return pop
    X, F = pop.get("X", "F")
    keep = non_dominated(F)
    _, first = np.unique(X[keep], axis=0, return_index=True)
    return pop[keep[np.sort(first)]]


def refine_single(problem, algorithm, seeds: np.ndarray, starts: int, maxiter: int = 50) -> dict:
    """The polish of a finished single-objective stage: ``x`` and ``value``
    (the stage's answer: the polished design, or the GA's when the polish
    did not improve it), ``found_by`` (``polish`` or ``ga``) and the record
    written to result.json."""
    ev = problem.evaluate_designs
    best = algorithm.opt[0]
    x_ga, f_ga = np.asarray(best.X, dtype=float), float(best.F[0])
    if starts <= 0 or best.CV[0] > 0:
        return {"x": x_ga, "value": f_ga, "found_by": "ga", "record": None}
    pop = algorithm.pop
    X, F, CV = pop.get("X", "F", "CV")
    ok = CV[:, 0] <= 0
    cand = np.concatenate([x_ga[None], X[ok], np.asarray(seeds, dtype=float).reshape(-1, len(x_ga))])
    fc = np.concatenate([[f_ga], F[ok, 0], problem.objectives(ev(cand[1 + ok.sum():])["values"])[:, 0]
                         if len(seeds) else np.zeros(0)])
    start = distinct_best(cand, fc, starts, 0.05, ev.xl, ev.xu)
    res = polish_designs(problem, start, maxiter)
    x, f, by = x_ga, f_ga, "ga"
    if res["best"] is not None and res["best"][1] < f_ga:
        x, f, by = res["best"][0], res["best"][1], "polish"
        x, f = _snapped_single(problem, x, f)
    rec = {"starts": len(start), "ga_objective": f_ga, "objective": f, "improvement": f_ga - f,
           "relative_improvement": (f_ga - f) / abs(f_ga) if f_ga != 0 else 0.0, "route": res["route"],
           "route_reason": res["route_reason"], "derivative_evaluations": res["evaluations"], "runs": res["runs"],
           "optimality": optimality(problem, x, ev.free)}
    return {"x": x, "value": f, "found_by": by, "record": rec}


def refine_front(problem, X: np.ndarray, F: np.ndarray, maxiter: int = 20, reference=None):
    """(X, F, record): the front designs (X (k, n), objectives F (k, m))
    polished one by one (direction r: the front's range per objective, or
    1e-3 max(|F|, 1) where it has none), each snapped onto the bounds it lies
    within :data:`.extremes.SNAP` of when that is feasible and dominates or
    equals it, then filtered: a point dominated by another polished point or
    by a row of ``reference`` (objectives of other feasible designs, the
    pre-scan's) is dropped."""
    if len(X) == 0:
        return X, F, {"points": 0, "improved": 0}
    span = F.max(axis=0) - F.min(axis=0)
    r = np.where(span > 0, span, 1e-3 * np.maximum(np.abs(F).max(axis=0), 1.0))
    Xs, Fs, ts, calls = [], [], [], 0
    for x0 in X:
        x, f, t, c = polish_front_point(problem, np.asarray(x0, dtype=float), r, maxiter)
        x, f = _snapped_point(problem, x, f)
        Xs.append(x)
        Fs.append(f)
        ts.append(t)
        calls += c
    Xs, Fs = np.array(Xs), np.array(Fs)
    keep = non_dominated(Fs, reference)
    # equal designs (two points polished onto one) are kept once
    _, first = np.unique(np.round(Xs[keep], 12), axis=0, return_index=True)
    keep = keep[np.sort(first)]
    ts = np.array(ts)
    rec = {"points": int(len(X)), "improved": int(np.sum(ts < 0)), "kept": int(len(keep)),
           "median_improvement": float(np.median(-ts)), "max_improvement": float(np.max(-ts)),
           "direction": r.tolist(), "derivative_evaluations": int(calls)}
    return Xs[keep], Fs[keep], rec


def _snapped_single(problem, x, f: float):
    """(x, f) snapped onto the bounds within SNAP when the snapped design is
    feasible and at most SNAP_LOSS (relative) worse."""
    from .extremes import SNAP_LOSS, snap

    ev = problem.evaluate_designs
    xs = snap(x, ev.xl, ev.xu)
    if np.array_equal(xs, x):
        return x, f
    out: dict = {}
    problem._evaluate(xs[None, :], out)
    fs = float(out["F"][0, 0])
    if np.all(out["G"][0] <= 0) and fs <= f + SNAP_LOSS * max(abs(f), 1e-300):
        return xs, fs
    return x, f


def _snapped_point(problem, x, f):
    """(x, F) snapped onto the bounds within SNAP when the Evaluator finds the
    snapped design feasible and no worse in any objective (to SNAP_LOSS relative)."""
    from .extremes import SNAP_LOSS, snap

    ev = problem.evaluate_designs
    xs = snap(x, ev.xl, ev.xu)
    if np.array_equal(xs, x):
        return x, f
    out: dict = {}
    problem._evaluate(xs[None, :], out)
    fs = out["F"][0]
    if np.all(out["G"][0] <= 0) and np.all(fs <= f + SNAP_LOSS * np.maximum(np.abs(f), 1e-300)):
        return xs, fs
    return x, f


def observed(evaluator, X: np.ndarray, values: dict, found_by) -> dict:
    """``{index: {"min": {value, design, found_by}, "max": {...}}}`` over
    feasible designs X (k, n) with their index values (k,) and a found_by
    label per design (or one for all); the first of equal values wins."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    labels = [found_by] * len(X) if isinstance(found_by, str) else list(found_by)
    out = {}
    if len(X) == 0:
        return out
    for k in evaluator.index_names:
        v = np.asarray(values[k], dtype=float)
        good = np.isfinite(v)
        if not good.any():
            continue
        rec = {}
        for sense, pick in (("min", np.argmin), ("max", np.argmax)):
            i = int(pick(np.where(good, v, np.inf if sense == "min" else -np.inf)))
            design = {n: float(x) for n, x in zip(evaluator.free, X[i])}
            rec[sense] = {"value": float(v[i]), "design": design, "found_by": labels[i]}
        out[k] = rec
    return out


def merge_observed(ext: dict, obs: dict, stage: str, relabel: str | None = None) -> list[tuple]:
    """Fold one stage's observed extremes into ``ext`` (index -> sense ->
    record with ``stage``); a value replaces the recorded one only if it is
    strictly beyond it.  ``relabel`` replaces found_by (``later stage``).
    Returns the (index, sense, old, new) that changed."""
    changed = []
    for k, rec in obs.items():
        for sense in ("min", "max"):
            new = rec.get(sense)
            if new is None:
                continue
            cur = ext.setdefault(k, {}).get(sense)
            if cur is None or (new["value"] < cur["value"] if sense == "min" else new["value"] > cur["value"]):
                ext[k][sense] = {**new, "stage": stage, **({"found_by": relabel} if relabel else {})}
                changed.append((k, sense, None if cur is None else cur["value"], new["value"]))
    return changed
