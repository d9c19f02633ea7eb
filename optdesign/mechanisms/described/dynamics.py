"""Dynamics of a described mechanism from its bodies (Kane's form of
Lagrange's equations, in twist coordinates, then in pose coordinates).

Bodies and their velocity maps in the platform twist ``xi = (v, omega)``
(leg i: ``qdot_i = G_i xi``, rod ``d``, ``bdot = Vb xi`` with
``Vb = [I, -skew(r)]``, see :mod:`.legs`):

* platform: mass ``m`` at ``r_c = R c`` (velocity ``[I, -skew(r_c)] xi``),
  inertia ``R I_c R^T`` (angular velocity ``omega``);
* slider (prismatic): mass at ``a``, velocity ``u qdot``;
* crank (revolute): inertia ``I_axis`` about its axis (``omega = k qdot``),
  gravity of its mass at ``A + centre L_a chat``;
* rod (prismatic, revolute): ``count`` slender rods (a parallelogram is
  ``count: 2``: every rod of it moves as the equivalent one) of mass ``m`` with
  their centre at ``a + f d``, velocity ``(1 - f) t qdot + f bdot``, transverse
  inertia ``I`` about the centre, ``omega = d x ddot / l^2``;
* strut: a lower part (mass, centre at ``e1`` from A, transverse inertia) and
  an upper part (centre at ``e2`` from b towards A), both turning with
  ``omega = n x bdot / q``; ``ndot = (I - n n^T) bdot / q``.

Slender bodies have no inertia about their own axis, so their spin (which
the U or S joints leave free) carries no energy and ``d/dt (I omega) = I alpha``.

Each body contributes ``V_b^T m V_b`` to the twist mass matrix ``M_xi``, the
velocity products ``V_b^T m beta_b + W_b^T (I beta_w + omega x I omega)`` to
``c_xi`` (``beta``: the acceleration at ``xi_dot = 0``) and ``m g V_b[z]`` to
``g_xi``.  In pose coordinates (``xi = S xdot``, ``xi_dot = S xddot + sigma``):

    M_x = S^T M_xi S,  c_x = S^T (M_xi sigma + c_xi),  g_x = S^T g_xi,
    tau = J^-T (M_x xddot + c_x + g_x)   (J = G S; power tau.qdot = F.xdot).
"""
from __future__ import annotations

import numpy as np

from .constants import Constants

__all__ = ["twist_dynamics", "potential_energy", "point_map", "skew", "actuator_forces_of"]


def skew(n: np.ndarray) -> np.ndarray:
    z = np.zeros_like(n[..., 0])
    return np.stack([np.stack([z, -n[..., 2], n[..., 1]], -1),
                     np.stack([n[..., 2], z, -n[..., 0]], -1),
                     np.stack([-n[..., 1], n[..., 0], z], -1)], -2)


def point_map(r: np.ndarray) -> np.ndarray:
    """[I, -skew(r)] (..., 3, 6): the velocity of the point at r (from the
    platform origin) per unit twist."""
    eye = np.broadcast_to(np.eye(3), r.shape[:-1] + (3, 3))
    return np.concatenate([eye, -skew(r)], axis=-1)


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _quad(V, m):
    """sum over bodies of m V^T V: V (..., n, 3, 6), m (..., n) -> (..., 6, 6)."""
    return np.einsum("...nki,...n,...nkj->...ij", V, m, V)


