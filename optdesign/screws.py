"""Screw theory for mobility and constraint analysis of parallel mechanisms.

Conventions (those of the seed papers, e.g. eq. 1 of the 2-CPR/RRR paper):

* a **twist** is ``(omega; v)``: angular velocity and the velocity of the body
  point at the origin.  A revolute joint of unit axis ``s`` through point ``r``
  has the unit twist ``(s; r x s)``; a prismatic joint along ``s`` has ``(0; s)``;
* a **wrench** is ``(f; m)``: force and moment about the origin.  A force along
  ``s`` through ``r`` is ``(s; r x s)``; a couple about ``s`` is ``(0; s)``;
* the **reciprocal product** of a twist T and a wrench W is the power
  ``T o W = omega . m + v . f``.  A wrench is *reciprocal* to a twist when the
  product vanishes: it does no work on that motion.

Screws are rows of shape ``(6,)``; a screw *system* is a ``(k, 6)`` array whose
rows span it.  The functions below return orthonormal bases of the systems
(rows), computed by SVD with a relative tolerance, so they work for any
mechanism whose joints can be written as screws:

* :func:`constraint_wrenches` of one chain = the wrenches reciprocal to all its
  joint twists;
* :func:`platform_twist_space` of a parallel mechanism = the twists reciprocal
  to the union of the chains' constraint wrenches;
* :func:`joint_rates` solves ``sum_j qdot_j T_j = platform twist`` for one
  chain, which gives each chain's actuated joint rate from a platform twist,
  the screw-theory check of a Jacobian.

Twists mix angular (rad/s) and linear (m/s) parts, so ranks depend on the
length unit only through the tolerance; ``length_scale`` (a typical length of
the mechanism) makes the moment parts dimensionless before the SVD.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = [
    "revolute", "prismatic", "cylindrical", "helical", "spherical",
    "reciprocal_product", "span", "rank", "reciprocal", "constraint_wrenches",
    "platform_twist_space", "same_span", "contains", "joint_rates", "motion_type",
    "actuation_wrench", "actuation_jacobian",
    "twist_space_dimension",
]

#: the Klein form: T o W = T @ DELTA @ W
DELTA = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])


# --------------------------------------------------------------------------- joint twists
def _unit(s) -> np.ndarray:
    s = np.asarray(s, dtype=float)
    return s / np.linalg.norm(s, axis=-1, keepdims=True)


def revolute(axis, point) -> np.ndarray:
    """Unit twist ``(s; r x s)`` of a revolute joint, axis ``s`` through ``point``.
    Batched: ``axis`` and ``point`` (..., 3) give (..., 6)."""
    s = _unit(axis)
    r = np.asarray(point, dtype=float)
    s, r = np.broadcast_arrays(s, r)
    return np.concatenate([s, np.cross(r, s)], axis=-1)


def prismatic(direction) -> np.ndarray:
    """Unit twist ``(0; s)`` of a prismatic joint along ``direction`` (..., 3) -> (..., 6)."""
    s = _unit(direction)
    return np.concatenate([np.zeros_like(s), s], axis=-1)


def helical(axis, point, pitch: float) -> np.ndarray:
    """Unit twist ``(s; r x s + h s)`` of a helical joint of pitch ``h`` (m/rad)."""
    s = _unit(axis)
    r = np.asarray(point, dtype=float)
    s, r = np.broadcast_arrays(s, r)
    return np.concatenate([s, np.cross(r, s) + pitch * s], axis=-1)


def cylindrical(axis, point) -> np.ndarray:
    """The two twists of a cylindrical joint, (..., 2, 6): the translation along
    the axis first, then the rotation about it (the order of eq. 1: S11, S12)."""
    return np.stack([prismatic(axis), revolute(axis, point)], axis=-2)


def spherical(point) -> np.ndarray:
    """The three twists (..., 3, 6) of a spherical joint at ``point``: rotations
    about x, y and z through it."""
    r = np.asarray(point, dtype=float)
    return np.stack([revolute(np.broadcast_to(e, r.shape), r) for e in np.eye(3)], axis=-2)


# --------------------------------------------------------------------------- linear algebra
def reciprocal_product(a, b) -> np.ndarray:
    """``a o b = a_omega . b_m + a_v . b_f`` (symmetric), batched over leading axes."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.sum(a[..., :3] * b[..., 3:], axis=-1) + np.sum(a[..., 3:] * b[..., :3], axis=-1)


def _scaled(A, length_scale: float) -> np.ndarray:
    A = np.asarray(A, dtype=float)
    if A.ndim == 1:
        A = A[None, :]
    if length_scale != 1.0:
        A = A.copy()
        A[..., 3:] /= length_scale
    return A


