"""Forward kinematics of described mechanisms: the poses whose legs close for
given actuator values.

The closures with the actuators fixed are ``f_i(x) = |b_i(x) - a_i(q_i)|^2 - l_i^2``
(``|b_i(x) - A_i|^2 - q_i^2`` for struts), with ``df_i/dxi = 2 (d_i, r_i x d_i)``
in the platform twist and ``df/dx = 2 (d, r x d) S(x)`` in pose coordinates.

* :func:`forward`: a translational mechanism with three legs has the closed
  form of three spheres (centres ``a_i - P_i``, radii ``l_i`` or ``q_i``) with
  its two mirror solutions; the one reproducing the actuator values in the
  description's branches and nearest the start is kept (one Newton step
  polishes it).  Every other mechanism: damped Newton on the closures from the
  start (default the home pose), then from perturbed starts where that fails.
  A solution counts only if the inverse kinematics of its pose, in the
  description's branches, gives back the actuator values (to 1e-9 relative).
* :func:`forward_all`: both sphere solutions (translation, three legs), or
  every distinct solution Newton reaches from a Sobol set of starts around the
  home pose (not a certificate; the UPS+UPR+S module has a certified
  enumeration for its own equations).
"""
from __future__ import annotations

import numpy as np

from .poses import frames, rate_map, twist_columns

__all__ = ["forward", "forward_all", "closure"]


def _targets(C, Q):
    """Actuated points a (..., n, 3) and squared lengths (..., n) for actuator values Q."""
    kind = C.kind
    q = Q
    a_pr = C.A + q[..., None] * C.U
    a_rv = C.A + C.La[..., None] * (np.cos(q)[..., None] * C.R0 + np.sin(q)[..., None] * C.S0)
    a = np.where((kind == 0)[:, None], a_pr, np.where((kind == 1)[:, None], a_rv, np.broadcast_to(C.A, a_pr.shape)))
    L2 = np.where(kind == 2, q * q, C.Lr ** 2)
    return a, L2


def closure(mech, X, a, L2):
    """f (..., n) and df/dx (..., n, dof) at poses X."""
    C, spec = mech.constants, mech.pose_spec
    fr = frames(spec, X, C.centre, C.fixed)
    r = np.einsum("...jk,...ik->...ij", fr.R, C.P)
    d = fr.origin[..., None, :] + r - a
    f = np.sum(d * d, axis=-1) - L2
    Fxi = 2.0 * np.concatenate([d, np.cross(r, d)], axis=-1)
    S = rate_map(spec, fr)
    Fx = Fxi[..., list(twist_columns(spec))] if S is None else np.einsum("...ik,...kj->...ij", Fxi, S)
    return f, Fx


def _safe_solve(A, b):
    good = np.all(np.isfinite(A), axis=(-1, -2)) & np.all(np.isfinite(b), axis=-1)
    n = A.shape[-1]
    As = np.where(good[..., None, None], A, np.eye(n))
    with np.errstate(all="ignore"):
        scale = np.prod(np.linalg.norm(As, axis=-1), axis=-1)
        det = np.linalg.det(As)
        good &= np.abs(det) > 1e-13 * scale
    As = np.where(good[..., None, None], As, np.eye(n))
    out = np.linalg.solve(As, np.where(good[..., None], b, 0.0)[..., None])[..., 0]
    return np.where(good[..., None], out, np.nan)


def _newton(mech, X, a, L2, iters: int = 60):
    X = np.array(X, dtype=float)
    with np.errstate(all="ignore"):
        f, Fx = closure(mech, X, a, L2)
        res = np.max(np.abs(f), axis=-1)
        for _ in range(iters):
            dx = _safe_solve(Fx, f)
            step = np.ones(X.shape[:-1])
            Xn = X - dx
            fn, Fn = closure(mech, Xn, a, L2)
            rn = np.max(np.abs(fn), axis=-1)
            for _h in range(6):  # backtracking where the residual grew
                worse = ~(rn <= res) & np.isfinite(rn) | ~np.isfinite(rn)
                worse &= np.all(np.isfinite(dx), axis=-1)
                if not np.any(worse):
                    break
                step = np.where(worse, step * 0.5, step)
                Xt = X - step[..., None] * dx
                ft, Ft = closure(mech, Xt, a, L2)
                rt = np.max(np.abs(ft), axis=-1)
                Xn = np.where(worse[..., None], Xt, Xn)
                fn = np.where(worse[..., None], ft, fn)
                Fn = np.where(worse[..., None, None], Ft, Fn)
                rn = np.where(worse, rt, rn)
            upd = np.all(np.isfinite(Xn), axis=-1)
            done = np.max(np.abs(np.where(upd[..., None], Xn - X, 0.0)), axis=-1) <= 1e-15 * (1 + np.max(np.abs(X), axis=-1))
            X = np.where(upd[..., None], Xn, X)
            f = np.where(upd[..., None], fn, f)
            Fx = np.where(upd[..., None, None], Fn, Fx)
            res = np.where(upd, rn, res)
            if np.all(done | ~upd):
                break
    return X


def _matches(mech, X, Q, tol: float = 1e-9):
    with np.errstate(all="ignore"):
        q = mech.inverse(X)
        ok = np.all(np.abs(q - Q) <= tol * (1.0 + np.abs(Q)), axis=-1)
    return ok & np.all(np.isfinite(X), axis=-1)


