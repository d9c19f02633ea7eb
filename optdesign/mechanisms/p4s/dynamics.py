"""The 3-P(4S)'s velocity maps and dynamics terms (eq. 9-23) as functions of a
branch state (:meth:`P4S.branch_state`): the numpy model's building blocks,
shared with the compiled path's LAPACK hand-off (:mod:`.compiled`)."""
from __future__ import annotations

import numpy as np

from .geometry import Z, _p, skew

__all__ = ["mass_coefficients", "platform_mass", "solve_T", "velocity_force", "gravity_force",
           "rod_angular_map", "rod_velocity_map", "velocity_products"]


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


def rod_angular_map(st) -> np.ndarray:
    n, m, s, L = st["n"], st["m"], st["s"], st["L"]
    nxm = np.cross(n, m)
    return (skew(n) - nxm[..., :, None] * n[..., None, :] / s[..., None, None]) / L[..., None, None]


def rod_velocity_map(st) -> np.ndarray:
    n, m, s = st["n"], st["m"], st["s"]
    return 0.5 * (np.eye(3) + m[..., :, None] * n[..., None, :] / s[..., None, None])


def velocity_products(st, V) -> dict[str, np.ndarray]:
    n, m, s, L = st["n"], st["m"], st["s"], st["L"]
    qd = np.sum(n * V[..., None, :], axis=-1) / s                 # (.., N, 3)
    rel = V[..., None, :] - qd[..., None] * m                       # L * ndot
    h = np.sum(rel * rel, axis=-1) / (L * s)
    return {"qdd": h, "rod_center": 0.5 * h[..., None] * m,
            "rod_angular": -h[..., None] * np.cross(n, m) / L[..., None]}


def mass_coefficients(mech) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def platform_mass(mech, st) -> np.ndarray:
    """M_p (..., N, 3, 3) from the branch state (see :func:`mass_coefficients`)."""
    n, m, s = st["n"], st["m"], st["s"]
    u = n / s[..., None]                                            # rows J_i
    c0, alpha, beta = (_p(c, 2) for c in mass_coefficients(mech))
    uu = np.einsum("...bi,...bj->...ij", u, u)
    mu = np.einsum("...bi,...bj->...ij", m, u)
    return c0 * np.eye(3) + alpha * uu + beta * (mu + np.swapaxes(mu, -1, -2))


def velocity_force(mech, st, V) -> np.ndarray:
    n, s = st["n"], st["s"]
    J = n / s[..., None]
    vp = velocity_products(st, V)
    Jv = rod_velocity_map(st)
    Jw = rod_angular_map(st)
    me = _p(mech.m_slider, 2)
    rods = _p(mech.rods_per_branch * mech.m_rod, 2)
    Irod = _p(mech.rods_per_branch * mech.rod_Ixx, 2)
    C = np.sum(me * J * vp["qdd"][..., None], axis=-2)
    C = C + np.sum(rods * np.einsum("...bki,...bk->...bi", Jv, vp["rod_center"]), axis=-2)
    C = C + np.sum(Irod * np.einsum("...bki,...bk->...bi", Jw, vp["rod_angular"]), axis=-2)
    return C


def gravity_force(mech, st) -> np.ndarray:
    n, m, s = st["n"], st["m"], st["s"]
    J = n / s[..., None]
    Jv = rod_velocity_map(st)
    g = _p(mech.g, 2)
    me = _p(mech.m_slider, 2)
    rods = _p(mech.rods_per_branch * mech.m_rod, 2)
    G = _p(mech.m_platform * mech.g, 1) * Z
    G = G + np.sum(g * me * J * m[..., 2:3], axis=-2)
    G = G + np.sum(g * rods * Jv[..., 2, :], axis=-2)
    return G


