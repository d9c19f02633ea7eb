"""A chain leg's forward kinematics by the product of exponentials, its joint
twists and its closure with the platform (numpy, batched over leading axes).

With the variables' elementary motions ``D_j(t)`` of the reference
configuration (a rotation about ``axis`` through ``point``, a translation
along ``axis``, or a parallelogram's translation ``(Rot(axis, t) - I) side``)
the last link is at ``g(theta) = D_1(theta_1) ... D_k(theta_k)`` (the end
frame is ``g (I, end)``).  The spatial twist of variable j, ``(omega; v)`` in
:mod:`optdesign.screws`' convention (``v`` the velocity of the body point at
the base origin), is ``Ad_{D_1 ... D_(j-1)}`` of its own: ``(R a; c' x R a)``
for a rotation about the moved point ``c'``, ``(0; R a)`` for a translation,
``(0; R (a x Rot(a, t) side))`` for a parallelogram.

The closure of a leg with the platform frame ``(R_p, o)``, platform point
``b = o + R_p P``, in length units (``L`` the chain constants' length scale):

* position (a chain ending in S): ``f = p_end - b`` (3 rows);
* frame: ``f = (p_end - b, L vee(R_end R_p^T - R_p R_end^T) / 2)`` (6 rows),

with the derivatives ``df/dtheta_j = (v_j + omega_j x p_end, L omega_j)`` and
``df/dxi = -([I, -skew(r)], L [0, I])`` in the platform twist ``xi = (v_o,
omega)`` (``r = R_p P``); the orientation rows' derivatives are those of the
linearized residual, exact at a solution (Newton keeps its quadratic
convergence).
"""
from __future__ import annotations

import numpy as np

from .chain_constants import ROT, SLIDE

__all__ = ["rodrigues", "skew", "cross", "chain_poe", "leg_rows", "lsq"]


