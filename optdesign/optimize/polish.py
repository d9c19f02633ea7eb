"""The local, gradient-based polish of a stage's best designs.

SLSQP (scipy.optimize) in the design box scaled to the unit cube, with the
derivatives of :mod:`optdesign.gradients` (CasADi AD through the model, or
checked central differences).  The constraints are the smooth equivalents
of the Evaluator's (see :class:`optdesign.gradients.Derivatives`):

* conditioning, ``max_W cond(J) <= threshold``: the same condition at every
  workspace point, ``cond(x_j) / threshold - 1 <= 0`` (no kink of the
  maximum; the feasible set is the same);
* reach, every point of W reachable: lost only where an inverse-kinematics
  root becomes double (the discriminant crosses 0), which is an
  inverse-kinematics singularity: a row of J = -f_q^-1 f_x grows without
  bound there, so cond(J) -> infinity and the conditioning constraint is
  violated before reach is lost.  Reach is therefore not a separate smooth
  constraint; it is checked (with every other constraint of the Evaluator)
  at the end, and a design that fails it is never taken;
* stroke limits: at every point and actuator.

An objective is one :class:`~.problem.Term` (an index, an extra objective,
the normalized weighted sum).  Each polished design is evaluated again by the
Evaluator; it replaces the start only if it is feasible there and no worse.
A Pareto point is polished by the Pascoletti-Serafini scalarization
``min t`` s.t. ``(F_j(x) - F_j(x0)) / r_j <= t`` for every objective j
(r: the front's range), which moves it onto the front without leaving the
cone of designs that dominate it.

The first-order optimality measure at the result (:func:`optimality`): the
gradient of the scaled objective in unit-box coordinates, its projection on
the active bounds, and the KKT residual ``min_{lambda >= 0} ||grad f -
sum lambda_i grad c_i||`` over the active bounds and constraints (NNLS).
"""
from __future__ import annotations

import functools
import warnings

import numpy as np
from scipy.optimize import minimize, nnls
from threadpoolctl import ThreadpoolController

from ..gradients import derivatives
from .feasible import check, feasible_end
from .problem import normalized_terms

__all__ = ["term_value", "distinct_best", "polish_designs", "polish_front_point", "optimality", "one_blas_thread",
           "TOLERANCE", "ACTIVE"]

#: the stated tolerance of the optimality measure (KKT residual of the scaled
#: objective over max(1, its gradient norm), see :func:`optimality`)
TOLERANCE = 1e-6
#: a bound or constraint within this (unit box, constraint units) is active
ACTIVE = 1e-6
#: one-sided differences of the objective that differ by more than this
#: (relative) mark a kink (see :func:`optimality`)
KINK = 1e-3
#: the polish aims this far inside the conditioning and stroke constraints, so
#: that its answer is feasible for the Evaluator's strict test
MARGIN = 1e-9
#: SLSQP settings per derivative route: (iterations at most, ftol).  Central
#: differences cost 4 n + 1 evaluations a derivative and are good to about
#: 1e-8, so that route stops earlier.
SETTINGS = {"ad": (None, 1e-14), "fd": (15, 1e-10)}
#: restarts of a start whose SLSQP run ends without converging but with progress
RESTARTS = 3
#: a start whose iterate comes this close (unit box, max norm) to where an
#: earlier start ended is stopped: it is converging to the same design
JOIN = 1e-3


def term_value(term, values: dict, grads: dict | None = None):
    """Value (D,) of an objective term from index values, and its derivative (D, n) if ``grads``."""
    if term.kind in ("index", "extra"):
        v = term.sign * np.asarray(values[term.name], dtype=float)
        return v if grads is None else (v, term.sign * grads[term.name])
    f = normalized_terms(values, term.lo, term.hi, term.senses, term.literal)
    v = sum(term.weights[k] * f[k] for k in f)
    if grads is None:
        return v
    g = 0.0
    for k in f:
        span = term.hi[k] - term.lo[k]
        if span > 0:
            s = -1.0 if term.senses[k] == "max" and not term.literal else 1.0
            g = g + term.weights[k] * s * grads[k] / span
    return v, g + np.zeros_like(grads[next(iter(f))])