def twist_dynamics(C: Constants, st: dict, xi: np.ndarray | None = None) -> dict:
    """``M`` (..., N, 6, 6) and, with the twists ``xi`` (..., N, 6), the velocity
    term ``c`` (..., N, 6); always the gravity term ``g`` (..., N, 6)."""
    body = C.body
    kind = C.kind
    G, d, t, r, den = st["G"], st["d"], st["t"], st["r"], st["den"]
    R = st["frames"].R
    Vb = point_map(r)                                               # (..., n, 3, 6)
    gval = C.g[..., None]
    rod = kind != 2
    strut = kind == 2
    tG = t[..., :, None] * G[..., None, :]                          # (..., n, 3, 6)
    with np.errstate(all="ignore"):
        l2 = np.where(rod, C.Lr ** 2, 1.0)
        f = body["rod_centre"]
        m_rod = np.where(rod, body["rod_mass"] * body["rod_count"], 0.0)
        I_rod = np.where(rod, body["rod_inertia"] * body["rod_count"], 0.0)
        Vc = (1.0 - f)[..., None, None] * tG + f[..., None, None] * Vb
        Wr = np.einsum("...ij,...jk->...ik", skew(d), Vb - tG) / l2[..., None, None]
        # the actuator's own body: slider mass (prismatic) or crank inertia (revolute)
        m_act = np.where(kind == 0, body["slider_mass"], np.where(kind == 1, body["crank_inertia"], 0.0))
        # struts
        q = np.where(strut, st["den"], 1.0)
        n = np.where(strut[:, None], d / q[..., None], 0.0)
        Pn = np.eye(3) - n[..., :, None] * n[..., None, :]
        PV = np.einsum("...ij,...jk->...ik", Pn, Vb) / q[..., None, None]
        e1, e2 = body["lower_centre"], body["upper_centre"]
        m1 = np.where(strut, body["lower_mass"], 0.0)
        m2 = np.where(strut, body["upper_mass"], 0.0)
        I12 = np.where(strut, body["lower_inertia"] + body["upper_inertia"], 0.0)
        Vlo = e1[..., None, None] * PV
        Vup = Vb - e2[..., None, None] * PV
        Ws = np.einsum("...ij,...jk->...ik", skew(n), Vb) / q[..., None, None]
        # platform
        rc = np.einsum("...jk,...k->...j", R, C.com)                # (..., N, 3)
        Vp = point_map(rc)
        Iw = np.einsum("...ij,...jk,...lk->...il", R, C.I_platform, R)
        mp = C.m_platform[..., None]
    M = (_quad(Vc, m_rod) + _quad(Wr, I_rod) + np.einsum("...ni,...n,...nj->...ij", G, m_act, G)
         + _quad(Vlo, m1) + _quad(Vup, m2) + _quad(Ws, I12))
    M = M + C.m_platform[..., None, None] * np.einsum("...ki,...kj->...ij", Vp, Vp)
    M[..., 3:, 3:] += Iw
    # gravity (potential V = sum m g z): g_xi = sum m g V_b[z]
    gz = (m_rod[..., None] * Vc[..., 2, :] + m1[..., None] * Vlo[..., 2, :] + m2[..., None] * Vup[..., 2, :])
    slider_g = np.where(kind == 0, body["slider_mass"] * t[..., 2], 0.0)
    crank_g = np.where(kind == 1, body["crank_mass"] * body["crank_centre"] * t[..., 2], 0.0)
    gz = gz + (slider_g + crank_g)[..., None] * G
    g = gval * (np.sum(gz, axis=-2) + mp * Vp[..., 2, :])
    out = {"M": M, "g": g}
    if xi is None:
        return out
    xi = np.asarray(xi, dtype=float)
    v, w = xi[..., :3], xi[..., 3:]
    with np.errstate(all="ignore"):
        wl = w[..., None, :]
        bd = v[..., None, :] + np.cross(wl, r)                      # (..., n, 3)
        bb = np.cross(wl, np.cross(wl, r))                          # bddot at xi_dot = 0
        qd = _dot(G, xi[..., None, :])
        dd = bd - t * qd[..., None]
        # rods: qddot at xi_dot = 0 (from d^2/dt^2 |d|^2 = 0), a'' = -L_a chat for cranks
        app = np.where((kind == 1)[:, None], -C.La[..., None] * st["chat"], 0.0)
        qb_rod = (_dot(dd, dd) + _dot(d, bb) - qd * qd * _dot(d, app)) / den
        ab = t * qb_rod[..., None] + app * (qd * qd)[..., None]
        cb = (1.0 - f)[..., None] * ab + f[..., None] * bb
        alb = np.cross(d, bb - ab) / l2[..., None]
        # struts
        qb_s = (_dot(bd, bd) - qd * qd + _dot(d, bb)) / q
        nd = np.einsum("...ij,...j->...i", Pn, bd) / q[..., None]
        nb = (bb - qb_s[..., None] * n - 2.0 * qd[..., None] * nd) / q[..., None]
        alb_s = np.cross(n, nb)
        qb = np.where(strut, qb_s, qb_rod)
        c = (np.einsum("...nki,...n,...nk->...i", Vc, m_rod, cb) + np.einsum("...nki,...n,...nk->...i", Wr, I_rod, alb)
             + np.einsum("...ni,...n,...n->...i", G, m_act, qb)
             + np.einsum("...nki,...n,...nk->...i", Vlo, m1, e1[..., None] * nb)
             + np.einsum("...nki,...n,...nk->...i", Vup, m2, bb - e2[..., None] * nb)
             + np.einsum("...nki,...n,...nk->...i", Ws, I12, alb_s))
        ac = np.cross(w, np.cross(w, rc))
        c = c + mp * np.einsum("...ki,...k->...i", Vp, ac)
        c[..., 3:] += np.cross(w, np.einsum("...ij,...j->...i", Iw, w))
    out["c"] = c
    out["qddot_bias"] = qb
    return out