def skew(n: np.ndarray) -> np.ndarray:
    out = np.zeros(n.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -n[..., 2], n[..., 1]
    out[..., 1, 0], out[..., 1, 2] = n[..., 2], -n[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -n[..., 1], n[..., 0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (broadcast), as np.cross with less overhead."""
    a, b = np.broadcast_arrays(a, b)
    out = np.empty(a.shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def rodrigues(a: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rot(a, t) = cos t I + sin t skew(a) + (1 - cos t) a a^T (..., 3, 3) for unit
    axes a (..., 3) and angles t (...)."""
    s, c = np.sin(t)[..., None, None], np.cos(t)[..., None, None]
    return c * np.eye(3) + s * skew(a) + (1.0 - c) * (a[..., :, None] * a[..., None, :])


def _mv(R, v):
    return np.einsum("...ij,...j->...i", R, v)


def chain_poe(leg, theta: np.ndarray, links: bool = False) -> dict:
    """The chain at joint values theta (..., k): ``R``, ``p`` the last link's
    motion g (..., 3, 3), (..., 3); ``end`` (..., 3) the end point; ``tw``
    (..., k, 6) the variables' spatial twists; with ``links``, ``Rs``, ``ps``
    (lists of k + 1 motions, before any variable and after each) and ``dpara``
    (..., k, 3): d/dt of a parallelogram's twist per unit rate squared
    (``R (a x (a x Rot side))``, 0 for the other variables)."""
    theta = np.asarray(theta, dtype=float)
    shape = np.broadcast_shapes(theta.shape[:-1], leg["axis"].shape[:-2])
    R = np.broadcast_to(np.eye(3), shape + (3, 3))
    p = np.zeros(shape + (3,))
    tw, Rs, ps, dpa = [], [R], [p], []
    for j, code in enumerate(leg["codes"]):
        a, c, t = leg["axis"][..., j, :], leg["point"][..., j, :], theta[..., j]
        Ra = _mv(R, a)
        if code == ROT:
            cc = _mv(R, c) + p
            tw.append(np.concatenate([np.broadcast_to(Ra, shape + (3,)), cross(cc, Ra)], -1))
            Dj = rodrigues(a, t)
            pj = c - _mv(Dj, c)
            dpa.append(np.zeros(shape + (3,)))
        elif code == SLIDE:
            tw.append(np.concatenate([np.zeros(shape + (3,)), np.broadcast_to(Ra, shape + (3,))], -1))
            Dj = np.broadcast_to(np.eye(3), shape + (3, 3))
            pj = a * t[..., None]
            dpa.append(np.zeros(shape + (3,)))
        else:                                        # PARA
            Rt = rodrigues(a, t)
            s = _mv(Rt, leg["side"][..., j, :])
            tw.append(np.concatenate([np.zeros(shape + (3,)), _mv(R, cross(a, s))], -1))
            dpa.append(np.broadcast_to(_mv(R, cross(a, cross(a, s))), shape + (3,)))
            Dj = np.broadcast_to(np.eye(3), shape + (3, 3))
            pj = s - leg["side"][..., j, :]
        p = _mv(R, pj) + p
        R = R @ Dj
        Rs.append(R)
        ps.append(p)
    end = _mv(R, leg["end"]) + p
    out = {"R": R, "p": p, "end": end,
           "tw": np.stack(tw, -2) if tw else np.zeros(shape + (0, 6))}
    if links:
        out.update(Rs=Rs, ps=ps, dpara=np.stack(dpa, -2) if dpa else np.zeros(shape + (0, 3)))
    return out


def leg_rows(leg, ch: dict, Rp: np.ndarray, o: np.ndarray, length) -> tuple:
    """(f (..., m), df/dtheta (..., m, k), df/dxi (..., m, 6)) of one leg's closure
    at the chain state ``ch`` (:func:`chain_poe`) and the platform frame (Rp, o)."""
    r = _mv(Rp, leg["P"])
    b = o + r
    end = ch["end"]
    f = end - b
    w, v = ch["tw"][..., :3], ch["tw"][..., 3:]
    Ft = np.swapaxes(v + cross(w, end[..., None, :]), -1, -2)             # (..., 3, k)
    eye = np.broadcast_to(np.eye(3), r.shape[:-1] + (3, 3))
    Fx = -np.concatenate([eye, -skew(r)], -1)                                # (..., 3, 6)
    if leg["closure"] == "position":
        return f, Ft, Fx
    L = np.asarray(length, dtype=float)[..., None]
    E = ch["R"] @ np.swapaxes(Rp, -1, -2)
    e = 0.5 * np.stack([E[..., 2, 1] - E[..., 1, 2], E[..., 0, 2] - E[..., 2, 0], E[..., 1, 0] - E[..., 0, 1]], -1)
    f = np.concatenate([f, L * e], -1)
    Ft = np.concatenate([Ft, L[..., None] * np.swapaxes(w, -1, -2)], -2)
    zero = np.zeros(eye.shape)
    Fx = np.concatenate([Fx, -L[..., None] * np.concatenate([zero, eye], -1)], -2)
    return f, Ft, Fx


#: a square matrix is numerically singular where |det| <= HADAMARD prod |row_i|
HADAMARD = 1e-14


def lsq(A: np.ndarray, b: np.ndarray, rcond: float = 1e-13) -> np.ndarray:
    """The least-squares solution of A x = b for stacks of A (..., m, n), m >= n,
    of full column rank (b (..., m) or (..., m, r)); NaN where A is not finite
    or numerically rank deficient (square: ``|det A| <= HADAMARD prod |row_i|``,
    LU; tall: ``|R_ii| <= rcond max |R_jj|`` of its QR), and everywhere when m < n."""
    vec = b.ndim == A.ndim - 1
    B = b[..., None] if vec else b
    shape = np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    A = np.broadcast_to(A, shape + A.shape[-2:])
    B = np.broadcast_to(B, shape + B.shape[-2:])
    n = A.shape[-1]
    if A.shape[-2] < n:              # fewer equations than unknowns: not determined
        return np.full(shape + (n,) + (() if vec else B.shape[-1:]), np.nan)
    good = np.all(np.isfinite(A), axis=(-1, -2)) & np.all(np.isfinite(B), axis=(-1, -2))
    if A.shape[-2] == n:             # square: LU (the QR below is four times dearer)
        with np.errstate(all="ignore"):
            As = np.where(good[..., None, None], A, np.eye(n))
            # numerically singular: |det A| below HADAMARD times the product of its rows' norms
            sign, logdet = np.linalg.slogdet(As)
            good &= (sign != 0) & (logdet - np.sum(np.log(np.linalg.norm(As, axis=-1)), -1) > np.log(HADAMARD))
            As = np.where(good[..., None, None], As, np.eye(n))
            x = np.linalg.solve(As, np.where(good[..., None, None], B, 0.0))
        x = np.where(good[..., None, None], x, np.nan)
        return x[..., 0] if vec else x
    As = np.where(good[..., None, None], A, np.eye(A.shape[-2], n))
    with np.errstate(all="ignore"):
        Q, R = np.linalg.qr(As)
        d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
        good &= np.min(d, axis=-1) > rcond * np.max(d, axis=-1)
        R = np.where(good[..., None, None], R, np.eye(n))
        QtB = np.where(good[..., None, None], np.swapaxes(Q, -1, -2) @ np.where(good[..., None, None], B, 0.0), 0.0)
        x = np.linalg.solve(R, QtB)
    x = np.where(good[..., None, None], x, np.nan)
    return x[..., 0] if vec else x
