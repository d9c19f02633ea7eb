"""The CasADi route: a mechanism as closure equations and energies, written once;
derivatives by automatic differentiation.

A :class:`SymbolicModel` is built from

* ``closure(x, q, p) -> f`` (n_act equations, f = 0 on the mechanism), with
  ``x`` the pose (dof), ``q`` the actuator coordinates (n_act), ``p`` a dict of
  symbolic parameters;
* optionally ``kinetic(x, q, xd, qd, p) -> T`` and ``potential(x, q, p) -> V``
  (scalars), written from the bodies' own velocities and heights.

From these it derives, with no hand algebra:

* the Jacobian ``J = -(df/dq)^-1 df/dx`` (qdot = J xdot);
* the velocity-product term of the actuator accelerations, ``qdd = J a + c(x, xd)``;
* with q = q(x) implicit (the actuators follow the pose), the pose-space mass
  matrix ``M_p = d^2 T / d xd^2``, and Lagrange's equations
  ``F = M_p a + (d/dx (dT/dxd)) xd - dT/dx + dV/dx``, and the actuator forces
  ``tau = J^-T F`` (virtual work: tau . qdot = F . xdot);
* Newton's method on the closure equations for forward kinematics (and for
  inverse kinematics where no closed form is written).

Evaluation is batched with CasADi's ``map``; this path is the independent
check of hand-derived models and the way a new mechanism gets its derivatives,
not the fast path.
"""
from __future__ import annotations

from typing import Callable, Mapping, Sequence

import casadi as ca
import numpy as np

__all__ = ["SymbolicModel"]


def _total(expr, x, q, J):
    """d expr / dx along the mechanism (q = q(x)): the x and q parts with dq/dx = J."""
    return ca.jacobian(expr, x) + ca.mtimes(ca.jacobian(expr, q), J)


