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

_GAMMA = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
#: e_i, the unit vectors from the centre to the branches (3 branches x 3 components)
E = np.stack([np.cos(_GAMMA), np.sin(_GAMMA), np.zeros(3)], axis=-1)
E[np.abs(E) < 1e-15] = 0.0
Z = np.array([0.0, 0.0, 1.0])
#: t_i = z x e_i, the direction of the short sides of the parallelogram
T = np.cross(Z, E)

#: the paper's mass data (section 2.4)
PAPER_MASSES = {
    "m_platform": 4.16,   # kg, upper platform
    "m_slider": 2.57,     # kg, each driven slider
    "m_rod": 1.59,        # kg, each of the two rods of a parallelogram
    "rod_Ixx": 0.0223,    # kg m^2, rod inertia about a transverse axis through its centre
    "rod_Izz": 1.276e-4,  # kg m^2, rod inertia about its own axis (no spin: does not enter)
}


def _col(a: np.ndarray) -> np.ndarray:
    """Parameter (design shape, which already spans the pose axis) -> shape
    (..., 1, 1) to broadcast over the (branch, component) axes."""
    return np.asarray(a, dtype=float)[..., None, None]


def skew(n: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrices of vectors (..., 3) -> (..., 3, 3): skew(a) b = a x b."""
    z = np.zeros_like(n[..., 0])
    return np.stack([
        np.stack([z, -n[..., 2], n[..., 1]], -1),
        np.stack([n[..., 2], z, -n[..., 0]], -1),
        np.stack([-n[..., 1], n[..., 0], z], -1),
    ], -2)


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
        "base_radius": ExtraObjective(lambda p: np.asarray(p["r_b"], dtype=float), "min",
                                      "base circumradius r_b (the footprint of the base)", "m", ("r_b",)),
        "overall_radius": ExtraObjective(
            lambda p: np.maximum(np.asarray(p["r_b"], float), np.asarray(p["r_a"], float)), "min",
            "max(r_a, r_b) (the plan-view envelope)", "m", ("r_a", "r_b")),
    }
    multibody_check = "optdesign.mechanisms.p4s.mujoco"
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
    # The public methods take the compiled path (:mod:`.compiled`) where it
    # applies and this numpy model otherwise (OPTDESIGN_FAST=0, no numba,
    # other design shapes); the compiled inverse kinematics and Jacobian are
    # bitwise the numpy model's, the forward kinematics equal to 1e-12 m.
    def inverse(self, X: np.ndarray) -> np.ndarray:
        """Strokes (eq. 5) for platform positions X (..., N, 3); NaN where unreachable."""
        Q = compiled.inverse(self, X)
        return self.branch_state(X)["q"] if Q is None else Q

    def reachable(self, X: np.ndarray) -> np.ndarray:
        """Boolean mask (..., N): every branch has a real inverse-kinematics root."""
        Q = compiled.inverse(self, X)
        return self.branch_state(X)["reachable"] if Q is None else ~np.isnan(Q[..., 0])

    def forward(self, Q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Closed-form forward kinematics: the platform centre p for strokes Q (..., N, 3).

        p lies at distance L from the three sphere centres
        ``s_i = c_i - rho e_i = (r_b - rho) e_i + q_i m_i``; of the two mirror
        solutions the one above the plane of the centres is the assembly mode of
        the paper (platform above the sliders).  NaN where the spheres do not meet.
        ``out``: an optional C-contiguous float (N, 3) array to write into (one
        design, compiled path).
        """
        P = compiled.forward(self, Q, out)
        if P is not None:
            return P
        P = self.forward_numpy(Q)
        if out is not None:
            out[...] = P
            return out
        return P

    def forward_numpy(self, Q: np.ndarray) -> np.ndarray:
        """:meth:`forward` in numpy (the reference of the compiled kernel)."""
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
        J = compiled.jacobian(self, X)
        if J is not None:
            return J
        st = self.branch_state(X)
        return st["n"] / st["s"][..., None]

    def global_statistics(self, requests, X):
        """The fused compiled kernel's global indices (see :func:`.compiled.global_statistics`)."""
        return compiled.global_statistics(self, requests, X)

    def local_values(self, requests, X):
        """The fused compiled kernel's local values (see :func:`.compiled.local_values`)."""
        return compiled.local_values(self, requests, X)

    def bare_kernel(self, X):
        """The fused kernel alone, for benchmarks (see :func:`.compiled.bare_kernel`)."""
        return compiled.bare_kernel(self, X)

    def rod_angular_velocity_map(self, X: np.ndarray) -> np.ndarray:
        """J_omega_i (..., N, 3 branches, 3, 3): omega_i = J_omega_i v (eq. 9),
        ``(skew(n_i) - (n_i x m_i) n_i^T / (n_i.m_i)) / L``."""
        st = self.branch_state(X)
        return _rod_angular_map(st)

    def rod_velocity_map(self, X: np.ndarray) -> np.ndarray:
        """J_v_i (..., N, 3 branches, 3, 3): rod-centre velocity = J_v_i v (eq. 11),
        ``(I + m_i n_i^T / (n_i.m_i)) / 2``."""
        st = self.branch_state(X)
        return _rod_velocity_map(st)

    def velocity_product_terms(self, X: np.ndarray, V: np.ndarray) -> dict[str, np.ndarray]:
        """The velocity-product parts of the acceleration maps (eq. 13-15).

        Returns ``qdd`` (..., N, 3): the v^T H_i v term of the stroke
        accelerations, ``rod_center`` (..., N, 3, 3) and ``rod_angular``
        (..., N, 3, 3): the same for rod-centre and rod angular accelerations.
        With h_i = |v - qdot_i m_i|^2 / (L n_i.m_i) these are h_i, h_i m_i / 2
        and -h_i (n_i x m_i) / L.
        """
        st = self.branch_state(X)
        return _velocity_products(st, np.asarray(V, dtype=float))

    def accelerations(self, X, V, A) -> np.ndarray:
        """Stroke accelerations qdd = J a + v^T H v (eq. 13), shape (..., N, 3)."""
        st = self.branch_state(X)
        J = st["n"] / st["s"][..., None]
        return np.einsum("...ij,...j->...i", J, A) + _velocity_products(st, np.asarray(V, float))["qdd"]

    # ------------------------------------------------------------------ dynamics
    def platform_mass_matrix(self, X: np.ndarray) -> np.ndarray:
        """Symmetric mass matrix in platform coordinates, M_p (..., N, 3, 3), with
        kinetic energy T = v^T M_p v / 2 (platform, sliders, two rods per branch)."""
        st = self.branch_state(X)
        return platform_mass(self, st)

    def mass_matrix(self, X: np.ndarray) -> np.ndarray:
        """The M of eq. (23): actuator forces per unit platform acceleration,
        ``M = J^-T M_p`` (..., N, 3, 3), so that tau = M a + velocity + gravity terms."""
        st = self.branch_state(X)
        Mp = platform_mass(self, st)
        J = st["n"] / st["s"][..., None]
        return solve_T(J, Mp)

    def velocity_term(self, X: np.ndarray, V: np.ndarray) -> np.ndarray:
        """Actuator forces from velocity products (the V^T N V of eq. 23), (..., N, 3)."""
        st = self.branch_state(X)
        J = st["n"] / st["s"][..., None]
        C = _velocity_force(self, st, np.asarray(V, float))
        return solve_T(J, C[..., None])[..., 0]

    def gravity_term(self, X: np.ndarray) -> np.ndarray:
        """Actuator forces that hold the mechanism against gravity (tau^G), (..., N, 3)."""
        st = self.branch_state(X)
        J = st["n"] / st["s"][..., None]
        G = _gravity_force(self, st)
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
             + _velocity_force(self, st, np.asarray(V, float)) + _gravity_force(self, st))
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


