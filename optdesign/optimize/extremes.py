"""The normalization extremes by a deterministic multi-start (no seed).

The extremes of eq. 38-40 (each weighted index's smallest and largest value
over the feasible designs of the box) scale every normalized objective, so
they must not depend on the run's seed.  This stage finds them without one:

1. a fixed scan of the design box: ``optimizer.extremes.scan`` points of a
   Sobol sequence scrambled with the fixed seed 0 (the same points for every
   run seed), with the box's corners and centre added when there are at most
   a quarter as many corners as scan points;
2. for each weighted index and each sense, the ``optimizer.extremes.starts``
   best feasible scan designs at least 0.05 apart in the unit box;
3. each start polished by the project's SLSQP polish (:mod:`.polish`) under
   the Evaluator's constraints, every result checked by the Evaluator;
4. a second round around each extreme's best polished design: a fixed
   Sobol cloud of :data:`LOCAL_SCAN` designs within :data:`LOCAL_WIDTH` (unit
   box) of it, its :data:`LOCAL_STARTS` best feasible designs polished;
5. each polished design snapped onto the bounds it lies within :data:`SNAP`
   (unit box) of, and the snapped design taken when it is feasible and no
   worse (to :data:`SNAP_LOSS` relative): a design on its active bounds lies exactly on them;
6. where SLSQP left the best design short of a first-order point (on a
   singularity wall next to a reach boundary it stalls), the walk of
   :mod:`.wall` from it, at most ``optimizer.extremes.walk`` steps.

The stage's ``observed`` extremes (the best of the scan and of the polished
designs) are folded with the pre-scan's and the single-objective stages'
(:mod:`.normalization`).  The multi-start is part of the polish: with
``optimizer.polish: 0`` (or ``optimizer.extremes.starts: 0``) it does not run.
"""
from __future__ import annotations

import math

import numpy as np

from .polish import TOLERANCE, distinct_best, optimality, polish_designs, term_value
from .problem import DesignProblem, index_term
from .prescan import evaluate_batches, sobol
from .refine import observed
from .wall import walk_design

__all__ = ["scan_size", "extremes_scan", "run_extremes", "snap", "evaluate_batches", "SNAP"]

#: a coordinate this close to a bound (unit box) is put on it
SNAP = 1e-6
#: a snapped design is taken when its objective is at most this much worse (relative)
SNAP_LOSS = 1e-9
#: the local scan around an extreme's best polished design: its half-width
#: (unit box), its designs and the starts polished from it
LOCAL_WIDTH, LOCAL_SCAN, LOCAL_STARTS = 0.05, 256, 2
#: most steps of the walk along the singularity wall (:mod:`.wall`), ``optimizer.extremes.walk``'s default
WALK_ITERATIONS = 300


def scan_size(n: int) -> int:
    """Sobol designs of a scan of ``n``: the power of two at or above it."""
    return 2 ** max(0, math.ceil(math.log2(max(n, 1))))


def extremes_scan(xl: np.ndarray, xu: np.ndarray, n: int) -> np.ndarray:
    """The seed-free scan (m, n_var): 2^ceil(log2 n) Sobol points scrambled
    with seed 0, then the box's corners and centre when 4 x 2^n_var <= that."""
    d = len(xl)
    m = max(0, math.ceil(math.log2(max(n, 1))))
    U = sobol(d, m, 0)
    if 4 * 2 ** d <= 2 ** m:
        corners = np.array(np.meshgrid(*[[0.0, 1.0]] * d, indexing="ij")).reshape(d, -1).T
        U = np.concatenate([U, corners, np.full((1, d), 0.5)])
    return xl + (xu - xl) * U


def snap(x: np.ndarray, xl: np.ndarray, xu: np.ndarray, tol: float = SNAP) -> np.ndarray:
    """x with every coordinate within ``tol`` (unit box) of a bound put on it."""
    w = xu - xl
    u = (np.asarray(x, dtype=float) - xl) / w
    return np.where(u <= tol, xl, np.where(u >= 1.0 - tol, xu, x))


def _polished(evaluator, term, starts: np.ndarray) -> tuple[list, list]:
    """(designs, runs): each start's polished end and its snapped version
    when that is feasible and no worse (both checked by the Evaluator)."""
    problem = DesignProblem(evaluator, [term])
    got = polish_designs(problem, starts, join=False)
    ends = [np.asarray(r["end"], dtype=float) for r in got["runs"]]
    if not ends:
        return [], got["runs"]
    E = np.array(ends)
    S = np.array([snap(x, evaluator.xl, evaluator.xu) for x in E])
    vals, _, feas = evaluate_batches(evaluator, np.concatenate([E, S]))
    f = np.asarray(term_value(term, vals), dtype=float)
    n = len(E)
    out = []
    for j in range(n):
        fe, fs = f[j], f[n + j]
        take = feas[n + j] and fs <= fe + SNAP_LOSS * max(abs(fe), 1e-300)
        out.append(S[j] if take else E[j])
        got["runs"][j]["snapped"] = bool(take and not np.array_equal(S[j], E[j]))
    return out, got["runs"]