def _spheres(mech, a, L2):
    """The two solutions (2, ..., 3) of |p - c_i| = rho_i, c_i = a_i - P_i."""
    C = mech.constants
    c = a - C.P
    c1, c2, c3 = c[..., 0, :], c[..., 1, :], c[..., 2, :]
    r1, r2, r3 = L2[..., 0], L2[..., 1], L2[..., 2]
    with np.errstate(all="ignore"):
        e1 = c2 - c1
        dd = np.linalg.norm(e1, axis=-1)
        ex = e1 / dd[..., None]
        a2 = c3 - c1
        i = np.sum(ex * a2, axis=-1)
        ey = a2 - i[..., None] * ex
        j = np.linalg.norm(ey, axis=-1)
        ey = ey / j[..., None]
        ez = np.cross(ex, ey)
        x = (r1 - r2 + dd * dd) / (2 * dd)
        y = (r1 - r3 + i * i + j * j) / (2 * j) - i * x / j
        h2 = r1 - x * x - y * y
        h = np.sqrt(np.where(h2 >= 0, h2, np.nan))
        base = c1 + x[..., None] * ex + y[..., None] * ey
        return np.stack([base + h[..., None] * ez, base - h[..., None] * ez])


def _prepare(mech, Q, X0):
    C, spec = mech.constants, mech.pose_spec
    Q = np.asarray(Q, dtype=float)
    shape = np.broadcast_shapes(Q.shape[:-1], C.shape)
    Qb = np.broadcast_to(Q, shape + (Q.shape[-1],))
    home = np.asarray(spec.home, dtype=float)
    X0 = np.broadcast_to(home if X0 is None else np.asarray(X0, dtype=float), shape + (spec.dof,))
    with np.errstate(all="ignore"):
        a, L2 = _targets(C, Qb)
    return Qb, X0, a, L2


def forward(mech, Q, X0=None) -> np.ndarray:
    Qb, X0, a, L2 = _prepare(mech, Q, X0)
    spec = mech.pose_spec
    if spec.type == "translation" and len(mech.actuator_names) == 3:
        cand = _spheres(mech, a, L2)
        cand = np.stack([_newton(mech, c, a, L2, iters=2) for c in cand])
        ok = np.stack([_matches(mech, c, Qb) for c in cand])
        dist = np.where(ok, np.linalg.norm(cand - X0, axis=-1), np.inf)
        best = np.argmin(dist, axis=0)
        out = np.take_along_axis(cand, best[None, ..., None], axis=0)[0]
        return np.where(np.isfinite(np.min(dist, axis=0))[..., None], out, np.nan)
    X = _newton(mech, X0, a, L2)
    ok = _matches(mech, X, Qb)
    if not np.all(ok):
        rng = np.random.default_rng(0)
        span = np.array([0.05 if r in ("x", "y", "z") else 0.1 for r in spec.roles])
        for _ in range(6):
            if np.all(ok):
                break
            start = X0 + span * rng.uniform(-1, 1, X0.shape)
            Xt = _newton(mech, start, a, L2)
            okt = _matches(mech, Xt, Qb)
            use = ~ok & okt
            X = np.where(use[..., None], Xt, X)
            ok |= okt
    return np.where(ok[..., None], X, np.nan)


def forward_all(mech, Q, starts: int = 64, span_length: float = 0.25, span_angle: float = 0.8,
                tol: float = 1e-8) -> list[np.ndarray]:
    """All solutions found for each row of Q (N, n_act) of a single design:
    a list of (k, dof) arrays sorted by their first coordinate."""
    if mech.constants.shape != ():
        raise ValueError("forward_all expects a single design")
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    spec = mech.pose_spec
    N = Q.shape[0]
    if spec.type == "translation" and len(mech.actuator_names) == 3:
        _, _, a, L2 = _prepare(mech, Q, None)
        cand = _spheres(mech, a, L2)
        cand = np.stack([_newton(mech, c, a, L2, iters=2) for c in cand])        # (2, N, 3)
        ok = np.stack([_matches(mech, c, Q) for c in cand])
        sols = [cand[ok[:, k], k] for k in range(N)]
    else:
        from scipy.stats import qmc

        u = qmc.Sobol(spec.dof, scramble=True, seed=0).random(starts)
        span = np.array([span_length if r in ("x", "y", "z") else span_angle for r in spec.roles])
        S = np.asarray(spec.home) + (2 * u - 1) * span                            # (s, dof)
        S = np.concatenate([np.asarray(spec.home)[None], S])
        Qs = np.broadcast_to(Q[None], (len(S), N, Q.shape[1]))
        X0 = np.broadcast_to(S[:, None, :], (len(S), N, spec.dof))
        _, _, a, L2 = _prepare(mech, Qs, X0)
        X = _newton(mech, X0, a, L2)
        ok = _matches(mech, X, Qs)
        sols = [X[ok[:, k], k] for k in range(N)]
    out = []
    for s in sols:
        keep = []
        for x in s:
            if not any(np.max(np.abs(x - y)) < tol for y in keep):
                keep.append(x)
        out.append(np.array(sorted(keep, key=lambda v: tuple(v))).reshape(-1, spec.dof))
    return out
