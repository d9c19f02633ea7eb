"""Numba kernels for the 3-P(4S)'s inverse kinematics and Jacobian (eq. 5 and 8)
over D designs x N points, behind the public :meth:`P4S.inverse` and
:meth:`P4S.jacobian`.

The operations are those of :meth:`P4S.branch_state`, in its order (the same
sums from left to right, divisions where it divides), so the results are
bitwise the numpy model's: ``w_i = p + (rho - r_b) e_i``, ``b_i = m_i.w_i``,
``disc_i = L^2 - |w_i|^2 + b_i^2``, every stroke NaN unless all three
``disc_i >= 0``, ``q_i = b_i - sqrt(disc_i)``, ``n_i = (w_i - q_i m_i) / L``,
``s_i = sqrt(disc_i) / L``, rows ``J_i = n_i / s_i``.

Per-design constants ``P (D, 11)``: ``rho - r_b``, L and the rail directions
m_i (9 components), as :func:`.compiled._ik_inputs` builds them.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ...fast._jit import NJIT as _NJIT
from .geometry import E as _E

E00, E01, E02 = float(_E[0, 0]), float(_E[0, 1]), float(_E[0, 2])
E10, E11, E12 = float(_E[1, 0]), float(_E[1, 1]), float(_E[1, 2])
E20, E21, E22 = float(_E[2, 0]), float(_E[2, 1]), float(_E[2, 2])
@njit(**_NJIT)
def _branch(off, Lsq, e0, e1, e2, m0, m1, m2, x, y, z):
    """w_i, b_i and disc_i of one branch (the numpy model's operations)."""
    w0 = x + off * e0
    w1 = y + off * e1
    w2 = z + off * e2
    b = m0 * w0 + m1 * w1 + m2 * w2
    disc = Lsq - (w0 * w0 + w1 * w1 + w2 * w2) + b * b
    return w0, w1, w2, b, disc


@njit(**_NJIT)
def _point(P, d, x, y, z):
    """Per branch (w_i, b_i, sqrt(disc_i) or NaN for all if one branch fails) at one point."""
    off = P[d, 0]
    L = P[d, 1]
    Lsq = L * L
    a0, a1, a2, ba, da = _branch(off, Lsq, E00, E01, E02, P[d, 2], P[d, 3], P[d, 4], x, y, z)
    c0, c1, c2, bc, dc = _branch(off, Lsq, E10, E11, E12, P[d, 5], P[d, 6], P[d, 7], x, y, z)
    e0, e1, e2, be, de = _branch(off, Lsq, E20, E21, E22, P[d, 8], P[d, 9], P[d, 10], x, y, z)
    if da >= 0.0 and dc >= 0.0 and de >= 0.0:
        ra, rc, re = math.sqrt(da), math.sqrt(dc), math.sqrt(de)
    else:
        ra = rc = re = np.nan
    return L, (a0, a1, a2, ba, ra), (c0, c1, c2, bc, rc), (e0, e1, e2, be, re)


@njit(parallel=True, **_NJIT)
def p4s_inverse(P, X):
    """Strokes (D, N, 3), NaN where a pose is out of reach."""
    D = P.shape[0]
    N = X.shape[0]
    out = np.empty((D, N, 3))
    for t in prange(D * N):
        d = t // N
        j = t % N
        _, ba, bc, be = _point(P, d, X[j, 0], X[j, 1], X[j, 2])
        out[d, j, 0] = ba[3] - ba[4]
        out[d, j, 1] = bc[3] - bc[4]
        out[d, j, 2] = be[3] - be[4]
    return out


@njit(**_NJIT)
def _row(out, d, j, i, br, L, m0, m1, m2):
    w0, w1, w2, b, r = br
    q = b - r
    s = r / L
    out[d, j, i, 0] = ((w0 - q * m0) / L) / s
    out[d, j, i, 1] = ((w1 - q * m1) / L) / s
    out[d, j, i, 2] = ((w2 - q * m2) / L) / s


@njit(parallel=True, **_NJIT)
def p4s_jacobian(P, X):
    """J (D, N, 3, 3), rows n_i^T / (n_i . m_i); NaN where a pose is out of reach."""
    D = P.shape[0]
    N = X.shape[0]
    out = np.empty((D, N, 3, 3))
    for t in prange(D * N):
        d = t // N
        j = t % N
        L, ba, bc, be = _point(P, d, X[j, 0], X[j, 1], X[j, 2])
        _row(out, d, j, 0, ba, L, P[d, 2], P[d, 3], P[d, 4])
        _row(out, d, j, 1, bc, L, P[d, 5], P[d, 6], P[d, 7])
        _row(out, d, j, 2, be, L, P[d, 8], P[d, 9], P[d, 10])
    return out