class _Point:
    """Values (and derivatives) at one design, computed once per x: SLSQP asks
    for the objective, the constraints and their Jacobians separately, and
    for values alone along its line searches."""

    def __init__(self, evaluator, route):
        self.evaluator, self.route = evaluator, route
        self.key, self.d, self.full = None, None, False
        self.width = evaluator.xu - evaluator.xl
        self.calls = 0

    def at(self, u, grads: bool = True):
        key = np.asarray(u, dtype=float).tobytes()
        if key == self.key and (self.full or not grads):
            return self.d
        grads = grads or self.route == "auto"       # the first call with derivatives decides the route
        x = self.evaluator.xl + self.width * np.clip(u, 0.0, 1.0)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self.d = derivatives(self.evaluator, x[None, :], self.route, values_only=not grads)
        if grads:
            self.route = self.d.route
            self.calls += 1
        self.key, self.full = key, grads
        return self.d

    def constraints(self, u, grads: bool = True):
        """c(u) >= 0 (SLSQP's sign) and, with ``grads``, its Jacobian in unit-box coordinates."""
        d = self.at(u, grads)
        c = np.concatenate([-(d.constraints[k][0] + MARGIN) for k in d.constraints]) if d.constraints else np.zeros(0)
        bad = ~np.isfinite(c)
        c = np.where(bad, -1.0, c)
        if not grads:
            return c
        J = (np.concatenate([-d.constraint_grads[k][0] for k in d.constraints]) * self.width
             if d.constraints else np.zeros((0, len(u))))
        return c, np.where(bad[:, None] | ~np.isfinite(J), 0.0, J)


def _finite(v) -> float:
    v = float(v)
    return v if np.isfinite(v) else 1e30


@functools.cache
def _threadpools() -> ThreadpoolController:
    return ThreadpoolController()


def one_blas_thread():
    """A context with one BLAS thread.  The libraries are found once per
    process (threadpoolctl's ``threadpool_limits`` looks them up again on every
    entry, which cost more than a polish step's arithmetic)."""
    return _threadpools().limit(limits=1, user_api="blas")


def _minimize(*args, **kwargs):
    """scipy.optimize.minimize with one BLAS thread: SLSQP's steps depend on
    the BLAS thread count in their last bits (a worker of a process pool runs
    with fewer threads than the main process), and the same seed must give
    the same files whatever runs it."""
    with np.errstate(all="ignore"), warnings.catch_warnings(), one_blas_thread():
        warnings.simplefilter("ignore")
        return minimize(*args, **kwargs)


def _options(pt, u0, maxiter: int) -> dict:
    """SLSQP's options for the derivative route at u0 (computed here, so the route is known)."""
    pt.at(u0)
    cap, ftol = SETTINGS[pt.route]
    return {"maxiter": int(maxiter if cap is None else min(maxiter, cap)), "ftol": ftol}


def _slsqp(fun, jac, u0, cons, n_bounds, options, callback=None):
    return _minimize(fun, u0, jac=jac, method="SLSQP", bounds=[(0.0, 1.0)] * n_bounds,
                     constraints=[cons], options=options, callback=callback)


def _objective(term, pt, f0: float, width):
    """(fun, jac) SLSQP minimizes for a term, in unit-box coordinates: an index
    or extra objective of one sign as log(sign * value) when that is positive at
    the start (the same optimum; near a singularity, where an index grows like
    1 / distance, its logarithm is much better conditioned), otherwise the
    value scaled by 1 / max(|f0|, 0.01)."""
    sign = getattr(term, "sign", 1.0)      # the term's value is sign * sigma
    log = term.kind in ("index", "extra") and sign * f0 > 0

    def value(v):
        if log:   # sign * log(sigma): log sigma minimized, or -log sigma for a maximized index
            return sign * np.log(sign * v) if sign * v > 0 else np.inf
        return v / max(abs(f0), 1e-2)

    def fun(u):
        return _finite(value(float(term_value(term, pt.at(u, False).values)[0])))

    def jac(u):
        d = pt.at(u)
        v, g = term_value(term, d.values, d.grads)
        g = g[0] * width * (sign / v[0] if log else 1.0 / max(abs(f0), 1e-2))
        return np.where(np.isfinite(g), g, 0.0)

    return fun, jac


