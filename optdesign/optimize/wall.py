"""A projected-gradient walk along the singularity wall, after SLSQP.

Next to a reach boundary the feasible set of ``max_W cond <= limit`` ends in
a wall: cond grows like the inverse square root of the distance to where a
pose of W is lost, so a constrained optimum lies a distance of order
``(c / limit)^2`` from that boundary (about 1e-6 of the box for the Delta of
configs/delta_opt.yaml), and a step a little longer than that, across a
curved wall, lands where a pose is unreachable and the constraint is flat.
SLSQP's quasi-Newton steps are far longer and it stalls there.  This walk
moves along the wall instead, in the unit box:

1. at u, the gradient g of the polish's scaled objective and the
   constraint rows c_j >= 0 with their gradients (:mod:`optdesign.gradients`);
2. the direction d: -g projected onto the cone that does not decrease the
   active rows (c_j <= :data:`ACTIVE_ROW`) nor leave the box at an active
   bound (NNLS on the normalized normals: Moreau's decomposition); ``|d|``
   below :data:`STATIONARY` ends the walk (a first-order point);
3. :data:`TRIALS` step lengths at once, ``u + alpha_i d / |d|``, each
   restored along the active normals (Newton on the largest row, which is
   linear in the distance to the wall near it; doubled steps while the row
   is flat past the reach boundary), all in one call of the Evaluator per
   Newton step;
4. the best feasible trial that improves is taken and the lengths follow
   it; none: they shrink; the walk ends when they fall below
   :data:`ALPHA_MIN` or after ``iterations``.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import nnls

from ..gradients import derivatives
from .feasible import check
from .polish import MARGIN, _objective, _Point, one_blas_thread

__all__ = ["walk", "walk_design"]

#: a constraint row this close to 0 (in its own units) is active: the walk
#: keeps to the walls of every hill near the limit (measured on delta_opt:
#: with 0.5 the walk stalled where a second hill's wall rose, 0.0362 short of
#: r's bound; with 50 its directions were too narrow; 5 reached the corner)
ACTIVE_ROW = 5.0
#: a projected direction shorter than this (unit box, scaled objective) is stationary
STATIONARY = 1e-10
#: the first step, the largest and the smallest before the walk ends (unit box)
ALPHA0, ALPHA_MAX, ALPHA_MIN = 1e-3, 0.05, 1e-11
#: a coordinate this close to a bound (unit box) is on it (a design on a bound in SI
#: comes back a rounding off it in the unit box)
BOUND = 1e-9
#: the trial lengths, as factors of the current one
TRIALS = np.array([4.0, 1.0, 0.25, 1.0 / 16.0])
#: Newton steps of the restoration, and where it aims (inside the rows, their units)
RESTORE_STEPS, TARGET = 20, 1e-7


def _direction(g: np.ndarray, c: np.ndarray, J: np.ndarray, u: np.ndarray):
    """(d, the unit normal the restoration follows, the rows' slope along it)."""
    n = len(u)
    normals = [J[j] / np.linalg.norm(J[j]) for j in np.flatnonzero(c <= ACTIVE_ROW) if np.linalg.norm(J[j]) > 0]
    cols = (normals + [np.eye(n)[i] for i in np.flatnonzero(u <= BOUND)]
            + [-np.eye(n)[i] for i in np.flatnonzero(u >= 1.0 - BOUND)])
    if cols:
        B = np.stack(cols, axis=1)
        with one_blas_thread():
            lam, _ = nnls(B, g)
        d = B @ lam - g
    else:
        d = -g
    if not normals:
        return d, np.zeros(n), 0.0
    nrm = np.sum(normals, axis=0)
    nrm = nrm / max(np.linalg.norm(nrm), 1e-300)
    return d, nrm, float(np.max(J @ nrm))


def _restore(rows, Y: np.ndarray, normal: np.ndarray, slope: float) -> np.ndarray:
    """Each row of Y moved along ``normal`` until its largest constraint row is
    TARGET inside: ``rows(Y) -> (k, m)`` the constraint rows (>= 0 feasible)."""
    if slope <= 0:
        return Y
    Y = Y.copy()
    last = np.zeros(len(Y))
    for _ in range(RESTORE_STEPS):
        c = rows(Y)
        worst = np.min(c, axis=1) if c.shape[1] else np.zeros(len(Y))
        todo = worst < TARGET
        if not todo.any():
            break
        s = np.where(worst <= -1.0, np.maximum(2.0 * last, (TARGET + 1.0) / slope), (TARGET - worst) / slope)
        s = np.where(todo, s, 0.0)
        Y = _snap(Y + s[:, None] * normal)
        last = np.where(todo, s, last)
    return Y


def _snap(Y: np.ndarray) -> np.ndarray:
    """Into the box, a coordinate within :data:`BOUND` of a bound onto it."""
    Y = np.clip(Y, 0.0, 1.0)
    return np.where(Y <= BOUND, 0.0, np.where(Y >= 1.0 - BOUND, 1.0, Y))


def walk(grad, rows, check, u0: np.ndarray, iterations: int = 200) -> tuple[np.ndarray, float, int]:
    """(u, value, iterations) from the feasible u0 (unit box): ``grad(u) ->
    (g, c, J)`` the scaled objective's gradient and the constraint rows with
    their Jacobian at one design, ``rows(U) -> (k, m)`` the rows at several,
    ``check(U) -> (values (k,), feasible (k,))`` the Evaluator's verdict."""
    u = np.asarray(u0, dtype=float)
    f, ok = check(u[None])
    f = float(f[0])
    if not ok[0]:
        return u, f, 0
    alpha, it = ALPHA0, 0
    for it in range(1, iterations + 1):
        g, c, J = grad(u)
        d, normal, slope = _direction(g, c, J, u)
        dn = float(np.linalg.norm(d))
        if dn < STATIONARY or alpha < ALPHA_MIN:
            break
        a = np.minimum(alpha * TRIALS, ALPHA_MAX)
        Y = _restore(rows, _snap(u[None] + a[:, None] * (d / dn)[None]), normal, slope)
        F, okY = check(Y)
        F = np.where(okY, F, np.inf)
        j = int(np.argmin(F))
        if F[j] < f:
            u, f, alpha = Y[j], float(F[j]), float(a[j]) * 2.0
        else:
            alpha = float(a[-1]) * 0.25
    return u, f, it


def walk_design(problem, x0: np.ndarray, iterations: int = 200) -> dict:
    """The walk from the feasible design x0 (SI) for the single objective of
    ``problem`` (a DesignProblem with one term): ``{"end", "end_value",
    "iterations", "evaluations"}`` (the Evaluator's objective value)."""
    ev = problem.evaluate_designs
    xl, w = ev.xl, ev.xu - ev.xl
    F0, ok0, _ = check(problem, np.asarray(x0, dtype=float))
    pt = _Point(ev, "auto")
    fun, jac = _objective(problem.terms[0], pt, float(F0[0]), w)
    calls = [0]

    def grad(u):
        g = jac(u)
        c, J = pt.constraints(u)
        return g, c, J

    def rows(U):
        calls[0] += len(U)
        d = derivatives(ev, xl + w * U, pt.route, values_only=True)
        c = np.concatenate([-(d.constraints[k] + MARGIN) for k in d.constraints], axis=1)
        return np.where(np.isfinite(c), c, -1.0)

    def verdict(U):
        calls[0] += len(U)
        F, ok, _ = check(problem, xl + w * U)
        return F, ok

    u, f, it = walk(grad, rows, verdict, (np.asarray(x0, dtype=float) - xl) / w, iterations)
    return {"end": (xl + w * u).tolist(), "end_value": f, "iterations": it, "evaluations": calls[0] + pt.calls}