class SymbolicModel:
    """Closure equations (and optionally energies) of a mechanism, with AD derivatives.

    Parameters
    ----------
    dof, n_act : sizes of the pose x and the actuator vector q.
    param_names : names of the parameters the functions read from ``p``.
    closure : ``f(x, q, p)`` -> CasADi expression of n_act components.
    kinetic : ``T(x, q, xd, qd, p)`` -> scalar, optional.
    potential : ``V(x, q, p)`` -> scalar, optional.
    """

    def __init__(self, dof: int, n_act: int, param_names: Sequence[str],
                 closure: Callable, kinetic: Callable | None = None, potential: Callable | None = None):
        self.dof, self.n_act = dof, n_act
        self.param_names = tuple(param_names)
        # the functions as written, for routes that build their own graphs
        # (derivatives with respect to the parameters: optdesign.gradients)
        self.closure_fn, self.kinetic_fn, self.potential_fn = closure, kinetic, potential
        x = ca.SX.sym("x", dof)
        q = ca.SX.sym("q", n_act)
        xd = ca.SX.sym("xd", dof)
        a = ca.SX.sym("a", dof)
        P = ca.SX.sym("p", len(self.param_names))
        p = {k: P[i] for i, k in enumerate(self.param_names)}
        f = closure(x, q, p)
        fx = ca.jacobian(f, x)
        fq = ca.jacobian(f, q)
        J = -ca.solve(fq, fx)
        qd = ca.mtimes(J, xd)
        # qdd = J a + (dJ/dt) xd, with dJ/dt taken along x and q(x)
        Jxd = ca.mtimes(J, xd)
        c = ca.mtimes(_total(Jxd, x, q, J), xd)
        self._f = ca.Function("closure", [x, q, P], [f])
        self._J = ca.Function("jacobian", [x, q, P], [J])
        self._acc = ca.Function("accel", [x, q, xd, a, P], [ca.mtimes(J, a) + c])
        self._fx = ca.Function("fx", [x, q, P], [fx])
        self._fq = ca.Function("fq", [x, q, P], [fq])
        self.has_dynamics = kinetic is not None
        if kinetic is not None:
            T = kinetic(x, q, xd, qd, p)
            V = potential(x, q, p) if potential is not None else ca.SX(0)
            dTdxd = ca.gradient(T, xd)
            Mp = ca.jacobian(dTdxd, xd)
            F = (ca.mtimes(Mp, a) + ca.mtimes(_total(dTdxd, x, q, J), xd)
                 - _total(T, x, q, J).T + _total(V, x, q, J).T)
            tau = ca.solve(J.T, F)
            self._Mp = ca.Function("Mp", [x, q, xd, P], [Mp])
            self._tau = ca.Function("tau", [x, q, xd, a, P], [tau])
            self._F = ca.Function("F", [x, q, xd, a, P], [F])
            self._T = ca.Function("T", [x, q, xd, P], [T])
            self._V = ca.Function("V", [x, q, P], [V])
        # Newton on the closure equations for x given q (forward kinematics)
        self._newton_x = ca.Function("newton_x", [x, q, P], [x - ca.solve(fx, f)])
        self._newton_q = ca.Function("newton_q", [x, q, P], [q - ca.solve(fq, f)])

    # ------------------------------------------------------------------ batching
    def _pvec(self, params: Mapping[str, float], n: int) -> np.ndarray:
        cols = [np.broadcast_to(np.asarray(params[k], dtype=float).ravel(), (n,)) if np.ndim(params[k]) else np.full(n, float(params[k]))
                for k in self.param_names]
        return np.stack(cols, axis=0)

    @staticmethod
    def _call(fun: ca.Function, args: Sequence[np.ndarray]) -> np.ndarray:
        n = args[0].shape[1]
        out = fun.map(n)(*args)
        return np.asarray(out, dtype=float)

    def _stack_out(self, fun, args, rows, cols=1):
        res = self._call(fun, args)  # (rows, cols * n)
        n = args[0].shape[1]
        if cols == 1:
            return res.T.reshape(n, rows)
        return res.reshape(rows, n, cols).transpose(1, 0, 2)

    # ------------------------------------------------------------------ public, batched
    def closure(self, X, Q, params) -> np.ndarray:
        X, Q = np.atleast_2d(X), np.atleast_2d(Q)
        n = X.shape[0]
        return self._stack_out(self._f, [X.T, Q.T, self._pvec(params, n)], self.n_act)

    def jacobian(self, X, Q, params) -> np.ndarray:
        """J (N, n_act, dof) at consistent (X, Q)."""
        X, Q = np.atleast_2d(X), np.atleast_2d(Q)
        n = X.shape[0]
        return self._stack_out(self._J, [X.T, Q.T, self._pvec(params, n)], self.n_act, self.dof)

    def accelerations(self, X, Q, Xd, A, params) -> np.ndarray:
        """qdd (N, n_act) = J a + c(x, xd)."""
        X, Q = np.atleast_2d(X), np.atleast_2d(Q)
        n = X.shape[0]
        return self._stack_out(self._acc, [X.T, Q.T, np.atleast_2d(Xd).T, np.atleast_2d(A).T, self._pvec(params, n)], self.n_act)

    def platform_mass_matrix(self, X, Q, params, Xd=None) -> np.ndarray:
        """M_p (N, dof, dof) = d^2 T / d xd^2."""
        X, Q = np.atleast_2d(X), np.atleast_2d(Q)
        n = X.shape[0]
        Xd = np.zeros_like(X) if Xd is None else np.atleast_2d(Xd)
        args = [X.T, Q.T, Xd.T, self._pvec(params, n)]
        return self._stack_out(self._Mp, args, self.dof, self.dof)

    def actuator_forces(self, X, Q, Xd, A, params) -> np.ndarray:
        """tau (N, n_act) from Lagrange's equations in pose coordinates."""
        X, Q = np.atleast_2d(X), np.atleast_2d(Q)
        n = X.shape[0]
        return self._stack_out(self._tau, [X.T, Q.T, np.atleast_2d(Xd).T, np.atleast_2d(A).T, self._pvec(params, n)], self.n_act)

    def energies(self, X, Q, Xd, params) -> tuple[np.ndarray, np.ndarray]:
        X, Q = np.atleast_2d(X), np.atleast_2d(Q)
        n = X.shape[0]
        pv = self._pvec(params, n)
        T = self._call(self._T, [X.T, Q.T, np.atleast_2d(Xd).T, pv]).ravel()
        V = self._call(self._V, [X.T, Q.T, pv]).ravel()
        return T, V

    def forward_newton(self, Q, X0, params, tol: float = 1e-14, max_iter: int = 50) -> tuple[np.ndarray, np.ndarray]:
        """Newton on f(x, q) = 0 for x, from X0 (N, dof); returns (X, converged mask)."""
        return self._newton(self._newton_x, np.atleast_2d(X0).astype(float), np.atleast_2d(Q).astype(float),
                            params, tol, max_iter, solve_for="x")

    def inverse_newton(self, X, Q0, params, tol: float = 1e-14, max_iter: int = 50) -> tuple[np.ndarray, np.ndarray]:
        """Newton on f(x, q) = 0 for q, from Q0 (N, n_act); returns (Q, converged mask)."""
        return self._newton(self._newton_q, np.atleast_2d(X).astype(float), np.atleast_2d(Q0).astype(float),
                            params, tol, max_iter, solve_for="q")

    def _newton(self, step, X, Q, params, tol, max_iter, solve_for):
        n = X.shape[0]
        pv = self._pvec(params, n)
        stepm = step.map(n)
        cur = X.copy() if solve_for == "x" else Q.copy()
        for _ in range(max_iter):
            if solve_for == "x":
                new = np.asarray(stepm(cur.T, Q.T, pv), dtype=float).T
            else:
                new = np.asarray(stepm(X.T, cur.T, pv), dtype=float).T
            delta = np.max(np.abs(new - cur), axis=1)
            cur = new
            if np.all(~np.isfinite(delta) | (delta < tol)):
                break
        if solve_for == "x":
            res = self.closure(cur, Q, params)
        else:
            res = self.closure(X, cur, params)
        ok = np.all(np.isfinite(cur), axis=1) & (np.max(np.abs(res), axis=1) < 1e-10)
        return cur, ok