def _tol(sv: np.ndarray, tol: float) -> float:
    return tol * max(1.0, float(sv[0])) if sv.size else tol


def rank(A, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """Rank of screw systems (..., k, 6), batched."""
    A = _scaled(A, length_scale)
    if A.shape[-2] == 0:
        return np.zeros(A.shape[:-2], dtype=int)
    sv = np.linalg.svd(A, compute_uv=False)
    thr = tol * np.maximum(1.0, sv[..., :1])
    return np.sum(sv > thr, axis=-1)


def span(A, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """Basis (r, 6) of the row span of one screw system (k, 6): orthonormal rows
    (orthogonal in the metric with moments divided by ``length_scale``, unit in SI)."""
    A = _scaled(A, length_scale)
    if A.shape[0] == 0:
        return np.zeros((0, 6))
    _, sv, vt = np.linalg.svd(A)
    r = int(np.sum(sv > _tol(sv, tol)))
    B = vt[:r]
    if length_scale != 1.0:
        B = B.copy()
        B[:, 3:] *= length_scale
        B /= np.linalg.norm(B, axis=1, keepdims=True)   # unit rows in SI
    return B


def reciprocal(A, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """Basis (6 - rank, 6) of the screws reciprocal to every row of ``A`` (k, 6).

    The reciprocal system is the null space of ``A @ DELTA`` (``A @ DELTA @ x = 0``
    means ``row o x = 0`` for every row), found from the SVD.  Twists in,
    wrenches out, and vice versa.  With ``length_scale`` L the moment parts are
    divided by L before the SVD (and the result is returned in SI).
    """
    A = np.asarray(A, dtype=float)
    if A.ndim == 1:
        A = A[None, :]
    if A.shape[0] == 0:
        return np.eye(6)
    # with moments divided by L on both sides, T o W = L (T' o W'): reciprocity is
    # unchanged, and the SVD sees numbers of one unit
    S = np.diag([1.0, 1.0, 1.0, length_scale, length_scale, length_scale])
    M = _scaled(A, length_scale) @ DELTA
    _, sv, vt = np.linalg.svd(M)
    r = int(np.sum(sv > _tol(sv, tol)))
    N = vt[r:] @ S            # back to SI: x = S x'
    # re-orthonormalize in the scaled metric for a tidy basis
    return span(N, tol, length_scale) if len(N) else np.zeros((0, 6))


def constraint_wrenches(chain, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """The constraint wrench system of one chain (joint twists as rows, (k, 6)):
    the wrenches reciprocal to all its joint twists, basis (6 - rank, 6)."""
    return reciprocal(chain, tol, length_scale)


def platform_twist_space(chains: Sequence, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """The twist space of the platform of a parallel mechanism, basis (dof, 6).

    ``chains`` is a sequence of joint-twist arrays (k_i, 6), one per chain from
    base to platform.  The platform's constraint wrench system is the union of
    the chains' constraint wrenches; its twists are the screws reciprocal to
    that union (mobility at this configuration, instantaneous).
    """
    W = [constraint_wrenches(c, tol, length_scale) for c in chains]
    W = np.concatenate(W, axis=0) if W else np.zeros((0, 6))
    return reciprocal(W, tol, length_scale)


def platform_constraints(chains: Sequence, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """Basis of the union of the chains' constraint wrench systems."""
    W = [constraint_wrenches(c, tol, length_scale) for c in chains]
    return span(np.concatenate(W, axis=0), tol, length_scale) if W else np.zeros((0, 6))


def same_span(A, B, tol: float = 1e-8, length_scale: float = 1.0) -> bool:
    """True when the screw systems spanned by the rows of A and B coincide."""
    ra = int(rank(A, tol, length_scale))
    rb = int(rank(B, tol, length_scale))
    rab = int(rank(np.concatenate([np.atleast_2d(A), np.atleast_2d(B)], axis=0), tol, length_scale))
    return ra == rb == rab


def contains(A, s, tol: float = 1e-8, length_scale: float = 1.0) -> bool:
    """True when screw ``s`` (6,) lies in the system spanned by the rows of A."""
    A = np.atleast_2d(A)
    return int(rank(np.concatenate([A, np.atleast_2d(s)], axis=0), tol, length_scale)) == int(rank(A, tol, length_scale))


def joint_rates(chain, twist) -> tuple[np.ndarray, float]:
    """Joint rates of one chain that produce a platform ``twist``: the least-squares
    solution of ``sum_j qdot_j chain[j] = twist`` and the residual norm (0 when the
    twist is one the chain allows).  Batched over leading axes of ``chain``
    (..., k, 6) and ``twist`` (..., 6); returns rates (..., k) and residuals (...)."""
    C = np.asarray(chain, dtype=float)
    t = np.asarray(twist, dtype=float)
    A = np.swapaxes(C, -1, -2)                                  # (..., 6, k)
    pinv = np.linalg.pinv(A)
    rates = np.einsum("...kj,...j->...k", pinv, np.broadcast_to(t, A.shape[:-1]))
    res = np.linalg.norm(np.einsum("...jk,...k->...j", A, rates) - t, axis=-1)
    return rates, res


def actuation_wrench(chain, active: int, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """The actuation (transmission) wrench of one chain, (6,) unit.

    With the actuated joint ``active`` locked, the chain also transmits a wrench
    that is reciprocal to all its *passive* joint twists but not to the actuated
    one (Joshi and Tsai, 2002).  It is found as the part of
    ``reciprocal(passive twists)`` orthogonal (in the scaled metric) to the
    chain's constraint wrenches, and is unique up to scale and up to adding
    constraint wrenches when the chain is not singular.
    """
    C = np.atleast_2d(np.asarray(chain, dtype=float))
    passive = np.delete(C, active, axis=0)
    Wp = reciprocal(passive, tol, length_scale)
    Wc = reciprocal(C, tol, length_scale)
    P = _scaled(Wp, length_scale)
    if len(Wc):
        Q = span(_scaled(Wc, length_scale), tol)          # orthonormal (scaled coordinates)
        P = P - (P @ Q.T) @ Q
    _, sv, vt = np.linalg.svd(P)
    if sv.size == 0 or sv[0] <= tol:
        raise ValueError("the chain has no actuation wrench: the actuated joint is redundant or the chain is singular")
    w = vt[0].copy()
    w[3:] *= length_scale
    return w / np.linalg.norm(w)


def actuation_jacobian(chains: Sequence, actives: Sequence[int], tol: float = 1e-9,
                       length_scale: float = 1.0) -> np.ndarray:
    """Inverse Jacobian from screws, (n_chains, 6): ``qdot_i = A[i] @ twist``.

    For chain i with actuation wrench W_i, the power balance of the locked
    passive joints gives ``W_i o twist = (W_i o T_active) qdot_i``, so row i is
    ``(DELTA W_i) / (W_i o T_active)``.  ``twist`` is the platform twist
    ``(omega; v)`` at the origin; for a translational platform the columns 3-5
    are the usual velocity Jacobian.
    """
    rows = []
    for c, a in zip(chains, actives):
        c = np.atleast_2d(np.asarray(c, dtype=float))
        W = actuation_wrench(c, a, tol, length_scale)
        rows.append((DELTA @ W) / reciprocal_product(W, c[a]))
    return np.stack(rows)


def motion_type(T, tol: float = 1e-9, length_scale: float = 1.0) -> tuple[int, int]:
    """(rotations, translations) of a twist system: the rank of its angular parts
    and the dimension of its pure translations (dimension minus that rank)."""
    T = np.atleast_2d(np.asarray(T, dtype=float))
    if T.shape[0] == 0:
        return 0, 0
    d = int(rank(T, tol, length_scale))
    rw = int(rank(np.concatenate([T[:, :3], np.zeros_like(T[:, 3:])], axis=1), tol, length_scale))
    return rw, d - rw


def twist_space_dimension(chains: Sequence, tol: float = 1e-9, length_scale: float = 1.0) -> np.ndarray:
    """Dimension of the platform twist space at many configurations at once.

    ``chains``: a sequence of arrays (..., k_i, 6) with common leading axes.
    The constraint wrenches of a chain are the right singular vectors of
    ``chain @ DELTA`` with (near-)zero singular values; rather than forming
    ragged bases, every chain contributes its 6 right singular vectors weighted
    by 1 where the singular value is below the tolerance and 0 elsewhere, and
    the union's rank gives ``dof = 6 - rank``.  Vectorized (no loop over points).
    Configurations with non-finite twists (unreachable poses) get -1.
    """
    rows = []
    good = True
    for c in chains:
        C = _scaled(np.asarray(c, dtype=float), length_scale)
        ok = np.all(np.isfinite(C), axis=(-1, -2))
        good = good & ok
        C = np.where(ok[..., None, None], C, 0.0)
        M = C @ DELTA
        _, sv, vt = np.linalg.svd(M)                            # vt (..., 6, 6)
        k = sv.shape[-1]
        full = np.zeros(sv.shape[:-1] + (6,))
        full[..., :k] = sv
        thr = tol * np.maximum(1.0, full[..., :1])
        null = full <= thr                                       # (..., 6)
        # the constraint wrenches (scaled coordinates) are the rows of vt with null == True
        rows.append(vt * null[..., :, None])
    U = np.concatenate(rows, axis=-2)
    return np.where(good, 6 - rank(U, tol), -1)
