"""Numba kernels for the closed-form forward kinematics of the 3-P(4S), one
design (:func:`optdesign.fast.forward_p4s`).

Kept apart from :mod:`._p4s_kernels` so that editing one module leaves the
numba cache of the other valid (the local-index kernel takes ~30 s to
compile).  Importing this module imports numba; :mod:`optdesign.fast` imports
it lazily and falls back to :meth:`P4S.forward` when that fails.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..mechanisms.p4s import E as _E

# e_i components (x, y; the z components are 0)
E00, E01 = float(_E[0, 0]), float(_E[0, 1])
E10, E11 = float(_E[1, 0]), float(_E[1, 1])
E20, E21 = float(_E[2, 0]), float(_E[2, 1])

_NJIT = dict(cache=True, error_model="numpy", fastmath=False)

#: poses per task: the unit of parallel work
FK_CHUNK = 2048


@njit(**_NJIT)
def _fk_chunk(F, Q, lo, hi, buf, out):
    """Forward kinematics of poses lo..hi-1 of Q (N, 3) into out (N, 3).  The
    strokes are first copied into rows of buf (6 FK_CHUNK: q1, q2, q3, then
    x, y, z), so that the pose loop reads and writes unit-stride rows of one
    array at constant offsets and LLVM vectorizes it; slices indexed from 0
    avoid the wraparound select that turns loads into gathers."""
    n = hi - lo
    Qc = Q[lo:hi]
    for j in range(n):
        buf[j] = Qc[j, 0]
        buf[FK_CHUNK + j] = Qc[j, 1]
        buf[2 * FK_CHUNK + j] = Qc[j, 2]
    for j in range(n):
        x, y, z = _fk_point(F, buf[j], buf[FK_CHUNK + j], buf[2 * FK_CHUNK + j])
        buf[3 * FK_CHUNK + j] = x
        buf[4 * FK_CHUNK + j] = y
        buf[5 * FK_CHUNK + j] = z
    Oc = out[lo:hi]
    for j in range(n):
        Oc[j, 0] = buf[3 * FK_CHUNK + j]
        Oc[j, 1] = buf[4 * FK_CHUNK + j]
        Oc[j, 2] = buf[5 * FK_CHUNK + j]


@njit(parallel=True, **_NJIT)
def p4s_forward(F, Q, out):
    """Forward kinematics of one design for the N stroke triples Q (N, 3) into
    out (N, 3) (both C-contiguous); returns out.

    F = (r_b - rho, cos phi, sin phi, L^2, L) of the design.  Sphere centres
    s_i = a_i e_i + h_i z with a_i = (r_b - rho) - q_i cos phi, h_i = q_i sin phi;
    subtracting the sphere equations gives x and y as affine functions of z,
    then a quadratic in z whose upper root is the assembly mode of the paper
    (one division for that root and the 2 x 2 solve); one Newton step on the
    three sphere equations (one more division) removes the round-off.
    """
    N = Q.shape[0]
    nch = (N + FK_CHUNK - 1) // FK_CHUNK
    for t in prange(nch):
        lo = t * FK_CHUNK
        hi = min(lo + FK_CHUNK, N)
        buf = np.empty(6 * FK_CHUNK)
        _fk_chunk(F, Q, lo, hi, buf, out)
    return out


@njit(inline="always", **_NJIT)
def _fk_point(F, qa, qb, qc):
    off = F[0]
    c = F[1]
    s = F[2]
    Lsq = F[3]
    a0 = off - c * qa
    a1 = off - c * qb
    a2 = off - c * qc
    h0 = s * qa
    h1 = s * qb
    h2 = s * qc
    # centres (a_i e_i, h_i)
    s00 = a0 * E00
    s01 = a0 * E01
    s10 = a1 * E10
    s11 = a1 * E11
    s20 = a2 * E20
    s21 = a2 * E21
    # |p - s_i|^2 = L^2, with P = |p|^2:
    #   2 s_i.p - P = |s_i|^2 - L^2
    # unknowns (x, y, P) affine in z: 2 sx_i x + 2 sy_i y - P = k_i - 2 h_i z
    k0 = a0 * a0 + h0 * h0 - Lsq
    k1 = a1 * a1 + h1 * h1 - Lsq
    k2 = a2 * a2 + h2 * h2 - Lsq
    # differences eliminate P: rows (s_i - s_0) . (x, y) = ((k_i - k_0) - 2 (h_i - h_0) z) / 2
    A00 = s10 - s00
    A01 = s11 - s01
    A10 = s20 - s00
    A11 = s21 - s01
    det = A00 * A11 - A01 * A10
    e0 = 0.5 * (k1 - k0)
    e1 = 0.5 * (k2 - k0)
    f0 = -(h1 - h0)
    f1 = -(h2 - h0)
    # x = (x0 + x1 z) / det, y = (y0 + y1 z) / det (Cramer, the division
    # postponed: the quadratic below is scaled by det^2, which leaves its root
    # unchanged, so one division serves 1 / det and the root)
    x0 = A11 * e0 - A01 * e1
    x1 = A11 * f0 - A01 * f1
    y0 = A00 * e1 - A10 * e0
    y1 = A00 * f1 - A10 * f0
    # sphere 0: (x - s00)^2 + (y - s01)^2 + (z - h0)^2 = L^2, times det^2
    dsq = det * det
    X0 = x0 - s00 * det
    Y0 = y0 - s01 * det
    qa2 = x1 * x1 + y1 * y1 + dsq
    qb2 = X0 * x1 + Y0 * y1 - h0 * dsq          # half of the linear coefficient
    qc2 = X0 * X0 + Y0 * Y0 + (h0 * h0 - Lsq) * dsq
    disc = qb2 * qb2 - qa2 * qc2
    sq = math.sqrt(disc)
    # upper root, written without cancellation: z = num / den
    neg = qb2 <= 0.0
    num = sq - qb2 if neg else -qc2
    den = qa2 if neg else qb2 + sq
    rr = 1.0 / (den * det)
    idet = den * rr
    z = (num * det) * rr
    x1 = x1 * idet
    y1 = y1 * idet
    x = x0 * idet + x1 * z
    y = y0 * idet + y1 * z
    # one Newton step on f_i = (|p - s_i|^2 - L^2) / 2 (Jacobian rows d_i = p - s_i),
    # reduced to one division: rows 1 and 2 minus row 0 are the constant
    # s_0 - s_i, whose xy part is the 2 x 2 system A inverted above, so with
    # r_i = g_0 - g_i: (dx, dy) = (ex, ey) + (x1, y1) dz, and row 0 gives dz
    # (its divisor d_0 . (x1, y1, 1) is the quadratic's derivative, +-sqrt(disc)).
    d00 = x - s00
    d01 = y - s01
    d02 = z - h0
    d10 = x - s10
    d11 = y - s11
    d12 = z - h1
    d20 = x - s20
    d21 = y - s21
    d22 = z - h2
    g0 = 0.5 * (d00 * d00 + d01 * d01 + d02 * d02 - Lsq)
    g1 = 0.5 * (d10 * d10 + d11 * d11 + d12 * d12 - Lsq)
    g2 = 0.5 * (d20 * d20 + d21 * d21 + d22 * d22 - Lsq)
    r1 = g0 - g1
    r2 = g0 - g2
    ex = (A11 * r1 - A01 * r2) * idet
    ey = (A00 * r2 - A10 * r1) * idet
    dnw = d00 * x1 + d01 * y1 + d02
    ok = dnw != 0.0
    dz = (g0 - d00 * ex - d01 * ey) / (dnw if ok else 1.0)
    dx = ex + x1 * dz
    dy = ey + y1 * dz
    nan = np.nan
    good = disc >= 0.0
    x = (x - dx if ok else x) if good else nan
    y = (y - dy if ok else y) if good else nan
    z = (z - dz if ok else z) if good else nan
    return x, y, z
