"""Forward kinematics of the UPS+UPR+S (seed paper 000): every root in the
domain, certified (interval Krawczyk on the two trigonometric closure
equations), and the paper's GA answer (eq. 15) for comparison; and the rigid
mechanism of section 1.1 (``UpsUprS(model="rigid")``): its inverse
kinematics, Jacobian, parasitic yaw and closed-form forward kinematics."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from .ups_upr_s import UpsUprS

__all__ = ["ForwardSolution", "solve_all", "ga_forward", "rigid_angles", "rigid_inverse", "rigid_jacobian", "rigid_yaw",
           "rigid_roots"]


# ---------------------------------------------------------------------- forward kinematics
# q_i^2 - Q_i^2 as trigonometric polynomials in (theta, psi) (eq. 14), term by
# term: coefficient * sin^a(theta) cos^b(theta) sin^e(psi) cos^f(psi).
_TERMS1 = np.array([[0, 0, 0, 0], [0, 1, 0, 0], [1, 1, 0, 1], [1, 0, 0, 1], [1, 1, 0, 0]])
_TERMS2 = np.array([[0, 0, 0, 0], [0, 0, 0, 1], [1, 0, 1, 0], [2, 0, 1, 1], [1, 0, 1, 1], [0, 2, 1, 0]])


def _coefficients(mech: "UpsUprS", Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients (N, terms) of eq. 14 for actuator lengths Q (N, 2)."""
    R, a1, a2, b1, b2 = (float(mech.params[k]) for k in ("R", "a1", "a2", "b1", "b2"))
    n = Q.shape[0]
    C1 = np.empty((n, 5))
    C1[:, 0] = b1 ** 2 + a1 ** 2 + R ** 2 - Q[:, 0] ** 2
    C1[:, 1:] = [-2 * a1 * b1, 2 * b1 * R, -2 * a1 * R, -2 * b1 * R]
    C2 = np.empty((n, 6))
    C2[:, 0] = b2 ** 2 + a2 ** 2 + R ** 2 - Q[:, 1] ** 2
    C2[:, 1:] = [-2 * a2 * b2, -2 * a2 * R, 2 * b2 * R, 2 * b2 * R, 2 * b2 * R]
    return C1, C2


def _trig_eval(C: np.ndarray, terms: np.ndarray, th: np.ndarray, ps: np.ndarray):
    """Value (M,) and gradient (M, 2) of sum_k C_k s^a c^b t^e d^f at (th, ps)."""
    s, c, t, d = np.sin(th)[:, None], np.cos(th)[:, None], np.sin(ps)[:, None], np.cos(ps)[:, None]
    a, b, e, f = terms.T

    def pw(x, k):
        return np.where(k > 0, x ** np.maximum(k, 0), 1.0)

    A = pw(s, a) * pw(c, b)
    B = pw(t, e) * pw(d, f)
    dA = a * pw(s, a - 1) * pw(c, b + 1) - b * pw(s, a + 1) * pw(c, b - 1)
    dB = e * pw(t, e - 1) * pw(d, f + 1) - f * pw(t, e + 1) * pw(d, f - 1)
    val = np.sum(C * A * B, -1)
    grad = np.stack([np.sum(C * dA * B, -1), np.sum(C * A * dB, -1)], -1)
    return val, grad


def _hessian_bounds(C: np.ndarray, terms: np.ndarray) -> np.ndarray:
    """Rigorous bounds (M, 2, 2) of |d^2 G / d(th, ps)^2| over all angles.

    A product of n sines and cosines is a trigonometric polynomial of degree n
    and sup-norm <= 1, so by Bernstein's inequality its k-th derivative is
    bounded by n^k; the mixed derivative of f(theta) g(psi) by n_theta n_psi."""
    nt = terms[:, 0] + terms[:, 1]
    npsi = terms[:, 2] + terms[:, 3]
    A = np.abs(C)
    Mtt = A @ (nt ** 2).astype(float)
    Mtp = A @ (nt * npsi).astype(float)
    Mpp = A @ (npsi ** 2).astype(float)
    return np.stack([np.stack([Mtt, Mtp], -1), np.stack([Mtp, Mpp], -1)], -2)