# ---------------------------------------------------------------------- helpers
def _p(a, k: int) -> np.ndarray:
    """A (broadcast) design parameter with k trailing axes added."""
    a = np.asarray(a, dtype=float)
    return a.reshape(a.shape + (1,) * k)


def solve_T(J: np.ndarray, B: np.ndarray) -> np.ndarray:
    """J^-T B for stacks of 3x3 J; NaN where J is singular or not finite."""
    Jt = np.swapaxes(J, -1, -2)
    good = np.all(np.isfinite(Jt), axis=(-1, -2)) & np.all(np.isfinite(B), axis=(-1, -2))
    Js = np.where(good[..., None, None], Jt, np.eye(3))
    Bs = np.where(good[..., None, None], B, 0.0)
    det = np.linalg.det(Js)
    good &= np.abs(det) > 0
    Js = np.where(good[..., None, None], Js, np.eye(3))
    out = np.linalg.solve(Js, Bs)
    return np.where(good[..., None, None], out, np.nan)


def _rod_angular_map(st) -> np.ndarray:
    n, m, s, L = st["n"], st["m"], st["s"], st["L"]
    nxm = np.cross(n, m)
    return (skew(n) - nxm[..., :, None] * n[..., None, :] / s[..., None, None]) / L[..., None, None]