def _best(evaluator, term, ends: list):
    """(design, value) of the best feasible of ``ends`` by ``term``, or None."""
    if not ends:
        return None
    E = np.array(ends)
    vals, _, feas = evaluate_batches(evaluator, E)
    f = np.where(feas, np.asarray(term_value(term, vals), dtype=float), np.inf)
    if not np.isfinite(f).any():
        return None
    return E[int(np.argmin(f))], float(np.min(f))


def _local_round(evaluator, term, ends: list) -> tuple[list, list]:
    """A second round around the best of ``ends``: a fixed Sobol cloud (seed 0)
    in the box of half-width :data:`LOCAL_WIDTH` (unit box) around it, its
    :data:`LOCAL_STARTS` best feasible designs polished.  The feasible set
    near the singularity constraint is broken into narrow pockets; the next
    pocket is often a little better."""
    best = _best(evaluator, term, ends)
    if best is None:
        return [], []
    xl, w = evaluator.xl, evaluator.xu - evaluator.xl
    c = (best[0] - xl) / w
    U = sobol(len(c), int(math.log2(LOCAL_SCAN)), 0)
    U = np.clip(c + LOCAL_WIDTH * (2.0 * U - 1.0), 0.0, 1.0)
    X = xl + w * U
    v, _, ok = evaluate_batches(evaluator, X)
    g = np.where(ok, np.asarray(term_value(term, v), dtype=float), np.inf)
    S = distinct_best(X, g, LOCAL_STARTS, 0.01, evaluator.xl, evaluator.xu)
    return _polished(evaluator, term, S) if len(S) else ([], [])


def _walked(evaluator, term, ends: list, steps: int) -> tuple[list, list]:
    """The walk along the singularity wall (:mod:`.wall`) from the best of
    ``ends`` when SLSQP left it short of a first-order point (its KKT
    residual above :data:`~.polish.TOLERANCE`, or not measurable): the walk's
    end when it is better."""
    best = _best(evaluator, term, ends) if steps > 0 else None
    if best is None:
        return [], []
    x0, f0 = best
    problem = DesignProblem(evaluator, [term])
    opt = optimality(problem, x0, evaluator.free)
    if opt["measurable"] and opt["converged"]:
        return [], []
    got = walk_design(problem, x0, steps)
    run = {"start": x0.tolist(), "start_value": f0, "snapped": False, "message": "wall walk", **got}
    return ([np.asarray(got["end"])] if got["end_value"] < f0 else []), [run]


def run_extremes(evaluator, names, starts: int, n: int, on_batch=None, walk: int = WALK_ITERATIONS) -> dict:
    """The stage result: the scan's size and feasible count, per weighted
    index and sense the polish runs, and ``observed`` (the extremes of every
    index over the scan and the polished designs)."""
    X = extremes_scan(evaluator.xl, evaluator.xu, n)
    vals, _, feas = evaluate_batches(evaluator, X, on_batch)
    Xf = X[feas]
    vf = {k: v[feas] for k, v in vals.items()}
    found, labels, runs = [], [], {}
    for k in names:
        for sense in ("min", "max"):
            term = index_term(k, sense)
            with np.errstate(all="ignore"):
                S = distinct_best(Xf, np.asarray(term_value(term, vf), dtype=float), starts, 0.05,
                                  evaluator.xl, evaluator.xu)
            if not len(S):
                continue
            got, rec = _polished(evaluator, term, S)
            more, rec2 = _local_round(evaluator, term, got)
            got, rec = got + more, rec + rec2
            more, rec2 = _walked(evaluator, term, got, walk)
            got, rec = got + more, rec + rec2
            found += got
            labels += ["multistart"] * len(got)
            runs[f"{k}.{sense}"] = [{"start": r["start"], "end": r["end"], "start_value": r["start_value"],
                                     "end_value": r["end_value"], "iterations": r["iterations"],
                                     "evaluations": r["evaluations"],
                                     "snapped": r.get("snapped", False), "message": r["message"]} for r in rec]
    P = np.array(found).reshape(-1, X.shape[1])
    pv, _, pf = evaluate_batches(evaluator, P)
    # the polished designs first: of equal values the first wins
    XA = np.concatenate([P[pf], Xf])
    VA = {k: np.concatenate([pv[k][pf], vf[k]]) for k in evaluator.index_names}
    lab = [lb for lb, ok in zip(labels, pf) if ok] + ["extremes scan"] * len(Xf)
    obs = observed(evaluator, XA, VA, lab) if len(XA) else {}
    return {"stage": "extremes", "kind": "extremes", "evaluations": int(len(X) + 3 * len(P) + LOCAL_SCAN * len(runs)
                                                         + sum(r["evaluations"] for v in runs.values() for r in v)),
            "scan": int(len(X)), "feasible_designs": int(feas.sum()), "starts": int(starts),
            "runs": runs, "observed": obs}
