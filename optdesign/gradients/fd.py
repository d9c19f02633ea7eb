"""The central-difference route of :mod:`optdesign.gradients` (described
mechanisms, a free parameter the CasADi model does not read).

One evaluation of ``4 n + 1`` designs (steps h and 2h, Richardson-combined,
their difference kept as an error estimate).  With the worst case over W on,
the stencil is evaluated on the samples only: the constraints on maxima
over W take their values from the search at the design itself and their
derivatives from differences of the local quantity at the pose of each
maximum, held (the envelope theorem), so a derivative costs one search per
design, not one per stencil design.

The singularity constraint is given as one row per hill the search climbed
(:func:`optdesign.worstcase.maximize`'s ``hills``), largest first: the first
row is the maximum over W, the others the local maxima elsewhere in W.
Where the maximum moves from one hill to another it has a kink; the rows
stay smooth, so the polish sees every hill before it becomes the largest.
Each row is :func:`smooth_singularity` of cond.
"""
from __future__ import annotations

import numpy as np

from .. import worstcase
from ..evaluate import _COND, Evaluator

__all__ = ["FD_STEP", "ENVELOPE_STEP", "smooth_singularity", "fd_derivatives"]

#: the Evaluator's constraints taken as they are, differenced on the stencil (the strokes' values are
#: replaced by the envelope's with the worst case on; the constraint singularity's stay the samples')
_SAMPLED = ("stroke_low", "stroke_high", "constraint_singularity")
#: central-difference step, relative to the width of the design box
FD_STEP = 2e-6
#: the step of the worst-case constraints' differences at a held pose: no
#: search runs, so the differences can be short (next to a reach boundary
#: the optimum of an index can lie within about 1e-6 of the box from where
#: cond is infinite)
ENVELOPE_STEP = 1e-8


def smooth_singularity(cond, limit: float) -> np.ndarray:
    """The fd route's singularity constraint (``<= 0`` exactly where
    ``cond <= limit``): ``1 - (limit / cond)^2`` from cond = limit / 2 up,
    and below that its continuation linear in log cond (``-3 + 8 log(2 cond
    / limit)``, the same value and slope at limit / 2).  Next to a reach
    boundary, where cond grows like the inverse square root of the distance
    to it, the first form is linear in that distance; far from the limit the
    second grows no faster than log cond.  1 where cond is not finite (or
    no point is reachable), the first form's limit there."""
    c = np.asarray(cond, dtype=float)
    ok = np.isfinite(c) & (c > 0)
    with np.errstate(all="ignore"):
        near = 1.0 - (limit / c) ** 2
        far = -3.0 + 8.0 * np.log(2.0 * c / limit)
        return np.where(ok, np.where(2.0 * c >= limit, near, far), 1.0)


def _singularity(res: dict, limit: float) -> np.ndarray:
    """:func:`smooth_singularity` of an Evaluator result's maximum, 1 where a
    sample is unreachable (the maximum is over the reachable points: past a
    reach boundary it would look small)."""
    return np.where(np.asarray(res["reachable_fraction"]) >= 1.0, smooth_singularity(res["cond_max"], limit), 1.0)


