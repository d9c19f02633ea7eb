"""The UPS+UPR+S two-degree-of-freedom mechanism (seed paper 000, Xia et al. 2018).

The paper's model (section 2), which this module implements as printed:

* base frame at the centre of the spherical joint A1; ``m1 = 0``,
  ``m2 = (a1, 0, 0)``, ``m3 = (0, a2, 0)`` (eq. 2);
* platform points in the platform frame at B1: ``n1 = 0``, ``n2 = (b1, 0, 0)``,
  ``n3 = (0, b2, 0)`` (eq. 3); orientation Rz(phi) Ry(theta) Rx(psi) (eq. 1)
  with phi = 0 (section 1.2), so that eq. 9 gives
  ``l2 = (b1 cos(theta) + px, py, -b1 sin(theta) + pz)`` and
  ``l3 = (b2 sin(theta) sin(psi) + px, b2 cos(psi) + py, b2 cos(theta) sin(psi) + pz)``;
* B1 on the sphere of radius R about A1 (eq. 13):
  ``p = R (sin(theta) cos(psi), sin(theta) sin(psi), cos(theta))``;
* actuator lengths ``q_i = |l_i - m_i|`` (eq. 10-12).

The pose is ``x = (sin(theta), sin(psi))`` with cos(theta), cos(psi) >= 0 (the
paper's domain: both sines in [-1, 1]), the actuators ``(q2, q3)``.

Forward kinematics (eq. 14-15) has several solutions.  :meth:`UpsUprS.forward_all`
finds every one of them in the domain with a certificate: a subdivision of the
(theta, psi) square in which every box is either *excluded* (a rigorous lower
bound of |q_i^2 - Q_i^2| over the box is positive) or *verified* by the
Krawczyk test to contain exactly one root; see :func:`solve_all`.  The paper's
genetic algorithm (MATLAB gatool on f = f1^2 + f2^2, eq. 15) is available as
``method="ga"`` (pymoo) for comparison.

The parameters are SI (metres); the paper's values R = 260, a1 = a2 = 150,
b1 = 150, b2 = 100 mm are the defaults.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from . import register
from .base import Mechanism
from .params import Param

PAPER_PARAMETERS = {"R": 0.260, "a1": 0.150, "a2": 0.150, "b1": 0.150, "b2": 0.100}

#: Table 1 of the paper: sin(theta), sin(psi), q2, q3 (lengths in mm)
PAPER_TABLE1 = np.array([
    [-0.267, 0.31, 300.2610, 299.8322],
    [-0.2, 0.405, 289.9693, 310.0407],
    [-0.333, 0.218, 310.5343, 290.1589],
    [-0.067, 0.051, 269.9140, 273.6341],
    [0.0, -0.26, 260.0, 245.2259],
])
#: Table 2 of the paper: q2, q3 (mm), the GA's sin(theta), sin(psi)
PAPER_TABLE2 = np.array([
    [300, 300, -0.267, 0.31],
    [290, 310, -0.2, 0.405],
    [310, 290, -0.333, 0.218],
    [270, 270, -0.067, 0.051],
    [260, 240, 0.0, -0.26],
])


def _p(a, k: int) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return a.reshape(a.shape + (1,) * k)


@register
class UpsUprS(Mechanism):
    """UPS+UPR+S mechanism, pose (sin theta, sin psi), actuators (q2, q3).

    >>> mech = UpsUprS()
    >>> (1000 * mech.inverse(np.array([[-0.2, 0.405]]))).round(3)
    array([[289.969, 310.041]])
    """

    name = "ups_upr_s"
    pose_names = ("s_theta", "s_psi")
    actuator_names = ("q2", "q3")
    parameters = tuple(Param(k, "length", v, design=True, low=0.0, low_open=True, doc=doc) for k, v, doc in (
        ("R", PAPER_PARAMETERS["R"], "distance from the centre S to the platform joints"),
        ("a1", PAPER_PARAMETERS["a1"], "base offset of the UPS leg"),
        ("a2", PAPER_PARAMETERS["a2"], "base offset of the UPR leg"),
        ("b1", PAPER_PARAMETERS["b1"], "platform offset of the UPS leg"),
        ("b2", PAPER_PARAMETERS["b2"], "platform offset of the UPR leg")))
    supported_indices = ("isotropy", "dexterity", "manipulability")
    angular_axes = ()
    dimensionless_axes = ("s_theta", "s_psi")     # sines of the angles

    # ------------------------------------------------------------------ geometry
    def legs(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """Leg vectors v2 = l2 - m2, v3 = l3 - m3 (..., N, 3) and their
        derivatives with respect to theta and psi, at poses X (..., N, 2)."""
        X = np.asarray(X, dtype=float)
        s, t = X[..., 0], X[..., 1]
        with np.errstate(invalid="ignore"):
            c = np.sqrt(np.where(np.abs(s) <= 1, 1.0 - s * s, np.nan))
            d = np.sqrt(np.where(np.abs(t) <= 1, 1.0 - t * t, np.nan))
        R, a1, a2, b1, b2 = (np.asarray(self.params[k], float) for k in ("R", "a1", "a2", "b1", "b2"))
        zero = np.zeros(np.broadcast_shapes(s.shape, R.shape))
        p = np.stack([R * s * d, R * s * t, R * c + zero], -1)
        p_th = np.stack([R * c * d, R * c * t, -R * s + zero], -1)
        p_ps = np.stack([-R * s * t, R * s * d, zero], -1)
        v2 = p + np.stack([b1 * c - a1 + zero, zero, -b1 * s + zero], -1)
        v3 = p + np.stack([b2 * s * t + zero, b2 * d - a2 + zero, b2 * c * t + zero], -1)
        v2_th = p_th + np.stack([-b1 * s + zero, zero, -b1 * c + zero], -1)
        v2_ps = p_ps
        v3_th = p_th + np.stack([b2 * c * t + zero, zero, -b2 * s * t + zero], -1)
        v3_ps = p_ps + np.stack([b2 * s * d + zero, -b2 * t + zero, b2 * c * d + zero], -1)
        return {"p": p, "v2": v2, "v3": v3, "v2_th": v2_th, "v2_ps": v2_ps, "v3_th": v3_th,
                "v3_ps": v3_ps, "c": c, "d": d}

    # ------------------------------------------------------------------ kinematics
    def inverse(self, X: np.ndarray) -> np.ndarray:
        """Actuator lengths (q2, q3) (eq. 12) at poses X (..., N, 2); NaN outside
        the domain |sin| <= 1."""
        g = self.legs(X)
        return np.stack([np.linalg.norm(g["v2"], axis=-1), np.linalg.norm(g["v3"], axis=-1)], -1)

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """J (..., N, 2, 2) = d(q2, q3)/d(sin theta, sin psi) (metres per unit sine).

        d q_i / d theta = v_i . dv_i/dtheta / q_i, and d/d(sin theta) =
        (1 / cos theta) d/dtheta (infinite at cos = 0, where the sine is not a
        coordinate)."""
        g = self.legs(X)
        q2 = np.linalg.norm(g["v2"], axis=-1)
        q3 = np.linalg.norm(g["v3"], axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            j11 = np.sum(g["v2"] * g["v2_th"], -1) / q2 / g["c"]
            j12 = np.sum(g["v2"] * g["v2_ps"], -1) / q2 / g["d"]
            j21 = np.sum(g["v3"] * g["v3_th"], -1) / q3 / g["c"]
            j22 = np.sum(g["v3"] * g["v3_ps"], -1) / q3 / g["d"]
        return np.stack([np.stack([j11, j12], -1), np.stack([j21, j22], -1)], -2)

    def reachable(self, X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, dtype=float)
        ok = np.all(np.abs(X) < 1.0, axis=-1)
        return np.broadcast_to(ok, self.inverse(X).shape[:-1])

    def forward_all(self, q, method: str = "certified", **kw):
        """Every forward-kinematics solution for actuator lengths q (2,) in the
        domain (cos theta, cos psi >= 0), as an array (k, 2) of (sin theta, sin psi)
        sorted by sin theta.  ``method="certified"`` (default): :func:`solve_all`,
        complete by construction; ``method="ga"``: the paper's GA, one answer (1, 2).
        For q of shape (N, 2) a list of N arrays is returned."""
        q = np.asarray(q, dtype=float)
        single = q.ndim == 1
        Q = np.atleast_2d(q)
        if self.design_shape != ():
            raise ValueError("forward_all expects a single design")
        if method == "ga":
            out = [ga_forward(self, qq, **kw)[None, :] for qq in Q]
        elif method == "certified":
            res = solve_all(self, Q, **kw)
            out = res.roots
        else:
            raise ValueError(f"unknown method {method!r}; expected 'certified' or 'ga'")
        return out[0] if single else out

    def forward(self, Q: np.ndarray) -> np.ndarray:
        """The solution in the paper's assembly mode, (N, 2): of all the roots
        in the domain, the one with the largest cos(theta) cos(psi), i.e. the one
        nearest the home pose theta = psi = 0 in that sense; NaN where there is none.
        Every Table 2 answer of the paper is in this mode (see docs/reproduction.md)."""
        Q = np.atleast_2d(np.asarray(Q, dtype=float))
        roots = solve_all(self, Q.reshape(-1, 2)).roots
        out = np.full((len(roots), 2), np.nan)
        for i, r in enumerate(roots):
            if len(r):
                score = np.sqrt(1 - r[:, 0] ** 2) * np.sqrt(1 - r[:, 1] ** 2)
                out[i] = r[np.argmax(score)]
        return out.reshape(Q.shape)

    # ------------------------------------------------------------------ eq. 6
    def constraint_residuals(self, X: np.ndarray, phi=0.0, platform: str = "rigid") -> np.ndarray:
        """The three constraint equations of eq. 6, divided by their scale
        (dimensionless), at poses X (..., N, 2) and rotation phi about z.

        l_i = Q n_i + p (eq. 4) with Q = Rz(phi) Ry(theta) Rx(psi) (eq. 1).
        ``platform="rigid"``: B1 at the end of the link A1B1 fixed to the platform
        along its z axis, p = R Q e_z (the mechanism as described in 1.1);
        ``platform="eq13"``: p from eq. 13 (the model of section 2).
        Returns (..., N, 3): (l1 x l2).x / (R b1), (l1 x l3).y / (R b2),
        (l1 x l2).(l1 x l3) / (R^2 b1 b2)."""
        X = np.asarray(X, dtype=float)
        s, t = X[..., 0], X[..., 1]
        c, d = np.sqrt(1 - s * s), np.sqrt(1 - t * t)
        phi = np.broadcast_to(np.asarray(phi, float), s.shape)
        Q = rot_zyx(phi, s, c, t, d)
        R, b1, b2 = (np.asarray(self.params[k], float)[..., None] for k in ("R", "b1", "b2"))
        if platform == "rigid":
            p = R * Q[..., :, 2]
        elif platform == "eq13":
            p = R * np.stack([s * d, s * t, c], -1)
        else:
            raise ValueError(f"unknown platform model {platform!r}")
        l1 = p
        l2 = b1 * Q[..., :, 0] + p
        l3 = b2 * Q[..., :, 1] + p
        c12 = np.cross(l1, l2)
        c13 = np.cross(l1, l3)
        R0, b10, b20 = R[..., 0], b1[..., 0], b2[..., 0]
        return np.stack([c12[..., 0] / (R0 * b10), c13[..., 1] / (R0 * b20),
                         np.sum(c12 * c13, -1) / (R0 ** 2 * b10 * b20)], -1)


def joint_screws(alpha: float, beta: float, params: Mapping[str, float] | None = None) -> dict:
    """The mechanism of section 1.1 built from its joints (not the model of
    section 2), at the configuration reached by turning the UPR chain's
    U joint by ``alpha`` about x1 and the platform by ``beta`` about the U's
    second axis u2 = Rx(alpha) y: platform orientation Q = Rx(alpha) Ry(beta),
    B1 = Q (0, 0, R) at the end of the link A1B1 fixed to the platform.

    Returns ``chains`` (the joint twists of S, UPR, UPS as (k, 6) arrays, in
    optdesign.screws conventions), ``actives`` (the prismatic joints), ``Q``,
    the points ``A``, ``B`` (3, 3), and ``u2``.
    """
    from .. import screws

    p = dict(PAPER_PARAMETERS, **(params or {}))
    ca_, sa_, cb_, sb_ = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    Rx = np.array([[1, 0, 0], [0, ca_, -sa_], [0, sa_, ca_]])
    Ry = np.array([[cb_, 0, sb_], [0, 1, 0], [-sb_, 0, cb_]])
    Q = Rx @ Ry
    A = np.array([[0, 0, 0], [p["a1"], 0, 0], [0, p["a2"], 0]], float)
    B = np.stack([Q @ [0, 0, p["R"]], Q @ [p["b1"], 0, p["R"]], Q @ [0, p["b2"], p["R"]]])
    ex, ey = np.eye(3)[0], np.eye(3)[1]
    u2 = Rx @ ey
    d2 = B[1] - A[1]
    d3 = B[2] - A[2]
    u3 = np.cross(ey, d3)
    S = screws.spherical(A[0])
    UPR = np.stack([screws.revolute(ex, A[1]), screws.revolute(u2, A[1]), screws.prismatic(d2),
                    screws.revolute(u2, B[1])])
    UPS = np.concatenate([np.stack([screws.revolute(ey, A[2]), screws.revolute(u3, A[2]),
                                    screws.prismatic(d3)]), screws.spherical(B[2])])
    return {"chains": [S, UPR, UPS], "actives": [None, 2, 2], "Q": Q, "A": A, "B": B, "u2": u2}


def rot_zyx(phi, s, c, t, d) -> np.ndarray:
    """Rz(phi) Ry(theta) Rx(psi) (eq. 1) from phi and the sines/cosines of theta, psi."""
    cf, sf = np.cos(phi), np.sin(phi)
    return np.stack([
        np.stack([cf * c, cf * s * t - sf * d, cf * s * d + sf * t], -1),
        np.stack([sf * c, sf * s * t + cf * d, sf * s * d - cf * t], -1),
        np.stack([-s, c * t, c * d], -1),
    ], -2)


# ---------------------------------------------------------------------- forward kinematics
# q_i^2 - Q_i^2 as trigonometric polynomials in (theta, psi) (eq. 14), term by
# term: coefficient * sin^a(theta) cos^b(theta) sin^e(psi) cos^f(psi).
_TERMS1 = np.array([[0, 0, 0, 0], [0, 1, 0, 0], [1, 1, 0, 1], [1, 0, 0, 1], [1, 1, 0, 0]])
_TERMS2 = np.array([[0, 0, 0, 0], [0, 0, 0, 1], [1, 0, 1, 0], [2, 0, 1, 1], [1, 0, 1, 1], [0, 2, 1, 0]])


def _coefficients(mech: UpsUprS, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def solve_all(mech: UpsUprS, Q: np.ndarray, n0: int = 8, min_width: float = 1e-9,
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


def ga_forward(mech: UpsUprS, q, population: int = 50, generations: int = 100, seed: int = 1) -> np.ndarray:
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
def symbolic_model():
    """Closure equations f = q_i^2 - |l_i - m_i|^2 with x = (sin theta, sin psi),
    for the CasADi route (Jacobian by AD, Newton forward kinematics)."""
    import casadi as ca

    from ..symbolic import SymbolicModel

    def closure(x, q, p):
        s, t = x[0], x[1]
        c, d = ca.sqrt(1 - s ** 2), ca.sqrt(1 - t ** 2)
        P = p["R"] * ca.vertcat(s * d, s * t, c)
        v2 = P + ca.vertcat(p["b1"] * c - p["a1"], 0, -p["b1"] * s)
        v3 = P + ca.vertcat(p["b2"] * s * t, p["b2"] * d - p["a2"], p["b2"] * c * t)
        return ca.vertcat(q[0] ** 2 - ca.sumsqr(v2), q[1] ** 2 - ca.sumsqr(v3))

    return SymbolicModel(2, 2, ("R", "a1", "a2", "b1", "b2"), closure)
