"""The 3-SPS-S spherical (three-rotation) mechanism (seed paper 004, Zhang et al. 2012).

Geometry (section 1.1, 2.1):

* both frames have their origin at W, the centre of the middle spherical
  joint; the base frame's X axis is parallel to O B1 (O the base centre), Z up;
* base joints ``B_i = (r_B cos g_i, r_B sin g_i, -h_B)``, g_i = 0, 120, 240 deg
  (the base lies h_B below W);
* platform joints in the platform frame
  ``P_i = (r_b cos(g_i + delta), r_b sin(g_i + delta), h_o)``: the platform lies
  h_o above W (the paper names h_o but gives no value) and its triangle is
  turned by ``delta`` about z relative to the base triangle (the paper's
  x axis "parallel to P P1" gives delta = 0; the figure is not in the text);
* orientation ``Q = Rz(phi) Ry(theta) Rx(psi)`` (X-Y-Z RPY angles), pose
  ``X = (psi, theta, phi)`` in radians;
* leg vectors ``L_i = Q P_i - B_i``, lengths ``l_i = |L_i|`` (eq. 2-3);
* Jacobian (eq. 10): rows ``(b_i x q_i)^T`` with ``b_i = Q P_i`` and
  ``q_i = L_i / l_i``, so that ``ldot = J omega`` with omega the platform's
  angular velocity in the base frame.  :meth:`SpsS.jacobian_euler` gives
  ``dl/dX = J E(X)`` for the RPY rates.

Indices (section 3): local stiffness = diagonal of ``K_L = k J^T J`` (eq. 12,
index kind ``axis_stiffness``), dexterity ``1/(||J||_F ||J^-1||_F)`` (eq. 16),
driving index ``sqrt(det(J^T J))`` (eq. 17).  Parameters r_b, r_B, h_B, h_o in
metres, delta in radians, k (leg stiffness) in N/m, so K_L is in N m / rad.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from . import register
from .base import ExtraObjective, Mechanism
from .params import Param

_G = np.radians([0.0, 120.0, 240.0])

def rpy(X: np.ndarray) -> np.ndarray:
    """Q = Rz(phi) Ry(theta) Rx(psi) for X = (psi, theta, phi) (..., 3) -> (..., 3, 3)."""
    X = np.asarray(X, dtype=float)
    cps, sps = np.cos(X[..., 0]), np.sin(X[..., 0])
    cth, sth = np.cos(X[..., 1]), np.sin(X[..., 1])
    cph, sph = np.cos(X[..., 2]), np.sin(X[..., 2])
    return np.stack([
        np.stack([cph * cth, cph * sth * sps - sph * cps, cph * sth * cps + sps * sph], -1),
        np.stack([sph * cth, sph * sth * sps + cph * cps, sph * sth * cps - cph * sps], -1),
        np.stack([-sth, cth * sps, cth * cps], -1),
    ], -2)


def euler_rate_map(X: np.ndarray) -> np.ndarray:
    """E(X) (..., 3, 3) with omega = E (psi_dot, theta_dot, phi_dot):
    columns Rz(phi) Ry(theta) x, Rz(phi) y, z."""
    X = np.asarray(X, dtype=float)
    cth, sth = np.cos(X[..., 1]), np.sin(X[..., 1])
    cph, sph = np.cos(X[..., 2]), np.sin(X[..., 2])
    z = np.zeros_like(cth)
    c1 = np.stack([cph * cth, sph * cth, -sth], -1)
    c2 = np.stack([-sph, cph, z], -1)
    c3 = np.stack([z, z, z + 1.0], -1)
    return np.stack([c1, c2, c3], -1)


def _p(a, k: int) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return a.reshape(a.shape + (1,) * k)


def _base_radius(p) -> np.ndarray:
    return np.asarray(p["r_B"], dtype=float)


def _overall_radius(p) -> np.ndarray:
    return np.maximum(np.asarray(p["r_B"], float), np.asarray(p["r_b"], float))


@register
class SpsS(Mechanism):
    """3-SPS-S orientation mechanism; pose (psi, theta, phi) in rad, legs (l1, l2, l3) in m.

    >>> mech = SpsS(r_b=0.4, r_B=0.8, h_B=0.31, h_o=0.0)
    >>> mech.inverse(np.zeros((1, 3))).round(4)
    array([[0.5061, 0.5061, 0.5061]])
    """

    name = "sps_s"
    pose_names = ("psi", "theta", "phi")
    actuator_names = ("l1", "l2", "l3")
    parameters = (
        Param("r_b", "length", 0.4, design=True, low=0.0, low_open=True, doc="platform joint circle radius"),
        Param("r_B", "length", 0.8, design=True, low=0.0, low_open=True, doc="base joint circle radius"),
        Param("h_B", "length", 0.31, design=True, low=0.0, low_open=True, doc="depth of the base below the centre W"),
        Param("h_o", "length", 0.0, design=True, doc="height of the platform above W (the paper gives none)"),
        #: leg stiffness, our assumption (see docs/mechanisms/sps_s.md)
        Param("k", "stiffness", 1000.0, low=0.0, low_open=True, doc="leg stiffness"),
        Param("delta", "angle", 0.0, doc="turn of the platform triangle relative to the base one"),
    )
    extra_objectives = {
        "base_radius": ExtraObjective(_base_radius, "min", "base joint circle radius r_B (the footprint of the base)",
                                      "m", ("r_B",)),
        "overall_radius": ExtraObjective(_overall_radius, "min", "max(r_b, r_B) (the plan-view envelope)", "m",
                                         ("r_b", "r_B")),
    }
    example = {  # configs/sps_s_opt.yaml: a turned platform triangle, +-10 deg in each angle
        "parameters": {"delta": {"value": 30, "unit": "deg"}},
        "design_variables": {"r_b": {"value": 0.4, "bounds": [0.2, 0.6]}, "r_B": {"value": 0.8, "bounds": [0.5, 1.2]},
                             "h_B": {"value": 0.31, "bounds": [0.15, 0.5]}, "h_o": {"value": 0.0, "bounds": [-0.1, 0.4]}},
        "workspace": {"type": "box", "unit": "deg", "axes": {"psi": [-10, 10], "theta": [-10, 10], "phi": [-10, 10]},
                      "sampling": "grid", "points_per_axis": 5},
        "indices": {"dexterity": {"kind": "dexterity"}, "stiffness": {"kind": "stiffness"},
                    "driving": {"kind": "driving"}},
    }
    supported_indices = ("axis_stiffness", "stiffness", "dexterity", "isotropy", "driving", "manipulability")
    angular_axes = ("psi", "theta", "phi")

    @classmethod
    def check_design(cls, design: Mapping[str, float]):
        if "h_o" in design and "h_B" in design and design["h_o"] <= -design["h_B"]:
            return "h_o", f"expected the platform above the base (h_o > -h_B), got h_o = {design['h_o']:g}, h_B = {design['h_B']:g}"
        return None

    # ------------------------------------------------------------------ geometry
    def base_points(self) -> np.ndarray:
        """B_i (design..., 3, 3) in the base frame."""
        rB, hB = _p(self.r_B, 1), _p(self.h_B, 1)
        x = rB * np.cos(_G) + 0 * hB
        y = rB * np.sin(_G) + 0 * hB
        return np.stack([x, y, -hB + 0 * x], -1)

    def platform_points_local(self) -> np.ndarray:
        """P_i (design..., 3, 3) in the platform frame."""
        rb, ho, de = _p(self.r_b, 1), _p(self.h_o, 1), _p(self.delta, 1)
        g = _G + de + 0 * rb + 0 * ho
        return np.stack([rb * np.cos(g), rb * np.sin(g), ho + 0 * g], -1)

    def legs(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """b_i = Q P_i (..., N, 3, 3), leg vectors L_i, lengths l_i (..., N, 3)
        and unit vectors q_i, at poses X (..., N, 3)."""
        Q = rpy(X)                                                        # (.., N, 3, 3)
        P = self.platform_points_local()                                  # (D.., 3, 3), D.. spans N
        B = self.base_points()
        b = np.einsum("...jk,...ik->...ij", Q, P)                        # (D.., N, 3 legs, 3)
        L = b - B
        l = np.linalg.norm(L, axis=-1)
        return {"b": b, "L": L, "l": l, "q": L / l[..., None], "Q": Q}

    def drawing(self, X: np.ndarray) -> dict:
        """The drawable points of one design at orientations X (N, 3) (see
        :meth:`Mechanism.drawing`): legs B_i -> b_i (length l_i, the actuator
        value), the central spherical joint at the origin, the platform triangle b_i."""
        X = np.asarray(X, dtype=float)
        g = self.legs(X)
        B = np.broadcast_to(self.base_points(), g["b"].shape)
        legs = [np.stack([B[:, i], g["b"][:, i]], axis=1) for i in range(3)]
        centre = np.zeros((X.shape[0], 1, 3))
        return {"base": B.copy(), "platform": g["b"], "joints": np.concatenate([B, g["b"], centre], 1),
                "legs": legs, "rods": np.zeros((X.shape[0], 0, 2, 3)), "rod_lengths": np.zeros(0)}

    # ------------------------------------------------------------------ kinematics
    def inverse(self, X: np.ndarray) -> np.ndarray:
        """Leg lengths (eq. 2-3), (..., N, 3)."""
        return self.legs(X)["l"]

    def reachable(self, X: np.ndarray) -> np.ndarray:
        return np.all(np.isfinite(self.inverse(X)), axis=-1)

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """J (..., N, 3, 3), rows (b_i x q_i)^T (eq. 10): ldot = J omega."""
        g = self.legs(X)
        return np.cross(g["b"], g["q"])

    def jacobian_euler(self, X: np.ndarray) -> np.ndarray:
        """dl/dX (..., N, 3, 3) for X = (psi, theta, phi): J E(X)."""
        return self.jacobian(X) @ euler_rate_map(np.asarray(X, float))

    def local_stiffness(self, X: np.ndarray) -> np.ndarray:
        """Diagonal of K_L = k J^T J (eq. 12), (..., N, 3): directions psi, theta, phi
        (rotations about the base X, Y, Z axes), N m / rad."""
        J = self.jacobian(X)
        return _p(self.k, 1) * np.sum(J * J, axis=-2)

    def forward(self, Q: np.ndarray, X0: np.ndarray | None = None) -> np.ndarray:
        """Forward kinematics by Newton on the closure equations (CasADi,
        :func:`symbolic_model`), (..., N, 3); NaN where Newton does not converge.

        Newton starts from X0 (default: the home pose 0) and from X0 +- 0.05 rad
        on each axis (the home pose is singular when delta = 0, so Newton from it
        alone can stall); of the converged answers the one nearest X0 is kept.
        Several poses can have the same leg lengths (with delta = 0, (0, 0, phi)
        and (0, 0, -phi)); the answer is then the one nearest X0."""
        Q = np.asarray(Q, dtype=float)
        shape = np.broadcast_shapes(Q.shape[:-1], self.design_shape)
        Qf = np.broadcast_to(Q, shape + (3,)).reshape(-1, 3)
        n = Qf.shape[0]
        X0 = np.zeros_like(Qf) if X0 is None else np.broadcast_to(np.asarray(X0, float), shape + (3,)).reshape(-1, 3)
        offs = np.concatenate([np.zeros((1, 3)), 0.05 * np.eye(3), -0.05 * np.eye(3)])
        starts = (X0[None] + offs[:, None]).reshape(-1, 3)
        params = {k: np.tile(np.broadcast_to(v, shape).ravel(), len(offs)) if v.ndim else float(v)
                  for k, v in self.params.items()}
        with np.errstate(all="ignore"):
            X, ok = _model().forward_newton(np.tile(Qf, (len(offs), 1)), starts, params)
        X = X.reshape(len(offs), n, 3)
        ok = ok.reshape(len(offs), n)
        dist = np.where(ok, np.linalg.norm(X - X0[None], axis=-1), np.inf)
        best = np.argmin(dist, axis=0)
        out = X[best, np.arange(n)]
        out = np.where(np.isfinite(dist[best, np.arange(n)])[:, None], out, np.nan)
        return out.reshape(shape + (3,))


_MODEL = None


def _model():
    global _MODEL
    if _MODEL is None:
        _MODEL = symbolic_model()
    return _MODEL


def symbolic_model():
    """Closure equations f_i = l_i^2 - |Q(x) P_i - B_i|^2, x = (psi, theta, phi),
    for the CasADi route (dl/dx by AD, Newton forward kinematics)."""
    import casadi as ca

    from ..symbolic import SymbolicModel

    def Rx(a):
        return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, ca.cos(a), -ca.sin(a)), ca.horzcat(0, ca.sin(a), ca.cos(a)))

    def Ry(a):
        return ca.vertcat(ca.horzcat(ca.cos(a), 0, ca.sin(a)), ca.horzcat(0, 1, 0), ca.horzcat(-ca.sin(a), 0, ca.cos(a)))

    def Rz(a):
        return ca.vertcat(ca.horzcat(ca.cos(a), -ca.sin(a), 0), ca.horzcat(ca.sin(a), ca.cos(a), 0), ca.horzcat(0, 0, 1))

    def closure(x, q, p):
        Q = Rz(x[2]) @ Ry(x[1]) @ Rx(x[0])
        out = []
        for i, g in enumerate(_G):
            P = ca.vertcat(p["r_b"] * ca.cos(g + p["delta"]), p["r_b"] * ca.sin(g + p["delta"]), p["h_o"])
            B = ca.vertcat(p["r_B"] * np.cos(g), p["r_B"] * np.sin(g), -p["h_B"])
            out.append(q[i] ** 2 - ca.sumsqr(Q @ P - B))
        return ca.vertcat(*out)

    return SymbolicModel(3, 3, ("r_b", "r_B", "h_B", "h_o", "delta", "k"), closure)