class ForwardSolution:
    """Result of :func:`solve_all`: ``roots`` (list of (k, 2) arrays of
    (sin theta, sin psi)), ``angles`` (list of (k, 2) arrays of (theta, psi)),
    ``unresolved`` (list of boxes that could neither be excluded nor verified,
    empty when the certificate is complete), ``boxes_examined`` (int)."""

    def __init__(self, roots, angles, unresolved, boxes_examined):
        self.roots = roots
        self.angles = angles
        self.unresolved = unresolved
        self.boxes_examined = boxes_examined

    @property
    def certified(self) -> bool:
        return all(len(u) == 0 for u in self.unresolved)


def solve_all(mech: "UpsUprS", Q: np.ndarray, n0: int = 8, min_width: float = 1e-9,
              max_levels: int = 60) -> ForwardSolution:
    """All roots of q_i(theta, psi)^2 = Q_i^2 (eq. 14) with theta, psi in
    [-pi/2, pi/2], for each row of Q (N, 2); vectorized over boxes and rows.

    Every box [x0 - h, x0 + h] of a subdivision of the square is tested:

    * exclusion: for each equation G_i, |G_i(x)| >= |G_i(x0)| - |grad G_i(x0)| . h
      - h^T M_i h / 2 (M_i a rigorous bound of the Hessian, :func:`_hessian_bounds`);
      if this lower bound exceeds a round-off margin for some i, the box has no root;
    * Krawczyk: with Y = grad G(x0)^-1 and |grad G(x) - grad G(x0)| <= M h
      (componentwise), K = x0 - Y G(x0) + (I - Y grad G(X))(X - x0) lies in
      x0 - Y G(x0) +- (|I - Y grad G(x0)| + |Y| M h) h; if that is inside the box,
      the box holds exactly one root, which Newton then converges to (the test
      is made on the box widened by half, so roots on box edges are verified).

    Boxes passing neither test are split in four, down to ``min_width`` (rad);
    a box still undecided there is reported in ``unresolved`` (a tangential or
    double root).  The union of excluded and verified boxes is the whole
    domain, so when ``unresolved`` is empty no root can have been missed (up to
    floating-point round-off in G, covered by the margin).  The square is
    widened by 1e-9 rad so that roots on its edge (cos = 0) are found too.
    """
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    N = Q.shape[0]
    C1, C2 = _coefficients(mech, Q)
    H1, H2 = _hessian_bounds(C1, _TERMS1), _hessian_bounds(C2, _TERMS2)
    margin = 1e-12 * np.stack([np.abs(C1).sum(-1), np.abs(C2).sum(-1)], -1)     # (N, 2)
    lim = np.pi / 2 + 1e-9
    g = (np.arange(n0) + 0.5) / n0 * 2 * lim - lim
    th0, ps0 = np.meshgrid(g, g, indexing="ij")
    idx = np.repeat(np.arange(N), n0 * n0)
    ct = np.tile(np.stack([th0.ravel(), ps0.ravel()], -1), (N, 1))
    h = np.full(N * n0 * n0, lim / n0)
    found = [[] for _ in range(N)]
    unresolved = [[] for _ in range(N)]
    examined = 0
    for _level in range(max_levels):
        if idx.size == 0:
            break
        examined += idx.size
        v1, g1 = _trig_eval(C1[idx], _TERMS1, ct[:, 0], ct[:, 1])
        v2, g2 = _trig_eval(C2[idx], _TERMS2, ct[:, 0], ct[:, 1])
        G = np.stack([v1, v2], -1)                                   # (M, 2)
        J = np.stack([g1, g2], -2)                                   # (M, 2, 2)
        Hb = np.stack([H1[idx], H2[idx]], -3)                        # (M, 2 eq, 2, 2)
        hv = np.stack([h, h], -1)
        quad = 0.5 * np.einsum("mejk,mj,mk->me", Hb, hv, hv)          # h^T M_e h / 2
        lower = np.abs(G) - np.einsum("mej,mj->me", np.abs(J), hv) - quad
        excluded = np.any(lower > margin[idx], axis=-1)
        # Krawczyk on the rest
        det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
        okdet = np.abs(det) > 0
        Y = np.stack([np.stack([J[:, 1, 1], -J[:, 0, 1]], -1), np.stack([-J[:, 1, 0], J[:, 0, 0]], -1)], -2)
        Y = Y / np.where(okdet, det, 1.0)[:, None, None]
        # the test runs on the box widened by half (so a root on an edge of the
        # subdivision is verified too); a unique root there covers the box
        hk = 1.5 * hv
        delta = np.einsum("mejk,mk->mej", Hb, hk)                    # |grad G(x) - grad G(x0)| bound
        E = np.abs(np.eye(2) - Y @ J) + np.abs(Y) @ delta
        step = -np.einsum("mij,mj->mi", Y, G)
        reach = np.abs(step) + np.einsum("mij,mj->mi", E, hk)
        verified = okdet & ~excluded & np.all(reach < hk, axis=-1)
        if np.any(verified):
            x = _newton(C1[idx[verified]], C2[idx[verified]], ct[verified])
            for k, xx in zip(idx[verified], x):
                found[k].append(xx)
        rest = ~excluded & ~verified
        small = rest & (h < min_width)
        for k, xx, hh in zip(idx[small], ct[small], h[small]):
            unresolved[k].append((xx, hh))
        split = rest & ~small
        if not np.any(split):
            idx = idx[:0]
            break
        hs = h[split] / 2
        cs = ct[split]
        offs = np.array([[-1, -1], [-1, 1], [1, -1], [1, 1]], float)
        ct = (cs[:, None, :] + offs[None] * hs[:, None, None]).reshape(-1, 2)
        h = np.repeat(hs, 4)
        idx = np.repeat(idx[split], 4)
    else:  # pragma: no cover - max_levels reached
        for k, xx, hh in zip(idx, ct, h):
            unresolved[k].append((xx, hh))
    roots, angles = [], []
    for k in range(N):
        a = np.array(found[k]).reshape(-1, 2)
        a = a[np.all(np.abs(a) <= np.pi / 2 + 1e-9, axis=-1)] if len(a) else a
        keep = []
        for x in a:  # boxes sharing an edge may verify the same root
            if not any(np.max(np.abs(x - y)) < 1e-8 for y in keep):
                keep.append(x)
        a = np.array(sorted(keep, key=lambda v: (v[0], v[1]))).reshape(-1, 2)
        a = np.clip(a, -np.pi / 2, np.pi / 2)
        angles.append(a)
        roots.append(np.sin(a))
    return ForwardSolution(roots, angles, unresolved, examined)