def polish_designs(problem, starts: np.ndarray, maxiter: int = 100, route: str = "auto", join: bool = True) -> dict:
    """Polish each start (feasible designs (k, n)) for the single objective of
    ``problem`` (a DesignProblem with one term); ``join``: stop a start that
    comes within :data:`JOIN` of where an earlier one ended.  Returns ``best`` (x, value,
    or None when no start improved), ``runs`` (per start: start and end
    value, iterations, evaluations, message) and ``evaluations``."""
    ev = problem.evaluate_designs
    term = problem.terms[0]
    pt = _Point(ev, route)
    xl, width = ev.xl, ev.xu - ev.xl
    F0, ok0, _ = check(problem, starts)
    runs, best = [], None
    for x0, f0, ok in zip(starts, F0, ok0):
        if not ok:
            continue
        fun, jac = _objective(term, pt, float(f0), width)

        calls = pt.calls
        cons = {"type": "ineq", "fun": lambda u: pt.constraints(u, False), "jac": lambda u: pt.constraints(u)[1]}
        ends = [(np.asarray(r["end"]) - xl) / width for r in runs] if join else []
        joined = []

        def meet(u):
            """Stop a start that has come within JOIN of where an earlier one ended."""
            for j, e in enumerate(ends):
                if np.max(np.abs(np.asarray(u) - e)) < JOIN:
                    joined.append(j)
                    raise StopIteration

        x, f, nit = x0, float(f0), 0
        for _ in range(1 + RESTARTS):
            # a line search that fails (SLSQP's quasi-Newton model gone stale next to the
            # singularity constraint) is restarted from where it stopped, while that helps
            u0 = (x - xl) / width
            res = _slsqp(fun, jac, u0, cons, len(x0), _options(pt, u0, maxiter), meet if ends else None)
            nit += int(res.nit)
            x1, f1 = feasible_end(problem, x, xl + width * np.clip(res.x, 0, 1))
            better = f1 < f - 1e-15 * max(abs(f), 1e-300)
            if better:
                x, f = x1, f1
            if res.success or not better or joined:
                break
        runs.append({"start": x0.tolist(), "start_value": float(f0), "end": x.tolist(), "end_value": f,
                     "iterations": nit, "evaluations": pt.calls - calls,
                     "message": f"joined start {joined[0] + 1}" if joined else str(res.message)})
        if f <= f0 and (best is None or f < best[1]):
            best = (x, f)
    return {"best": best, "runs": runs, "evaluations": pt.calls, "route": pt.d.route if pt.d is not None else None,
            "route_reason": pt.d.reason if pt.d is not None else ""}


def polish_front_point(problem, x0: np.ndarray, r: np.ndarray, maxiter: int = 100, route: str = "auto"):
    """Pascoletti-Serafini polish of one front design x0 of a multi-objective
    ``problem``: (x, F(x)) of a design that dominates or equals x0 (x0 itself
    when the scalarization does not improve it) and the improvement t <= 0
    (in units of r)."""
    ev = problem.evaluate_designs
    pt = _Point(ev, route)
    xl, width = ev.xl, ev.xu - ev.xl
    a, ok0, _ = _check_multi(problem, x0)
    if not ok0:
        return x0, a, 0.0, pt.calls
    n = len(x0)

    def objs(u, grads=True):
        d = pt.at(u, grads)
        vals = [term_value(t, d.values, d.grads if grads else None) for t in problem.terms]
        if not grads:
            return np.array([float(x[0]) for x in vals]), None
        v = np.array([float(x[0][0]) for x in vals])
        g = np.stack([x[1][0] * width for x in vals])
        return v, g

    def fun(z):
        g = np.zeros_like(z)
        g[-1] = 1.0
        return z[-1], g

    def cf(z):
        v, _ = objs(z[:-1], False)
        return np.concatenate([z[-1] - (v - a) / r, pt.constraints(z[:-1], False)])

    def cj(z):
        _, g = objs(z[:-1])
        _, J = pt.constraints(z[:-1])
        top = np.hstack([-g / r[:, None], np.ones((len(r), 1))])
        return np.vstack([top, np.hstack([J, np.zeros((len(J), 1))])])

    z0 = np.concatenate([(x0 - xl) / width, [0.0]])
    res = _minimize(fun, z0, jac=True, method="SLSQP", bounds=[(0.0, 1.0)] * n + [(None, None)],
                    constraints=[{"type": "ineq", "fun": cf, "jac": cj}], options=_options(pt, z0[:-1], maxiter))
    x = xl + width * np.clip(res.x[:-1], 0, 1)
    F, ok, _ = _check_multi(problem, x)
    if ok and np.all(F <= a) and np.any(F < a):
        return x, F, float(np.max((F - a) / r)), pt.calls
    return x0, a, 0.0, pt.calls


def _check_multi(problem, x):
    out = {}
    problem._evaluate(np.atleast_2d(x), out)
    return out["F"][0], bool(np.all(out["G"] <= 0)), out