def _rod_velocity_map(st) -> np.ndarray:
    n, m, s = st["n"], st["m"], st["s"]
    return 0.5 * (np.eye(3) + m[..., :, None] * n[..., None, :] / s[..., None, None])


def _velocity_products(st, V) -> dict[str, np.ndarray]:
    n, m, s, L = st["n"], st["m"], st["s"], st["L"]
    qd = np.sum(n * V[..., None, :], axis=-1) / s                 # (.., N, 3)
    rel = V[..., None, :] - qd[..., None] * m                       # L * ndot
    h = np.sum(rel * rel, axis=-1) / (L * s)
    return {"qdd": h, "rod_center": 0.5 * h[..., None] * m,
            "rod_angular": -h[..., None] * np.cross(n, m) / L[..., None]}


def mass_coefficients(mech: P4S) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(c0, alpha, beta) of the platform mass matrix in closed form,
    ``M_p = c0 I + sum_i [alpha u_i u_i^T + beta (m_i u_i^T + u_i m_i^T)]``
    with u_i = n_i / s_i the rows of J (eq. 8):
    ``c0 = m_p + 3 (m_r/4 + I_r/L^2)``, ``alpha = m_s + m_r/4 + I_r/L^2``,
    ``beta = m_r/4 - I_r/L^2`` (m_r, I_r: mass and transverse inertia of the
    rods of one branch).  It is ``m_p I + m_s J^T J + sum Jv_i^T m_r Jv_i +
    sum Jw_i^T I_r Jw_i`` (eq. 16-23) with |n_i| = |m_i| = 1: with
    Jv_i = (I + m_i u_i^T)/2 and Jw_i = (skew(n_i) - (n_i x m_i) u_i^T)/L,
    Jv^T Jv = (I + m u^T + u m^T + u u^T)/4 and
    Jw^T Jw = (I - m u^T - u m^T + u u^T)/L^2.  The compiled kernel
    (:mod:`.kernels`) uses the same coefficients."""
    L = np.asarray(mech.L, dtype=float)
    rods = np.asarray(mech.rods_per_branch, dtype=float) * np.asarray(mech.m_rod, dtype=float)
    irod = np.asarray(mech.rods_per_branch, dtype=float) * np.asarray(mech.rod_Ixx, dtype=float)
    mr4 = rods / 4.0
    il2 = irod / (L * L)
    c0 = np.asarray(mech.m_platform, dtype=float) + 3.0 * (mr4 + il2)
    alpha = np.asarray(mech.m_slider, dtype=float) + mr4 + il2
    beta = mr4 - il2
    return c0, alpha, beta


def platform_mass(mech: P4S, st) -> np.ndarray:
    """M_p (..., N, 3, 3) from the branch state (see :func:`mass_coefficients`)."""
    n, m, s = st["n"], st["m"], st["s"]
    u = n / s[..., None]                                            # rows J_i
    c0, alpha, beta = (_p(c, 2) for c in mass_coefficients(mech))
    uu = np.einsum("...bi,...bj->...ij", u, u)
    mu = np.einsum("...bi,...bj->...ij", m, u)
    return c0 * np.eye(3) + alpha * uu + beta * (mu + np.swapaxes(mu, -1, -2))


def _velocity_force(mech: P4S, st, V) -> np.ndarray:
    n, s = st["n"], st["s"]
    J = n / s[..., None]
    vp = _velocity_products(st, V)
    Jv = _rod_velocity_map(st)
    Jw = _rod_angular_map(st)
    me = _p(mech.m_slider, 2)
    rods = _p(mech.rods_per_branch * mech.m_rod, 2)
    Irod = _p(mech.rods_per_branch * mech.rod_Ixx, 2)
    C = np.sum(me * J * vp["qdd"][..., None], axis=-2)
    C = C + np.sum(rods * np.einsum("...bki,...bk->...bi", Jv, vp["rod_center"]), axis=-2)
    C = C + np.sum(Irod * np.einsum("...bki,...bk->...bi", Jw, vp["rod_angular"]), axis=-2)
    return C


def _gravity_force(mech: P4S, st) -> np.ndarray:
    n, m, s = st["n"], st["m"], st["s"]
    J = n / s[..., None]
    Jv = _rod_velocity_map(st)
    g = _p(mech.g, 2)
    me = _p(mech.m_slider, 2)
    rods = _p(mech.rods_per_branch * mech.m_rod, 2)
    G = _p(mech.m_platform * mech.g, 1) * Z
    G = G + np.sum(g * me * J * m[..., 2:3], axis=-2)
    G = G + np.sum(g * rods * Jv[..., 2, :], axis=-2)
    return G


# ---------------------------------------------------------------------- CasADi model
def symbolic_model():
    """The 3-P(4S) as closure equations and body energies for the CasADi route
    (optdesign.symbolic).  Independent of the hand-derived eq. 8-23 above: the
    energies are written from each body's own velocity (platform, three sliders,
    two rods per branch translating with their centres and rotating with
    omega = n x ndot), and every derivative comes from automatic differentiation.
    """
    import casadi as ca

    from ...symbolic import SymbolicModel

    names = ("r_a", "r_b", "L", "d", "phi", "m_platform", "m_slider", "m_rod", "rod_Ixx", "g", "rods_per_branch")

    def geometry(x, q, p):
        rho = ca.sqrt(p["r_a"] ** 2 - p["d"] ** 2 / 4)
        out = []
        for i in range(3):
            e = ca.DM(E[i])
            m = -ca.cos(p["phi"]) * e + ca.sin(p["phi"]) * ca.DM(Z)
            c = p["r_b"] * e + q[i] * m          # slider (bottom midpoint)
            dpt = x + rho * e                    # top midpoint on the platform
            out.append((c, dpt, m))
        return out

    def closure(x, q, p):
        return ca.vertcat(*[ca.sumsqr(dpt - c) - p["L"] ** 2 for c, dpt, _ in geometry(x, q, p)])

    def kinetic(x, q, xd, qd, p):
        T = 0.5 * p["m_platform"] * ca.sumsqr(xd)
        for i, (c, dpt, m) in enumerate(geometry(x, q, p)):
            cd = qd[i] * m                        # slider velocity
            T += 0.5 * p["m_slider"] * ca.sumsqr(cd)
            vmid = 0.5 * (cd + xd)                # rod centre velocity (both rods)
            n = (dpt - c) / p["L"]
            ndot = (xd - cd) / p["L"]
            omega = ca.cross(n, ndot)
            T += p["rods_per_branch"] * (0.5 * p["m_rod"] * ca.sumsqr(vmid) + 0.5 * p["rod_Ixx"] * ca.sumsqr(omega))
        return T

    def potential(x, q, p):
        V = p["m_platform"] * p["g"] * x[2]
        for i, (c, dpt, m) in enumerate(geometry(x, q, p)):
            V += p["m_slider"] * p["g"] * c[2]
            V += p["rods_per_branch"] * p["m_rod"] * p["g"] * 0.5 * (c[2] + dpt[2])
        return V

    return SymbolicModel(3, 3, names, closure, kinetic, potential)


from . import compiled  # noqa: E402  (the compiled path imports this module's helpers)
