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
        ("a1", PAPER_PARAMETERS["a1"], "base offset of the UPR leg (A2 = (a1, 0, 0))"),
        ("a2", PAPER_PARAMETERS["a2"], "base offset of the UPS leg (A3 = (0, a2, 0))"),
        ("b1", PAPER_PARAMETERS["b1"], "platform offset of the UPR leg (B2)"),
        ("b2", PAPER_PARAMETERS["b2"], "platform offset of the UPS leg (B3)"))) + (
        Param("model", "switch", "printed", choices={"printed": 0.0, "rigid": 1.0},
              doc="printed: section 2 as printed (eq. 13, phi = 0; not a rigid motion); rigid: the mechanism of "
                  "section 1.1 (Q = Rx(alpha) Ry(beta), B1 fixed on the platform, the yaw parasitic), "
                  "optdesign/mechanisms/ups_upr_s_fk.py"),)
    pose_units = {"s_theta": "1", "s_psi": "1"}
    example = {  # configs/ups_upr_s_opt.yaml: +-40 % around the paper's structure parameters
        "design_variables": {"R": {"value": 260, "bounds": [160, 360], "unit": "mm"},
                             "a1": {"value": 150, "bounds": [90, 210], "unit": "mm"},
                             "a2": {"value": 150, "bounds": [90, 210], "unit": "mm"},
                             "b1": {"value": 150, "bounds": [90, 210], "unit": "mm"},
                             "b2": {"value": 100, "bounds": [60, 140], "unit": "mm"}},
        "workspace": {"type": "box", "axes": {"s_theta": [-0.5, 0.5], "s_psi": [-0.5, 0.5]},
                      "sampling": "grid", "points_per_axis": 11},
        "indices": {"dexterity": {"kind": "dexterity"}, "manipulability": {"kind": "manipulability"}},
    }
    supported_indices = ("isotropy", "dexterity", "manipulability")
    angular_axes = ()

    def __init__(self, **params):
        super().__init__(**params)
        m = np.unique(np.asarray(self.model, dtype=float))
        if m.size != 1 or m[0] not in (0.0, 1.0):
            raise ValueError(f"ups_upr_s: model must be 0 (printed) or 1 (rigid), got {self.model}")
        self.rigid = bool(m[0] == 1.0)

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
        if self.rigid:
            return _fk.rigid_inverse(self, X)
        g = self.legs(X)
        return np.stack([np.linalg.norm(g["v2"], axis=-1), np.linalg.norm(g["v3"], axis=-1)], -1)

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """J (..., N, 2, 2) = d(q2, q3)/d(sin theta, sin psi) (metres per unit sine).

        d q_i / d theta = v_i . dv_i/dtheta / q_i, and d/d(sin theta) =
        (1 / cos theta) d/dtheta (infinite at cos = 0, where the sine is not a
        coordinate)."""
        if self.rigid:
            return _fk.rigid_jacobian(self, X)
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
        if self.rigid:
            out = [_fk.rigid_roots(self, qq) for qq in Q]
        elif method == "ga":
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
        roots = ([_fk.rigid_roots(self, q) for q in Q.reshape(-1, 2)] if self.rigid
                 else solve_all(self, Q.reshape(-1, 2)).roots)
        out = np.full((len(roots), 2), np.nan)
        for i, r in enumerate(roots):
            if len(r):
                score = np.sqrt(1 - r[:, 0] ** 2) * np.sqrt(1 - r[:, 1] ** 2)
                out[i] = r[np.argmax(score)]
        return out.reshape(Q.shape)

    def yaw(self, X: np.ndarray) -> np.ndarray:
        """The rotation phi about z of Q = Rz(phi) Ry(theta) Rx(psi) at poses X: 0 in
        the printed model (section 1.2's conclusion), parasitic in the rigid one."""
        if self.rigid:
            return _fk.rigid_yaw(X)
        return np.zeros(np.broadcast_shapes(np.shape(X)[:-1], self.design_shape))

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
        printed = ca.vertcat(q[0] ** 2 - ca.sumsqr(v2), q[1] ** 2 - ca.sumsqr(v3))
        # section 1.1's rigid mechanism (optdesign/mechanisms/ups_upr_s_fk.py)
        sa = c * t
        al, be = ca.asin(sa), ca.atan2(s, c * d)
        R, a1, a2, b1, b2 = (p[k] for k in ("R", "a1", "a2", "b1", "b2"))
        rigid = ca.vertcat(q[0] ** 2 - (a1 ** 2 + b1 ** 2 + R ** 2 - 2 * a1 * (b1 * ca.cos(be) + R * ca.sin(be))),
                           q[1] ** 2 - (a2 ** 2 + b2 ** 2 + R ** 2
                                        - 2 * a2 * (b2 * ca.cos(al) - R * ca.sin(al) * ca.cos(be))))
        return ca.if_else(p["model"] > 0.5, rigid, printed)

    return SymbolicModel(2, 2, ("R", "a1", "a2", "b1", "b2", "model"), closure)


from .ups_upr_s_fk import ForwardSolution, ga_forward, solve_all  # noqa: E402,F401  (forward kinematics)
from . import ups_upr_s_fk as _fk  # noqa: E402  (and section 1.1's rigid mechanism)
