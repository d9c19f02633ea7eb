"""The 3-P(4S) translational vibration table (seed paper 001, Zhao et al. 2017).

Geometry (section 1.1, with the sign fix recorded in docs/reproduction.md):

* base frame {O}: origin at the centre of the base triangle, z up;
* branch i (gamma_i = 0, 120, 240 deg) has its prismatic rail starting at
  ``u_i = r_b e_i`` with ``e_i = (cos gamma_i, sin gamma_i, 0)`` and running along
  ``m_i = R(z, alpha_i) R(x, +phi) y = -cos(phi) e_i + sin(phi) z`` (inward and
  upward; alpha_i = gamma_i + 90 deg).  The paper prints R(x, -phi), with which
  the rails point inward and downward and no branch reaches the platform;
* the slider sits at ``c_i = u_i + q_i m_i`` (q_i the stroke, eq. 3);
* the 4S parallelogram of each branch is equivalent to one rod c_i d_i of length
  L (eq. 4); its top midpoint is ``d_i = p + rho e_i`` with
  ``rho = r_a cos(theta)``, ``theta = asin(d / (2 r_a))`` (eq. 1);
* the platform only translates (p = platform centre).

Inverse kinematics (eq. 5): ``q_i = m_i.w_i - sqrt(L^2 - |w_i|^2 + (m_i.w_i)^2)``
with ``w_i = p + (rho - r_b) e_i`` (the smaller root: the slider below the rod).

Everything is batched over poses and (broadcast) designs.
"""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from .. import register
from ..base import ExtraObjective, Mechanism
from ..params import Param
from .dynamics import (  # noqa: F401
    gravity_force,
    mass_coefficients,
    platform_mass,
    rod_angular_map,
    rod_velocity_map,
    solve_T,
    velocity_force,
    velocity_products,
)
from .geometry import E, T, Z, _col, _p, skew  # noqa: F401

#: the paper's mass data (section 2.4)
PAPER_MASSES = {
    "m_platform": 4.16,   # kg, upper platform
    "m_slider": 2.57,     # kg, each driven slider
    "m_rod": 1.59,        # kg, each of the two rods of a parallelogram
    "rod_Ixx": 0.0223,    # kg m^2, rod inertia about a transverse axis through its centre
    "rod_Izz": 1.276e-4,  # kg m^2, rod inertia about its own axis (no spin: does not enter)
}

def _base_radius(p) -> np.ndarray:
    return np.asarray(p["r_b"], dtype=float)


def _overall_radius(p) -> np.ndarray:
    return np.maximum(np.asarray(p["r_b"], float), np.asarray(p["r_a"], float))