def optimality(problem, x: np.ndarray, names, route: str = "auto") -> dict:
    """First-order optimality of a single-objective ``problem`` at x: the
    gradient of the objective scaled as the polish scales it (by
    1 / max(|f|, 0.01)) in unit-box coordinates, its norm, the projected
    gradient norm (active bounds only), the KKT residual over the active
    bounds and constraints, and which are active.  The measure compared with
    :data:`TOLERANCE` is ``kkt_relative``: the KKT residual over
    max(1, gradient norm), so that a gradient held by active bounds (the
    common case here) is measured against its own size.  The measure assumes
    a differentiable objective: an index that is a singular value has a kink
    where that value crosses its neighbour at some point of W (a symmetric
    design, say).  So the objective's one-sided differences along each
    variable (steps of 1e-6 of the box, the Evaluator's values) are compared:
    ``one_sided_jump``, their largest difference relative to their size;
    above :data:`KINK` ``differentiable`` is False and the measure is no
    certificate there.  (A singular value that stays double for every design,
    as at the centre of a symmetric W, is smooth and is not flagged.)"""
    ev = problem.evaluate_designs
    pt = _Point(ev, route)
    width = ev.xu - ev.xl
    u = (np.asarray(x, dtype=float) - ev.xl) / width
    d = pt.at(u)
    v, g = term_value(problem.terms[0], d.values, d.grads)
    scale = 1.0 / max(abs(float(v[0])), 1e-2)
    g = scale * g[0] * width
    low, high = u <= ACTIVE, u >= 1.0 - ACTIVE
    proj = np.where((low & (g > 0)) | (high & (g < 0)), 0.0, g)
    cols, active = [], {}
    for k in d.constraints:
        c, G = d.constraints[k][0], d.constraint_grads[k][0] * width
        on = np.isfinite(c) & (c >= -ACTIVE)
        if on.any():
            active[k] = int(on.sum())
            cols += [-G[j] for j in np.flatnonzero(on)]   # c <= 0: -grad c points inside
    cols += [np.eye(len(u))[i] for i in np.flatnonzero(low)] + [-np.eye(len(u))[i] for i in np.flatnonzero(high)]
    bounds = [f"{names[i]} at its lower bound" for i in np.flatnonzero(low)]
    bounds += [f"{names[i]} at its upper bound" for i in np.flatnonzero(high)]
    jump = _one_sided_jump(problem, np.asarray(x, dtype=float), width)
    common = {"one_sided_jump": jump if np.isfinite(jump) else None, "differentiable": bool(jump <= KINK),
              "tolerance": TOLERANCE, "active_bounds": bounds, "active_constraints": active, "route": d.route,
              "objective_scale": scale if np.isfinite(scale) else None}
    if not (np.all(np.isfinite(g)) and all(np.all(np.isfinite(c)) for c in cols)):
        # impossible geometry next to x (a square root of a negative number in
        # the model, say): no derivative there, so no first-order measure
        return {**common, "measurable": False, "gradient_norm": None, "projected_gradient_norm": None,
                "kkt_residual": None, "kkt_relative": None, "converged": False,
                "note": "the derivative of the objective or of an active constraint is not finite at this design "
                        "(impossible geometry next to it): no first-order measure"}
    if cols:
        A = np.stack(cols, axis=1)
        with one_blas_thread():
            _, res = nnls(A, g)
    else:
        res = float(np.linalg.norm(g))
    gn = float(np.linalg.norm(g))
    return {**common, "measurable": True, "gradient_norm": gn, "projected_gradient_norm": float(np.linalg.norm(proj)),
            "kkt_residual": float(res), "kkt_relative": float(res) / max(1.0, gn),
            "converged": float(res) / max(1.0, gn) <= TOLERANCE}


def _one_sided_jump(problem, x: np.ndarray, width: np.ndarray, h_rel: float = 1e-6) -> float:
    """The largest jump of the objective's slope across x along one variable,
    per unit box: max_j |right_j - left_j| width_j over max(|f|, max_j of
    the one-sided slopes times width_j), from one evaluation of 2 n + 1
    designs.  A smooth objective gives about h_rel (curvature times the step),
    a kink a number of order one."""
    n = len(x)
    h = h_rel * width
    X = np.concatenate([x[None], x + np.diag(h), x - np.diag(h)])
    with np.errstate(all="ignore"):
        F, _, _ = check(problem, X)
    if not np.all(np.isfinite(F)):
        return float("inf")      # the objective is not finite next to x (impossible geometry): no slope
    right, left = (F[1:n + 1] - F[0]) / h, (F[0] - F[n + 1:]) / h
    scale = max(abs(float(F[0])), float(np.max(np.maximum(np.abs(right), np.abs(left)) * width)), 1e-300)
    return float(np.max(np.abs(right - left) * width) / scale)


def distinct_best(X: np.ndarray, f: np.ndarray, k: int, min_distance: float = 0.05, xl=None, xu=None) -> np.ndarray:
    """The ``k`` best rows of X by f (smallest first, ties by row order), each
    at least ``min_distance`` in the unit box from those taken before it."""
    order = np.lexsort((np.arange(len(f)), np.where(np.isfinite(f), f, np.inf)))
    lo = X.min(axis=0) if xl is None else np.asarray(xl, dtype=float)
    hi = X.max(axis=0) if xu is None else np.asarray(xu, dtype=float)
    width = np.where(hi > lo, hi - lo, 1.0)
    taken: list[int] = []
    for i in order:
        if not np.isfinite(f[i]):
            break
        u = (X[i] - lo) / width
        if all(np.max(np.abs(u - (X[j] - lo) / width)) >= min_distance for j in taken):
            taken.append(int(i))
            if len(taken) == k:
                break
    return X[taken]
