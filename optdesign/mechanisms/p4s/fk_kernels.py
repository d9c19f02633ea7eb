"""Numba kernels for the closed-form forward kinematics of the 3-P(4S), one
design (behind :meth:`P4S.forward`, through :func:`.compiled.forward`).

Kept apart from :mod:`.kernels` so that editing one module leaves the
numba cache of the other valid (the local-index kernel takes ~30 s to
compile).  Importing this module imports numba; :mod:`.compiled` imports
it lazily and falls back to the numpy model when that fails.
"""
from __future__ import annotations

import math

from numba import njit, prange

from ...fast._jit import NJIT as _NJIT
from ...fast._jit import fma as _fma
from .geometry import E as _E

# e_i components (x, y; the z components are 0); e_0 = (1, 0, 0) exactly, which
# the kernel uses to drop the terms a0 * 0 and a0 * 1
E10, E11 = float(_E[1, 0]), float(_E[1, 1])
E20, E21 = float(_E[2, 0]), float(_E[2, 1])
if not (_E[0, 0] == 1.0 and _E[0, 1] == 0.0 and not _E[:, 2].any()):
    raise ImportError("the FK kernel assumes e_0 = (1, 0, 0) and e_i in the xy plane")

# Fused multiply-adds are written out (_fma, one rounding): fewer
# instructions than separate products and sums, and unlike fast-math
# contraction (fastmath={"contract"}, as fast) the compiler does not choose
# which products to fuse, so the vectorized loop, its scalar remainder and the
# scalar loop taken when out aliases Q give bitwise the same results.  No
# fast-math flag: NaN where the spheres do not meet must survive.


#: poses per task: the unit of parallel work
FK_CHUNK = 2048


@njit(**_NJIT)
def _fk_chunk(F, q, lo, hi, o):
    """Forward kinematics of poses lo..hi-1 of the flat (3 N,) strokes q into
    the flat (3 N,) output o.  Flat views with indices 3 j + k (k = 0, 1, 2)
    are an interleaved access of compile-time stride 3, which LLVM vectorizes
    with in-register shuffles (vpermt2pd with AVX-512) in the same loop as the
    pose code: no copy to and from a transposed buffer (the (N, 3) arrays
    indexed [j, k] have a run-time row stride, and such copies stayed scalar).  Slices indexed from 0
    avoid the wraparound select that turns loads into gathers."""
    n = hi - lo
    qc = q[3 * lo:3 * hi]
    oc = o[3 * lo:3 * hi]
    for j in range(n):
        x, y, z = _fk_point(F, qc[3 * j], qc[3 * j + 1], qc[3 * j + 2])
        oc[3 * j] = x
        oc[3 * j + 1] = y
        oc[3 * j + 2] = z


@njit(parallel=True, **_NJIT)
def p4s_forward(F, Q, out):
    """Forward kinematics of one design for the N stroke triples Q (N, 3) into
    out (N, 3) (both C-contiguous; out may be Q itself); returns out.

    F = (r_b - rho, cos phi, sin phi, L^2, L) of the design.  Sphere centres
    s_i = a_i e_i + h_i z with a_i = (r_b - rho) - q_i cos phi, h_i = q_i sin phi;
    subtracting the sphere equations gives x and y as affine functions of z,
    then a quadratic in z whose upper root is the assembly mode of the paper
    (one division for that root and the 2 x 2 solve); one Newton step on the
    three sphere equations (one more division) removes the round-off.
    """
    N = Q.shape[0]
    q = Q.reshape(3 * N)
    o = out.reshape(3 * N)
    nch = (N + FK_CHUNK - 1) // FK_CHUNK
    for t in prange(nch):
        lo = t * FK_CHUNK
        hi = min(lo + FK_CHUNK, N)
        _fk_chunk(F, q, lo, hi, o)
    return out