@register
class P4S(Mechanism):
    """3-P(4S) parallel mechanism (three translations).

    Design parameters (SI): ``r_a`` platform circumradius, ``r_b`` base
    circumradius, ``L`` rod length, ``d`` short side of the parallelogram,
    ``phi`` rail inclination (rad).  Fixed parameters: the masses and rod
    inertia of section 2.4, ``g`` (m/s^2), joint stiffness ``k`` (N/m) and
    ``rods_per_branch`` (2: the two long sides of each parallelogram).

    >>> mech = P4S(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=np.radians(30))
    >>> mech.inverse(np.array([[0.0, 0.0, 0.592]])).round(3)
    array([[0.432, 0.432, 0.432]])
    """

    name = "p4s"
    pose_names = ("x", "y", "z")
    actuator_names = ("l1", "l2", "l3")
    parameters = (
        Param("r_a", "length", design=True, low=0.0, low_open=True, doc="platform circumradius"),
        Param("r_b", "length", design=True, low=0.0, low_open=True, doc="base circumradius"),
        Param("L", "length", design=True, low=0.0, low_open=True, doc="rod length of the parallelograms"),
        Param("d", "length", design=True, low=0.0, low_open=True, doc="short side of the parallelograms"),
        Param("phi", "angle", design=True, low=0.0, high=math.pi / 2, low_open=True, high_open=True,
              doc="rail inclination from the base plane"),
        Param("m_platform", "mass", PAPER_MASSES["m_platform"], low=0.0, doc="upper platform"),
        Param("m_slider", "mass", PAPER_MASSES["m_slider"], low=0.0, doc="each driven slider"),
        Param("m_rod", "mass", PAPER_MASSES["m_rod"], low=0.0, doc="each rod of a parallelogram"),
        Param("rod_Ixx", "inertia", PAPER_MASSES["rod_Ixx"], low=0.0, doc="rod inertia about a transverse axis"),
        Param("rod_Izz", "inertia", PAPER_MASSES["rod_Izz"], low=0.0, doc="rod inertia about its axis"),
        Param("g", "acceleration", 9.81, low=0.0, doc="gravity"),
        Param("k", "stiffness", 1.0, low=0.0, low_open=True, doc="joint stiffness of K = J^T k J"),
        Param("rods_per_branch", "count", 2.0, low=0.0, doc="rods carrying mass in each parallelogram"),
    )
    extra_objectives = {
        "base_radius": ExtraObjective(_base_radius, "min", "base circumradius r_b (the footprint of the base)",
                                      "m", ("r_b",)),
        "overall_radius": ExtraObjective(_overall_radius, "min", "max(r_a, r_b) (the plan-view envelope)", "m",
                                         ("r_a", "r_b")),
    }
    multibody_check = "optdesign.mechanisms.p4s.mujoco"
    example = {  # the paper's design box and workspace plane (configs/p4s_paper.yaml)
        "design_variables": {"r_a": {"value": 0.25, "bounds": [0.21, 0.29]},
                             "r_b": {"value": 0.67, "bounds": [0.63, 0.71]},
                             "L": {"value": 0.38}, "d": {"value": 0.12},
                             "phi": {"value": 30, "bounds": [25, 35], "unit": "deg"}},
        "workspace": {"type": "box", "axes": {"x": [-0.05, 0.05], "y": [-0.05, 0.05], "z": 0.57},
                      "sampling": "grid", "step": 0.01},
        "indices": {"dynamic": {"kind": "dynamic"}, "stiffness": {"kind": "stiffness"},
                    "isotropy": {"kind": "isotropy"}},
    }
    supported_indices = ("dynamic", "stiffness", "isotropy", "dexterity", "manipulability", "driving")

    @classmethod
    def check_design(cls, design: Mapping[str, float]):
        if "d" in design and "r_a" in design and design["d"] >= 2 * design["r_a"]:
            return "d", f"expected d < 2 r_a (theta = asin(d / 2 r_a)), got d = {design['d']:g}, r_a = {design['r_a']:g}"
        return None

    # ------------------------------------------------------------------ geometry
    @property
    def rho(self) -> np.ndarray:
        """Distance from the platform centre to a top midpoint d_i: r_a cos(theta)."""
        return np.sqrt(np.maximum(self.r_a ** 2 - 0.25 * self.d ** 2, 0.0))

    def rail_directions(self) -> np.ndarray:
        """m_i, unit vectors along the rails, shape (design..., 3, 3)."""
        return -_col(np.cos(self.phi)) * E + _col(np.sin(self.phi)) * Z

    def branch_state(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """Per-branch quantities at poses X (..., N, 3): strokes q, rod unit
        vectors n, rail vectors m, s = n.m, all with a branch axis before the
        component axis."""
        X = np.asarray(X, dtype=float)
        m = self.rail_directions()                                         # (D.., 3, 3)
        off = _col(self.rho - self.r_b)
        L = _p(self.L, 1)                                                  # (D.., 1)
        w = X[..., :, None, :] + off * E                                   # (D.., N, 3, 3)
        b = np.sum(m * w, axis=-1)                                         # (D.., N, 3)
        disc = L ** 2 - np.sum(w * w, axis=-1) + b ** 2
        ok = disc >= 0.0
        # a pose is reachable only if every branch is: otherwise all strokes NaN
        root = np.sqrt(np.where(np.all(ok, axis=-1, keepdims=True), disc, np.nan))
        q = b - root
        n = (w - q[..., None] * m) / L[..., None]
        s = root / L
        m = np.broadcast_to(m, n.shape)
        return {"q": q, "n": n, "m": m, "s": s, "w": w, "L": L, "reachable": np.all(ok, axis=-1)}

    # ------------------------------------------------------------------ kinematics
    def inverse(self, X: np.ndarray) -> np.ndarray:
        """Strokes (eq. 5) for platform positions X (..., N, 3); NaN where unreachable."""
        return self.state(X).q

    def reachable(self, X: np.ndarray) -> np.ndarray:
        """Boolean mask (..., N): every branch has a real inverse-kinematics root."""
        return self.state(X).reachable

    # the state at poses (:mod:`optdesign.mechanisms.state`): the branch state once
    def kinematic_core(self, X: np.ndarray) -> dict[str, np.ndarray]:
        return self.branch_state(X)

    def inverse_of(self, st) -> np.ndarray:
        return st.core["q"]

    def reachable_of(self, st) -> np.ndarray:
        return st.core["reachable"]

    def jacobian_of(self, st) -> np.ndarray:
        c = st.core
        return c["n"] / c["s"][..., None]

    def index_matrices_of(self, st, needs: set[str]) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        if "J" in needs:
            out["J"] = st.J
        if "M" in needs:
            c = st.core
            out["M"] = solve_T(c["n"] / c["s"][..., None], platform_mass(self, c))
        return out

    def forward(self, Q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Closed-form forward kinematics: the platform centre p for strokes Q (..., N, 3).

        p lies at distance L from the three sphere centres
        ``s_i = c_i - rho e_i = (r_b - rho) e_i + q_i m_i``; of the two mirror
        solutions the one above the plane of the centres is the assembly mode of
        the paper (platform above the sliders).  NaN where the spheres do not meet.
        ``out``: an optional array of the result's shape to write into (and return).
        """
        P = self._forward(Q)
        if out is not None:
            out[...] = P
            return out
        return P

    def forward_numpy(self, Q: np.ndarray) -> np.ndarray:
        """:meth:`forward` (the name the benchmarks and tests of the hand-written FK kernel used)."""
        return self._forward(Q)

    def _forward(self, Q: np.ndarray) -> np.ndarray:
        Q = np.asarray(Q, dtype=float)
        m = self.rail_directions()
        off = _col(self.r_b - self.rho)
        L = np.asarray(self.L, dtype=float)
        s = off * E + Q[..., :, None] * m                                   # (D.., N, 3, 3)
        s1, s2, s3 = s[..., 0, :], s[..., 1, :], s[..., 2, :]
        a1 = s2 - s1
        a2 = s3 - s1
        dd = np.sqrt(np.sum(a1 * a1, axis=-1))
        ex = a1 / dd[..., None]
        i = np.sum(ex * a2, axis=-1)
        ey = a2 - i[..., None] * ex
        j = np.sqrt(np.sum(ey * ey, axis=-1))
        ey = ey / j[..., None]
        ez = np.cross(ex, ey)
        x = 0.5 * dd
        y = 0.5 * (i * i + j * j) / j - i * x / j
        h2 = L ** 2 - x * x - y * y
        h = np.sqrt(np.where(h2 >= 0.0, h2, np.nan))
        h = np.where(ez[..., 2] >= 0.0, h, -h)
        p = s1 + x[..., None] * ex + y[..., None] * ey + h[..., None] * ez
        # one Newton step on the three sphere equations removes round-off of the
        # closed form (keeps 1e-15 m even for nearly collinear sphere centres)
        r = p[..., None, :] - s
        f = 0.5 * (np.sum(r * r, axis=-1) - L[..., None] ** 2)
        with np.errstate(all="ignore"):
            good = np.all(np.isfinite(r), axis=(-1, -2)) & (np.abs(np.linalg.det(np.where(np.isfinite(r), r, 0.0))) > 0)
            rs = np.where(good[..., None, None], r, np.eye(3))
            dp = np.linalg.solve(rs, np.where(good[..., None], f, 0.0)[..., None])[..., 0]
        ok = good & np.all(np.isfinite(dp), axis=-1) & np.isfinite(h)
        return np.where(ok[..., None], p - dp, p)

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """J (..., N, 3, 3) with qdot = J v: rows n_i^T / (n_i^T m_i) (eq. 8)."""
        return self.state(X).J

    def global_statistics(self, requests, X):
        """The engine's global indices on this mechanism's description (see :func:`.compiled.global_statistics`)."""
        return compiled.global_statistics(self, requests, X)

    def local_values(self, requests, X):
        """The engine's local values (see :func:`.compiled.local_values`)."""
        return compiled.local_values(self, requests, X)

    def local_values_at(self, requests, X):
        """The engine, each design at its own points (see :func:`.compiled.local_values_at`)."""
        return compiled.local_values_at(self, requests, X)

    def zoom_cond(self, request, base, reg, u, val, h, live, budget, grid, stop, tol):
        """The worst-case search's zoom in the engine (``Mechanism.zoom_cond``), or None."""
        if not compiled._flat(self):
            return None
        return compiled.described(self).zoom_cond(request, base, reg, u, val, h, live, budget, grid, stop, tol)

    @classmethod
    def specialize_kernels(cls) -> None:
        """The description's shape on the engine's specialized tier (``Mechanism.specialize_kernels``)."""
        from ..described.packing import kernel_spec

        from ... import engine

        engine.specialize(kernel_spec(compiled.SHAPE))

    def rod_angular_velocity_map(self, X: np.ndarray) -> np.ndarray:
        """J_omega_i (..., N, 3 branches, 3, 3): omega_i = J_omega_i v (eq. 9),
        ``(skew(n_i) - (n_i x m_i) n_i^T / (n_i.m_i)) / L``."""
        st = self.branch_state(X)
        return rod_angular_map(st)

    def rod_velocity_map(self, X: np.ndarray) -> np.ndarray:
        """J_v_i (..., N, 3 branches, 3, 3): rod-centre velocity = J_v_i v (eq. 11),
        ``(I + m_i n_i^T / (n_i.m_i)) / 2``."""
        st = self.branch_state(X)
        return rod_velocity_map(st)

    def velocity_product_terms(self, X: np.ndarray, V: np.ndarray) -> dict[str, np.ndarray]:
        """The velocity-product parts of the acceleration maps (eq. 13-15).

        Returns ``qdd`` (..., N, 3): the v^T H_i v term of the stroke
        accelerations, ``rod_center`` (..., N, 3, 3) and ``rod_angular``
        (..., N, 3, 3): the same for rod-centre and rod angular accelerations.
        With h_i = |v - qdot_i m_i|^2 / (L n_i.m_i) these are h_i, h_i m_i / 2
        and -h_i (n_i x m_i) / L.
        """
        st = self.branch_state(X)
        return velocity_products(st, np.asarray(V, dtype=float))

    def accelerations(self, X, V, A) -> np.ndarray:
        """Stroke accelerations qdd = J a + v^T H v (eq. 13), shape (..., N, 3)."""
        st = self.branch_state(X)
        J = st["n"] / st["s"][..., None]
        return np.einsum("...ij,...j->...i", J, A) + velocity_products(st, np.asarray(V, float))["qdd"]

    # ------------------------------------------------------------------ dynamics
    def platform_mass_matrix(self, X: np.ndarray) -> np.ndarray:
        """Symmetric mass matrix in platform coordinates, M_p (..., N, 3, 3), with
        kinetic energy T = v^T M_p v / 2 (platform, sliders, two rods per branch)."""
        st = self.branch_state(X)
        return platform_mass(self, st)

    def mass_matrix(self, X: np.ndarray) -> np.ndarray:
        """The M of eq. (23): actuator forces per unit platform acceleration,
        ``M = J^-T M_p`` (..., N, 3, 3), so that tau = M a + velocity + gravity terms."""
        return self.state(X).matrices({"M"})["M"]

    def velocity_term(self, X: np.ndarray, V: np.ndarray) -> np.ndarray:
        """Actuator forces from velocity products (the V^T N V of eq. 23), (..., N, 3)."""
        st = self.branch_state(X)
        J = st["n"] / st["s"][..., None]
        C = velocity_force(self, st, np.asarray(V, float))
        return solve_T(J, C[..., None])[..., 0]

    def gravity_term(self, X: np.ndarray) -> np.ndarray:
        """Actuator forces that hold the mechanism against gravity (tau^G), (..., N, 3)."""
        st = self.branch_state(X)
        J = st["n"] / st["s"][..., None]
        G = gravity_force(self, st)
        return solve_T(J, G[..., None])[..., 0]

    def actuator_forces(self, X: np.ndarray, V: np.ndarray, A: np.ndarray) -> np.ndarray:
        """Forces the three actuators apply (..., N, 3) for platform positions X,
        velocities V and accelerations A: ``tau = J^-T (M_p a + c(v) + g)``
        (eq. 23 with the d'Alembert sign, the factor 2 for the two rods of each
        branch and the energy-consistent gravity term; see docs/reproduction.md)."""
        st = self.branch_state(X)
        J = st["n"] / st["s"][..., None]
        A = np.asarray(A, dtype=float)
        F = (np.einsum("...ij,...j->...i", platform_mass(self, st), A)
             + velocity_force(self, st, np.asarray(V, float)) + gravity_force(self, st))
        return solve_T(J, F[..., None])[..., 0]

    # ------------------------------------------------------------------ bodies
    def body_positions(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """Positions of every body: ``platform`` (..., N, 3), ``sliders``
        (..., N, 3, 3), ``rods`` (..., N, 3 branches, 2 rods, 3) (rod centres),
        ``rod_axes`` (..., N, 3, 3) unit vectors along the rods, and the joint
        points ``c`` (slider midpoints) and ``d`` (platform midpoints)."""
        X = np.asarray(X, dtype=float)
        st = self.branch_state(X)
        c = _col(self.r_b) * E + st["q"][..., None] * st["m"]
        dpt = X[..., None, :] + _col(self.rho) * E
        half = 0.5 * _col(self.d) * T                                      # (D.., 3, 3)
        mid = 0.5 * (c + dpt)
        rods = np.stack([mid + half, mid - half], axis=-2)
        return {"platform": np.broadcast_to(X, dpt.shape[:-2] + (3,)), "sliders": c, "rods": rods,
                "rod_axes": st["n"], "c": c, "d": dpt}

    def enclosure(self):
        """The interval enclosure of this design's kinematics (:mod:`.enclosure`)."""
        from .enclosure import P4SEnclosure

        p = {k: np.asarray(getattr(self, k), dtype=float) for k in ("r_a", "r_b", "L", "d", "phi")}
        if any(v.size != 1 for v in p.values()):
            raise NotImplementedError("an enclosure is of one design at a time")
        return P4SEnclosure(**{k: float(v.reshape(())) for k, v in p.items()}).evaluate

    def drawing(self, X: np.ndarray) -> dict:
        """The drawable points of one design at platform positions X (N, 3) (see
        :meth:`Mechanism.drawing`): each leg runs from the rail's start u_i
        through the slider c_i to the top midpoint d_i; the rods are the two long
        sides of each parallelogram (length L); the platform is the hexagon of
        the six top joints d_i -+ (d / 2) t_i."""
        X = np.asarray(X, dtype=float)
        b = self.body_positions(X)
        c, dpt = b["c"], b["d"]                                            # (N, 3, 3)
        half = 0.5 * np.asarray(self.d, float) * T                          # (3, 3)
        u = np.broadcast_to(np.asarray(self.r_b, float) * E, c.shape)
        bad = ~np.all(np.isfinite(c), axis=(-1, -2))
        top = np.stack([dpt - half, dpt + half], axis=-2)                   # (N, 3, 2, 3)
        bottom = np.stack([c - half, c + half], axis=-2)
        top = np.where(bad[:, None, None, None], np.nan, top)
        rods = np.stack([bottom, top], axis=-2).reshape(X.shape[0], 6, 2, 3)
        legs = [np.stack([u[:, i], c[:, i], dpt[:, i]], axis=1) for i in range(3)]
        return {"base": u.copy(), "platform": top.reshape(X.shape[0], 6, 3),
                "joints": np.concatenate([u, c, top.reshape(X.shape[0], 6, 3), bottom.reshape(X.shape[0], 6, 3)], 1),
                "legs": legs, "rods": rods, "rod_lengths": np.full(6, float(self.L))}


from . import compiled  # noqa: E402  (the compiled path imports this module's helpers)