def _newton(C1, C2, x, iters: int = 30) -> np.ndarray:
    x = x.copy()
    for _ in range(iters):
        v1, g1 = _trig_eval(C1, _TERMS1, x[:, 0], x[:, 1])
        v2, g2 = _trig_eval(C2, _TERMS2, x[:, 0], x[:, 1])
        J = np.stack([g1, g2], -2)
        dx = np.linalg.solve(J, np.stack([v1, v2], -1)[..., None])[..., 0]
        x -= dx
        if np.max(np.abs(dx)) < 1e-15:
            break
    return x


def ga_forward(mech: "UpsUprS", q, population: int = 50, generations: int = 100, seed: int = 1) -> np.ndarray:
    """The paper's forward kinematics: a genetic algorithm minimizing
    f = f1^2 + f2^2 (eq. 15, lengths in the caller's units) over
    (sin theta, sin psi) in [-1, 1]^2 (pymoo GA).  Returns the best individual (2,)."""
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.core.problem import Problem
    from pymoo.optimize import minimize

    q = np.asarray(q, dtype=float)

    class _FK(Problem):
        def __init__(self):
            super().__init__(n_var=2, n_obj=1, xl=-np.ones(2), xu=np.ones(2))

        def _evaluate(self, x, out, *args, **kwargs):
            out["F"] = np.sum((mech.inverse(x) - q) ** 2, axis=-1)

    res = minimize(_FK(), GA(pop_size=population), ("n_gen", generations), seed=seed, verbose=False)
    return np.asarray(res.X, dtype=float).reshape(2)


