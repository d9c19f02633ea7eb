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
from .base import Mechanism

_G = np.radians([0.0, 120.0, 240.0])

#: section 4 of the paper: stiffness ranges (N m / rad) per direction at phi = 0 and -10 deg
PAPER_STIFFNESS = {
    ("phi", 0.0): {"psi": (100, 170), "theta": (130, 200), "phi": (0.6, 2.5)},
    ("phi", -10.0): {"psi": (90, 160), "theta": (130, 190), "phi": (0.5, 2.3)},
}
#: section 4.2: dexterity ranges on the slices phi = 10, psi = 10, theta = 10 deg
PAPER_DEXTERITY = {("phi", 10.0): (0.1, 0.161), ("psi", 10.0): (0.02, 0.15), ("theta", 10.0): (0.02, 0.16)}
#: Table 1: driving index ranges on the slices (axis, value in deg)
PAPER_DRIVING = {
    ("psi", -10.0): (0.002, 0.014), ("psi", 0.0): (0.001, 0.012), ("psi", 10.0): (0.001, 0.011),
    ("theta", -10.0): (0.002, 0.011), ("theta", 0.0): (0.001, 0.012), ("theta", 10.0): (0.001, 0.014),
    ("phi", -10.0): (0.007, 0.013), ("phi", 0.0): (0.0003, 0.0180), ("phi", 10.0): (0.008, 0.014),
}


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
    design_parameters = ("r_b", "r_B", "h_B", "h_o")
    design_defaults = {"r_b": 0.4, "r_B": 0.8, "h_B": 0.31, "h_o": 0.0}
    length_parameters = ("r_b", "r_B", "h_B")
    #: k: leg stiffness (N/m), our assumption (see docs/mechanisms/sps_s.md);
    #: delta: turn of the platform triangle relative to the base one (rad)
    fixed_parameters = {"k": 1000.0, "delta": 0.0}
    positive_parameters = ("k",)
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


# ---------------------------------------------------------------------- section 4 ranges
def slice_poses(axis: str, value_deg: float, resolution: int = 21, half_range_deg: float = 10.0) -> np.ndarray:
    """Poses (n^2, 3) of a slice of the +-10 deg cube: ``axis`` fixed at
    ``value_deg``, the other two angles on an n x n grid."""
    g = np.radians(np.linspace(-half_range_deg, half_range_deg, resolution))
    i = SpsS.pose_names.index(axis)
    A, B = np.meshgrid(g, g, indexing="ij")
    cols = [A.ravel(), B.ravel()]
    cols.insert(i, np.full(A.size, np.radians(value_deg)))
    return np.stack(cols, -1)


def paper_ranges(mech: SpsS, resolution: int = 21, jacobian: str = "omega") -> dict[str, np.ndarray]:
    """Our (min, max) of every range section 4 reports, for a (population of)
    design(s): ``stiffness`` (design..., 2 slices, 3 directions, 2), ``dexterity``
    (design..., 3, 2), ``driving`` (design..., 9, 2), in the order of
    PAPER_STIFFNESS, PAPER_DEXTERITY, PAPER_DRIVING.  ``jacobian="omega"``: eq. 10;
    ``"euler"``: the Jacobian for the RPY rates, J E (the other reading of
    "the directions psi, theta, phi")."""
    from ..indices import local_index

    def J_of(X):
        return mech.jacobian(X) if jacobian == "omega" else mech.jacobian_euler(X)

    def rng_(v):
        return np.stack([v.min(axis=-1), v.max(axis=-1)], -1)

    st = []
    for axis, val in PAPER_STIFFNESS:
        J = J_of(slice_poses(axis, val, resolution))
        K = _p(mech.k, 1) * np.sum(J * J, axis=-2)                    # (D.., N, 3)
        st.append(rng_(np.moveaxis(K, -1, -2)))                        # (D.., 3, 2)
    dx = [rng_(local_index("dexterity", J=J_of(slice_poses(a, v, resolution)))) for a, v in PAPER_DEXTERITY]
    dr = [rng_(local_index("driving", J=J_of(slice_poses(a, v, resolution)))) for a, v in PAPER_DRIVING]
    return {"stiffness": np.stack(st, -3), "dexterity": np.stack(dx, -2), "driving": np.stack(dr, -2)}


def paper_targets() -> dict[str, np.ndarray]:
    """The paper's ranges, shaped as :func:`paper_ranges`."""
    st = np.array([[v[d] for d in ("psi", "theta", "phi")] for v in PAPER_STIFFNESS.values()], float)
    return {"stiffness": st, "dexterity": np.array(list(PAPER_DEXTERITY.values()), float),
            "driving": np.array(list(PAPER_DRIVING.values()), float)}


def log_misfit(ours: dict[str, np.ndarray], groups=("stiffness", "dexterity", "driving"),
               fit_k: bool = True, ends=(0, 1)) -> tuple[np.ndarray, np.ndarray]:
    """The factor by which our ranges miss the paper's, exp(max |log(ours / paper)|)
    over the range ends of ``groups`` (``ends``: 0 the lower, 1 the upper ends),
    and the factor by which k must be scaled to reach it (stiffness is
    proportional to k, so the best scale is the midpoint of the log ratios).
    Returns (factor (design...), k_scale (design...))."""
    tgt = paper_targets()
    logs_k, logs = [], []
    for gname in groups:
        t = np.take(tgt[gname], ends, axis=-1)
        o = np.take(ours[gname], ends, axis=-1)
        dshape = o.shape[:o.ndim - t.ndim]
        with np.errstate(divide="ignore", invalid="ignore"):
            r = (np.log(t) - np.log(o)).reshape(dshape + (-1,))
        (logs_k if gname == "stiffness" else logs).append(r)
    with np.errstate(invalid="ignore"):
        shift = np.zeros(())
        if logs_k:
            lk = np.concatenate(logs_k, -1)
            shift = 0.5 * (lk.max(-1) + lk.min(-1)) if fit_k else np.zeros(lk.shape[:-1])
            shift = np.where(np.isfinite(shift), shift, 0.0)
            logs.append(lk - shift[..., None])
        allr = np.concatenate(logs, -1)
        allr = np.where(np.isfinite(allr), allr, np.inf)
        return np.exp(np.abs(allr).max(-1)), np.exp(shift)


def scan_paper_ranges(h_o_values, delta_values, resolution: int = 21, jacobian: str = "omega",
                      chunk: int = 400, **params) -> dict[str, np.ndarray]:
    """:func:`paper_ranges` over the grid h_o x delta (k = 1, so stiffness
    ranges are per unit leg stiffness), vectorized over the designs in chunks.
    Returns ``h_o``, ``delta`` (G,) and the ranges with a leading axis G."""
    H, D = np.meshgrid(np.asarray(h_o_values, float), np.asarray(delta_values, float), indexing="ij")
    H, D = H.ravel(), D.ravel()
    parts = []
    for a in range(0, H.size, chunk):
        mech = SpsS(h_o=H[a:a + chunk, None], delta=D[a:a + chunk, None], k=1.0, **params)
        parts.append(paper_ranges(mech, resolution, jacobian))
    out = {k: np.concatenate([p[k] for p in parts], 0) for k in parts[0]}
    out.update(h_o=H, delta=D)
    return out