def _stencil(X: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The designs of central differences with steps h and 2h around each row of X: (D (4 n + 1), n)."""
    E = np.diag(h)
    offs = np.concatenate([np.zeros((1, len(h))), E, -E, 2 * E, -2 * E])
    return (X[:, None, :] + offs[None]).reshape(-1, len(h))


def _diff(a, D: int, h: np.ndarray):
    """(value at X, derivative (h and 2h combined, Richardson), error estimate
    |g_h - g_2h| / 3) from the values ``a`` on :func:`_stencil`'s designs."""
    n = len(h)
    a = np.asarray(a, dtype=float).reshape(D, 4 * n + 1)
    g1 = (a[:, 1:n + 1] - a[:, n + 1:2 * n + 1]) / (2 * h)
    g2 = (a[:, 2 * n + 1:3 * n + 1] - a[:, 3 * n + 1:]) / (4 * h)
    return a[:, 0], (4 * g1 - g2) / 3, np.abs(g1 - g2) / 3


def fd_derivatives(evaluator: Evaluator, X: np.ndarray, reason: str = "", values_only: bool = False) -> dict:
    """The fields of :class:`optdesign.gradients.Derivatives` on the fd route
    at the designs X (D, n)."""
    D, n = X.shape
    worst = bool(getattr(evaluator, "worst_case", False)) and hasattr(evaluator, "worst_poses")
    if values_only:
        res = evaluator(X)
        cons = {"singularity": _singularity(res, evaluator.limit)[:, None]}
        cons.update({k: np.asarray(res["constraints"][k], dtype=float)[:, None]
                     for k in _SAMPLED if k in res["constraints"]})
        if worst:
            got = _hill_rows(evaluator, X, res, None)
            if got is not None:
                cons["singularity"] = got[0]
        return {"route": "fd", "values": dict(res["values"]), "grads": {k: np.zeros((D, 0)) for k in res["values"]},
                "constraints": cons, "constraint_grads": {k: np.zeros(v.shape + (0,)) for k, v in cons.items()},
                "reach": np.asarray(res["reachable_fraction"]), "fd_error": {}, "reason": reason}
    h = FD_STEP * (evaluator.xu - evaluator.xl)
    res = evaluator(_stencil(X, h), worst_case=False) if worst else evaluator(_stencil(X, h))
    values, grads, err, cons, cgrads = {}, {}, {}, {}, {}
    for k, v in res["values"].items():
        values[k], grads[k], err[k] = _diff(v, D, h)
    rows = {"singularity": _singularity(res, evaluator.limit)}
    rows.update({k: res["constraints"][k] for k in _SAMPLED if k in res["constraints"]})
    for k, a in rows.items():
        v, g, _ = _diff(a, D, h)
        cons[k], cgrads[k] = v[:, None], g[:, None, :]
    if worst:
        _envelope(evaluator, X, cons, cgrads)
    reach = np.asarray(res["reachable_fraction"]).reshape(D, 4 * n + 1)[:, 0]
    return {"route": "fd", "values": values, "grads": grads, "constraints": cons, "constraint_grads": cgrads,
            "reach": reach, "fd_error": err, "reason": reason}


def _local(evaluator: Evaluator, designs: np.ndarray, stroke: bool = False) -> dict:
    req = next(r for r in evaluator.requests_all if r.name == (evaluator._cond or _COND))
    return worstcase.local_functions(evaluator.mechanism, evaluator.fixed, evaluator.designs(designs), req.kind,
                                     req.convention, stroke=stroke)


def _hill_rows(evaluator: Evaluator, X: np.ndarray, base: dict, h: np.ndarray | None):
    """(rows (D, k), their derivatives (D, k, n) or None without ``h``, the
    designs searched (D,)) of
    the singularity constraint at the hills of each design of X (the poses
    of the last search), largest first, the first row the Evaluator's
    maximum itself; a hill not climbed is a row of -1 without derivative;
    a design the search skipped keeps its sampled row first.  None where the
    Evaluator keeps no hills."""
    where = evaluator.worst_poses(X)
    if where is None or "cond_hills" not in where:
        return None
    hills = where["cond_hills"]
    D, k, _ = hills.shape
    ok = np.all(np.isfinite(hills), axis=2)                                   # (D, k)
    S = 1 if h is None else 4 * X.shape[1] + 1
    designs = X if h is None else _stencil(X, h)
    poses = np.repeat(np.where(ok[..., None], hills, 0.0), S, axis=0)        # (D S, k, dof)
    with np.errstate(all="ignore"):
        cond = np.asarray(_local(evaluator, designs)["cond"](np.repeat(np.arange(D * S), k))(
            poses.reshape(1, D * S * k, -1)), float)[0].reshape(D * S, k)
    t = smooth_singularity(cond, evaluator.limit)
    first = _singularity(base, evaluator.limit)
    centre = np.where(ok, t[::S], -np.inf)
    order = np.argsort(-centre, axis=1, kind="stable")
    rows = np.where(ok, t[::S], -1.0)
    rows = np.take_along_axis(rows, order, axis=1)
    searched = ok.any(axis=1)
    rows[:, 0] = first                     # the Evaluator's maximum (the largest hill, or the samples')
    if h is None:
        return rows, None, searched
    g = np.zeros((D, k, len(h)))
    for j in range(k):
        _, gj, _ = _diff(t[:, j], D, h)
        g[:, j] = np.where((ok[:, j] & np.all(np.isfinite(gj), axis=1))[:, None], gj, 0.0)
    g = np.take_along_axis(g, order[..., None], axis=1)
    return rows, g, searched


def _envelope(evaluator: Evaluator, X: np.ndarray, cons: dict, cgrads: dict) -> None:
    """The worst-case constraints of :func:`fd_derivatives` at the designs X
    (D, n): their values from the Evaluator (the continuous search), their
    derivatives the central differences (steps :data:`ENVELOPE_STEP`) of the
    local quantity at the pose of each maximum, held; the singularity's one
    row per hill (:func:`_hill_rows`).  For a design the search skips,
    infeasible on the samples already: the samples' maximum and its
    differences, as computed."""
    base = evaluator(X)
    where = evaluator.worst_poses(X)
    if where is None:
        return
    D, n = X.shape
    h = ENVELOPE_STEP * (evaluator.xu - evaluator.xl)
    got = _hill_rows(evaluator, X, base, h)
    if got is not None:
        rows, g, searched = got
        keep = searched[:, None]
        cons["singularity"] = np.where(keep, rows, np.concatenate([cons["singularity"], rows[:, 1:]], axis=1))
        cgrads["singularity"] = np.where(keep[..., None], g,
                                         np.concatenate([cgrads["singularity"], g[:, 1:]], axis=1))
    if evaluator.stroke_limits is None:
        return
    lo, hi = evaluator.stroke_limits
    pad = evaluator.margin * (hi - lo)
    for k, quantity, pose, form in (("stroke_high", "q_max", "q_max", lambda v: v - (hi - pad)),
                                    ("stroke_low", "q_min_neg", "q_min", lambda v: lo + pad + v)):
        if k in cons:
            _held(evaluator, X, h, where[pose], form, quantity, base["constraints"][k], k, cons, cgrads)


def _held(evaluator, X, h, P, form, quantity, at_x, k, cons, cgrads) -> None:
    """One stroke constraint row k from the local ``quantity`` at the held poses P (D, dof)."""
    D, n = X.shape
    known = np.all(np.isfinite(P), axis=1)
    if not known.any():
        return
    S = 4 * n + 1
    fs = _local(evaluator, _stencil(X, h), stroke=True)
    poses = np.repeat(np.where(known[:, None], P, 0.0), S, axis=0)[None]       # (1, D S, dof)
    with np.errstate(all="ignore"):
        raw = np.asarray(fs[quantity](np.arange(D * S))(poses), float)[0]
        v = np.where(np.isfinite(raw), form(raw), np.nan)
        _, g, _ = _diff(v, D, h)
    c = np.asarray(at_x, float)
    good = known & np.isfinite(c) & np.all(np.isfinite(g), axis=1)
    cons[k] = np.where(known[:, None], c[:, None], cons[k])
    cgrads[k] = np.where(good[:, None, None], g[:, None, :], np.where(known[:, None, None], 0.0, cgrads[k]))