# ---------------------------------------------------------------------- CasADi model


# ---------------------------------------------------------------------- the rigid mechanism of section 1.1
# The UPS+UPR+S as the rigid mechanism of section 1.1 of seed paper 000
# (``UpsUprS(model="rigid")``), beside the paper's printed model of section 2.
#
# The UPR chain (U at A2 = (a1, 0, 0) with its first axis x through A1, its
# second axis u2 = Rx(alpha) y; P; R at B2 parallel to u2) lets the platform
# turn by Q = Rx(alpha) Ry(beta) about the centre A1 of the S joint, and the
# link A1B1 is fixed to the platform: B1 = Q (0, 0, R), B2 = Q (b1, 0, R),
# B3 = Q (0, b2, R).  So
#
#     q2^2 = a1^2 + b1^2 + R^2 - 2 a1 (b1 cos(beta) + R sin(beta)),
#     q3^2 = a2^2 + b2^2 + R^2 - 2 a2 (b2 cos(alpha) - R sin(alpha) cos(beta)).
#
# In the paper's pose coordinates (sin theta, sin psi) of Q = Rz(phi) Ry(theta)
# Rx(psi) (eq. 1): sin(theta) = cos(alpha) sin(beta), cos(theta) sin(psi) =
# sin(alpha), cos(theta) cos(psi) = cos(alpha) cos(beta), and the yaw phi =
# atan2(sin(alpha) sin(beta), cos(beta)) is *not* 0: it is parasitic (the
# paper's eq. 6-8 conclude phi = 0 from the constraint equations written with
# eq. 13's B1, which is not on a link fixed to the platform; see
# docs/lower-mobility.md).  The forward kinematics is in closed form: beta from
# q2 (two roots), then alpha from q3 (two roots each), kept in the domain
# |alpha|, |beta| <= pi / 2 (cos(theta), cos(psi) >= 0).


def _rigid_params(mech):
    return tuple(np.asarray(mech.params[k], float) for k in ("R", "a1", "a2", "b1", "b2"))