@njit(inline="always", **_NJIT)
def _fk_point(F, qa, qb, qc):
    off = F[0]
    c = F[1]
    s = F[2]
    Lsq = F[3]
    a0 = _fma(-c, qa, off)
    a1 = _fma(-c, qb, off)
    a2 = _fma(-c, qc, off)
    h0 = s * qa
    h1 = s * qb
    h2 = s * qc
    # centres s_0 = (a0, 0, h0), s_i = (a_i e_i, h_i)
    s10 = a1 * E10
    s11 = a1 * E11
    s20 = a2 * E20
    s21 = a2 * E21
    # |p - s_i|^2 = L^2, with P = |p|^2:
    #   2 s_i.p - P = |s_i|^2 - L^2
    # unknowns (x, y, P) affine in z: 2 sx_i x + 2 sy_i y - P = k_i - L^2 - 2 h_i z
    k0 = _fma(a0, a0, h0 * h0)
    k1 = _fma(a1, a1, h1 * h1)
    k2 = _fma(a2, a2, h2 * h2)
    # differences eliminate P (and L^2): rows (s_i - s_0) . (x, y) = ((k_i - k_0) - 2 (h_i - h_0) z) / 2
    A00 = s10 - a0
    A01 = s11
    A10 = s20 - a0
    A11 = s21
    det = _fma(A00, A11, -(A01 * A10))
    e0 = 0.5 * (k1 - k0)
    e1 = 0.5 * (k2 - k0)
    f0 = h0 - h1
    f1 = h0 - h2
    # x = (x0 + x1 z) / det, y = (y0 + y1 z) / det (Cramer, the division
    # postponed: the quadratic below is scaled by det^2, which leaves its root
    # unchanged, so one division serves 1 / det and the root)
    x0 = _fma(A11, e0, -(A01 * e1))
    x1 = _fma(A11, f0, -(A01 * f1))
    y0 = _fma(A00, e1, -(A10 * e0))
    y1 = _fma(A00, f1, -(A10 * f0))
    # sphere 0: (x - a0)^2 + y^2 + (z - h0)^2 = L^2, times det^2
    dsq = det * det
    X0 = _fma(-a0, det, x0)
    qa2 = _fma(x1, x1, _fma(y1, y1, dsq))
    qb2 = _fma(X0, x1, _fma(y0, y1, -(h0 * dsq)))   # half of the linear coefficient
    qc2 = _fma(X0, X0, _fma(y0, y0, _fma(h0, h0, -Lsq) * dsq))
    disc = _fma(qb2, qb2, -(qa2 * qc2))
    # disc < 0 (the spheres do not meet): sq is NaN, and so are z (both
    # branches below) and then x, y and the Newton step: NaN comes out
    # without a select
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
    x = _fma(x0, idet, x1 * z)
    y = _fma(y0, idet, y1 * z)
    # one Newton step on f_i = (|p - s_i|^2 - L^2) / 2 (Jacobian rows d_i = p - s_i),
    # reduced to one division: rows 1 and 2 minus row 0 are the constant
    # s_0 - s_i, whose xy part is the 2 x 2 system A inverted above, so with
    # r_i = f_0 - f_i = (G_0 - G_i) / 2, G_i = |p - s_i|^2 (L^2 cancels):
    # (dx, dy) = (ex, ey) + (x1, y1) dz, and row 0 gives dz (its divisor
    # d_0 . (x1, y1, 1) is the quadratic's derivative, +-sqrt(disc)).
    d00 = x - a0
    d02 = z - h0
    d10 = x - s10
    d11 = y - s11
    d12 = z - h1
    d20 = x - s20
    d21 = y - s21
    d22 = z - h2
    G0 = _fma(d00, d00, _fma(y, y, d02 * d02))
    r1 = G0 - _fma(d10, d10, _fma(d11, d11, d12 * d12))
    r2 = G0 - _fma(d20, d20, _fma(d21, d21, d22 * d22))
    hdet = 0.5 * idet
    ex = _fma(A11, r1, -(A01 * r2)) * hdet
    ey = _fma(A00, r2, -(A10 * r1)) * hdet
    dnw = _fma(d00, x1, _fma(y, y1, d02))
    ok = dnw != 0.0
    dz = _fma(-y, ey, _fma(-d00, ex, 0.5 * (G0 - Lsq))) / (dnw if ok else 1.0)
    dx = _fma(x1, dz, ex)
    dy = _fma(y1, dz, ey)
    x = x - dx if ok else x
    y = y - dy if ok else y
    z = z - dz if ok else z
    return x, y, z