def potential_energy(C: Constants, st: dict) -> np.ndarray:
    """V = g sum m z of every body's centre of mass (..., N) (written from the
    positions, independently of ``twist_dynamics``'s gravity term)."""
    body = C.body
    kind = C.kind
    a, b, d = st["a"], st["b"], st["d"]
    R = st["frames"].R
    with np.errstate(all="ignore"):
        rod = kind != 2
        zrod = (a + body["rod_centre"][..., None] * d)[..., 2]
        m_rod = np.where(rod, body["rod_mass"] * body["rod_count"], 0.0)
        zsl = a[..., 2]
        zcr = (C.A + (body["crank_centre"] * C.La)[..., None] * st["chat"])[..., 2]
        n = d / np.where(kind == 2, st["den"], 1.0)[..., None]
        zlo = (C.A + body["lower_centre"][..., None] * n)[..., 2]
        zup = (b - body["upper_centre"][..., None] * n)[..., 2]
        legs = np.where(rod, m_rod * zrod, 0.0)
        legs = legs + np.where(kind == 0, body["slider_mass"] * zsl, 0.0)
        legs = legs + np.where(kind == 1, body["crank_mass"] * zcr, 0.0)
        legs = legs + np.where(kind == 2, body["lower_mass"] * zlo + body["upper_mass"] * zup, 0.0)
        rc = np.einsum("...jk,...k->...j", R, C.com)
        zp = st["frames"].origin[..., 2] + rc[..., 2]
        return C.g * (np.sum(legs, axis=-1) + C.m_platform * zp)


def _solve_T(J: np.ndarray, B: np.ndarray) -> np.ndarray:
    """J^-T B for stacks of square J (B (..., n, k)); NaN where J is singular or not finite."""
    n = J.shape[-1]
    Jt = np.swapaxes(J, -1, -2)
    shape = np.broadcast_shapes(Jt.shape[:-2], B.shape[:-2])
    Jt = np.broadcast_to(Jt, shape + Jt.shape[-2:])
    B = np.broadcast_to(B, shape + B.shape[-2:])
    good = np.all(np.isfinite(Jt), axis=(-1, -2)) & np.all(np.isfinite(B), axis=(-1, -2))
    Js = np.where(good[..., None, None], Jt, np.eye(n))
    Bs = np.where(good[..., None, None], B, 0.0)
    det = np.linalg.det(Js)
    good &= np.abs(det) > 0
    Js = np.where(good[..., None, None], Js, np.eye(n))
    out = np.linalg.solve(Js, Bs)
    return np.where(good[..., None, None], out, np.nan)


def actuator_forces_of(d: dict, A, parts, dof: int) -> np.ndarray:
    """Actuator forces J^-T (M a + c + g) from a pose's dynamics ``d`` (``J``,
    ``M``, ``c``, ``g``), with the terms ``parts`` names (accelerations A)."""
    F = 0.0
    if "M" in parts:
        F = F + np.einsum("...ij,...j->...i", d["M"], np.asarray(A, dtype=float))
    if "c" in parts:
        F = F + d["c"]
    if "g" in parts:
        F = F + d["g"]
    F = np.broadcast_to(F, d["J"].shape[:-2] + (dof,))
    return _solve_T(d["J"], F[..., None])[..., 0]