def rigid_angles(X: np.ndarray) -> dict:
    """alpha, beta and the derivatives d(alpha, beta)/d(sin theta, sin psi) at X (..., N, 2)."""
    X = np.asarray(X, dtype=float)
    s, t = X[..., 0], X[..., 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.sqrt(np.where(np.abs(s) <= 1, 1.0 - s * s, np.nan))
        d = np.sqrt(np.where(np.abs(t) <= 1, 1.0 - t * t, np.nan))
        sa = c * t
        ca = np.sqrt(1.0 - sa * sa)
        alpha = np.arcsin(sa)
        beta = np.arctan2(s, c * d)
        # d alpha: sa = c t;  d beta: beta = atan2(u, v), u = s, v = c d, u^2 + v^2 = ca^2
        da_ds, da_dt = -s / c * t / ca, c / ca
        u, v = s, c * d
        du = (1.0, 0.0)
        dv = (-s / c * d, -c * t / d)
        den = ca * ca
        db_ds = (v * du[0] - u * dv[0]) / den
        db_dt = (v * du[1] - u * dv[1]) / den
    return {"alpha": alpha, "beta": beta, "sa": sa, "ca": ca, "da": (da_ds, da_dt), "db": (db_ds, db_dt)}


def _rigid_squares(mech, a, b):
    R, a1, a2, b1, b2 = _rigid_params(mech)
    q2 = a1 * a1 + b1 * b1 + R * R - 2 * a1 * (b1 * np.cos(b) + R * np.sin(b))
    q3 = a2 * a2 + b2 * b2 + R * R - 2 * a2 * (b2 * np.cos(a) - R * np.sin(a) * np.cos(b))
    return q2, q3


def rigid_inverse(mech, X: np.ndarray) -> np.ndarray:
    g = rigid_angles(X)
    q2, q3 = _rigid_squares(mech, g["alpha"], g["beta"])
    with np.errstate(invalid="ignore"):
        return np.stack([np.sqrt(q2), np.sqrt(q3)], -1)


def rigid_jacobian(mech, X: np.ndarray) -> np.ndarray:
    """d(q2, q3)/d(sin theta, sin psi) of the rigid model."""
    R, a1, a2, b1, b2 = _rigid_params(mech)
    g = rigid_angles(X)
    a, b = g["alpha"], g["beta"]
    q = rigid_inverse(mech, X)
    with np.errstate(invalid="ignore", divide="ignore"):
        d2_db = -2 * a1 * (-b1 * np.sin(b) + R * np.cos(b))
        d3_da = -2 * a2 * (-b2 * np.sin(a) - R * np.cos(a) * np.cos(b))
        d3_db = -2 * a2 * (R * np.sin(a) * np.sin(b))
        rows = []
        for k in range(2):
            j2 = d2_db * g["db"][k] / (2 * q[..., 0])
            j3 = (d3_da * g["da"][k] + d3_db * g["db"][k]) / (2 * q[..., 1])
            rows.append((j2, j3))
    return np.stack([np.stack([rows[0][0], rows[1][0]], -1), np.stack([rows[0][1], rows[1][1]], -1)], -2)


def rigid_yaw(X: np.ndarray) -> np.ndarray:
    """The parasitic yaw phi of Q = Rz(phi) Ry(theta) Rx(psi) = Rx(alpha) Ry(beta)."""
    g = rigid_angles(X)
    return np.arctan2(g["sa"] * np.sin(g["beta"]), np.cos(g["beta"]))


def rigid_roots(mech, q) -> np.ndarray:
    """Every pose (k, 2) (sin theta, sin psi) of one design with the lengths q (2,), sorted by sin theta."""
    R, a1, a2, b1, b2 = (float(v) for v in _rigid_params(mech))
    k2 = (a1 * a1 + b1 * b1 + R * R - q[0] ** 2) / (2 * a1)          # b1 cos(beta) + R sin(beta)
    out = []
    r2, b0 = np.hypot(b1, R), np.arctan2(R, b1)
    if abs(k2) <= r2:
        for sb in (1.0, -1.0):
            beta = b0 + sb * np.arccos(k2 / r2)
            beta = (beta + np.pi) % (2 * np.pi) - np.pi
            if abs(beta) > np.pi / 2:
                continue
            k3 = (a2 * a2 + b2 * b2 + R * R - q[1] ** 2) / (2 * a2)   # b2 cos(alpha) - R cos(beta) sin(alpha)
            r3, a0 = np.hypot(b2, R * np.cos(beta)), np.arctan2(-R * np.cos(beta), b2)
            if abs(k3) > r3:
                continue
            for sa in (1.0, -1.0):
                alpha = a0 + sa * np.arccos(k3 / r3)
                alpha = (alpha + np.pi) % (2 * np.pi) - np.pi
                if abs(alpha) > np.pi / 2:
                    continue
                st = np.cos(alpha) * np.sin(beta)
                out.append((st, np.sin(alpha) / np.sqrt(1 - st * st)))
    keep = []
    for x in sorted(out):
        if not any(abs(x[0] - y[0]) < 1e-12 and abs(x[1] - y[1]) < 1e-12 for y in keep):
            keep.append(x)
    return np.array(keep, dtype=float).reshape(-1, 2)
