"""What the compiled kernel modules share: numba's options, an explicit
fused multiply-add, a compensated 2 x 2 minor and dot product, the closed-form largest
eigenvalue of a symmetric positive semi-definite 3 x 3 matrix and the
combination of per-chunk statistics.

numba's cache is keyed on the file of each cached function: an edit here does
not invalidate the kernels that inline these helpers; delete their caches
(``__pycache__/*.nbi``, ``*.nbc`` under the mechanism packages) after one."""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from numba.core import types
from numba.extending import intrinsic

#: cached, numpy's error model (division by zero gives inf/NaN, no exception),
#: no fast-math: the kernels' results must not depend on the compiler's choices
NJIT = dict(cache=True, error_model="numpy", fastmath=False)
#: the same for the routines compiled into the kernels that call them
#: (``numba.extending.register_jitable``, or ``njit(inline="always", ...)``).
#: numba compiles a register_jitable routine once per signature into a library
#: of its own, optimized and turned into machine code, and optimizes and
#: generates it again inside every library that links it: a routine at depth d
#: of the call tree costs d times.  So the kernels' glue (a block of points, the
#: tails) is inlined into its caller as untyped IR, with no library of its own,
#: and the selector overloads return the generic routines themselves, not
#: wrappers around them.  The large routines stay separate: numba's inlining
#: deep-copies the callee's IR block by block, which costs more than the LLVM
#: time it saves on them (measured on the engine's first compile, issue "One engine")
JITABLE = dict(error_model="numpy", fastmath=False)


@intrinsic
def fma(typingctx, a, b, c):
    """a * b + c with one rounding (llvm.fma: one instruction where the CPU has FMA)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen


# initial guess of e^{i theta/3} from z = e^{i theta}, theta in [0, pi]:
# w0 = c0 + c1 z + c2 conj(z) + c3 z^2 (minimax fit, |w0 - w| < 0.0195), then
# two Halley steps on w^3 = z (cubic convergence: 5e-6, then round-off).
_C0R, _C0I = 0.6687456362503021, 0.38610047310849865
_C1R, _C1I = 0.19364836492632637, -0.3354088068550356
_C2R, _C2I = 0.0494623499389, -0.08567130315592646
_C3R, _C3I = 0.06931901548496303, 0.04002135225020323


@njit(inline="always", **NJIT)
def lambda_max_psd(a00, a11, a22, a01, a02, a12):
    """Largest eigenvalue of a symmetric positive semi-definite 3 x 3 matrix.

    With q = tr(A)/3, B = A - q I, p^2 = tr(B^2)/6 and the discriminant
    written as a weighted sum of squares of the 2 x 2 minors of the pair
    (B, C = B^2 - 2 p^2 I) (Lagrange's identity on Parlett's Gram determinant;
    both vanish together at a double eigenvalue, so it keeps its relative
    accuracy there), the angle theta = atan2(sqrt(disc/27), det B) and
    lambda_max = q + 2 p cos(theta/3) (no scaling: the kernel's matrices are far
    from overflow, and ill-conditioned points are recomputed with LAPACK).  cos(theta/3) is the real part of the
    principal cube root of e^{i theta}, computed with a polynomial start and
    two Halley steps (arithmetic only, so the point loop vectorizes).
    """
    tr = a00 + a11 + a22
    q = tr * (1.0 / 3.0)
    b00 = a00 - q
    b11 = a11 - q
    b22 = a22 - q
    o01 = a01
    o02 = a02
    o12 = a12
    oo01 = o01 * o01
    oo02 = o02 * o02
    oo12 = o12 * o12
    p2 = (b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * (oo01 + oo02 + oo12)) * (1.0 / 6.0)
    det = b00 * (b11 * b22 - oo12) - o01 * (o01 * b22 - o12 * o02) + o02 * (o01 * o12 - b11 * o02)
    # C = B^2 - 2 p^2 I
    t2 = 2.0 * p2
    c00 = b00 * b00 + oo01 + oo02 - t2
    c11 = oo01 + b11 * b11 + oo12 - t2
    c22 = oo02 + oo12 + b22 * b22 - t2
    c01 = o01 * (b00 + b11) + o02 * o12
    c02 = o02 * (b00 + b22) + o01 * o12
    c12 = o12 * (b11 + b22) + o01 * o02
    # orthogonal coordinates of the traceless parts: (x1, x2) for the diagonal
    # (weights 1/2 and 1/6), the off-diagonals (weight 2)
    bx1 = b00 - b11
    bx2 = b00 + b11 - 2.0 * b22
    cx1 = c00 - c11
    cx2 = c00 + c11 - 2.0 * c22
    m12 = bx1 * cx2 - bx2 * cx1
    m13 = bx1 * c01 - o01 * cx1
    m14 = bx1 * c02 - o02 * cx1
    m15 = bx1 * c12 - o12 * cx1
    m23 = bx2 * c01 - o01 * cx2
    m24 = bx2 * c02 - o02 * cx2
    m25 = bx2 * c12 - o12 * cx2
    m34 = o01 * c02 - o02 * c01
    m35 = o01 * c12 - o12 * c01
    m45 = o02 * c12 - o12 * c02
    lag = ((1.0 / 12.0) * (m12 * m12)
           + (m13 * m13 + m14 * m14 + m15 * m15)
           + (1.0 / 3.0) * (m23 * m23 + m24 * m24 + m25 * m25)
           + 4.0 * (m34 * m34 + m35 * m35 + m45 * m45))
    # disc = 3 lag; sin-part = sqrt(disc / 27) = sqrt(lag) / 3
    y = math.sqrt(lag) * (1.0 / 3.0)
    x = det
    # |x + i y| = sqrt(det^2 + 4 p^6 - det^2) = 2 p^3
    sp = math.sqrt(p2)
    rho = 2.0 * p2 * sp
    ok = rho > 0.0
    irho = 1.0 / (rho if ok else 1.0)
    zr = x * irho if ok else 1.0
    zi = y * irho if ok else 0.0
    # start: c0 + c1 z + c2 conj(z) + c3 z^2
    z2r = zr * zr - zi * zi
    z2i = 2.0 * zr * zi
    wr = (_C0R + _C1R * zr - _C1I * zi + _C2R * zr + _C2I * zi + _C3R * z2r - _C3I * z2i)
    wi = (_C0I + _C1R * zi + _C1I * zr + _C2I * zr - _C2R * zi + _C3R * z2i + _C3I * z2r)
    for _ in range(2):
        # Halley on w^3 = z: w <- w (w^3 + 2 z) / (2 w^3 + z)
        sr = wr * wr - wi * wi
        si = 2.0 * wr * wi
        cr = sr * wr - si * wi
        ci = sr * wi + si * wr
        nr0 = cr + 2.0 * zr
        ni0 = ci + 2.0 * zi
        nr = wr * nr0 - wi * ni0
        ni = wr * ni0 + wi * nr0
        dr = 2.0 * cr + zr
        di = 2.0 * ci + zi
        idd = 1.0 / (dr * dr + di * di)
        wr = (nr * dr + ni * di) * idd
        wi = (ni * dr - nr * di) * idd
    lam = q + 2.0 * sp * wr
    return lam if tr > 0.0 else 0.0


@njit(inline="always", **NJIT)
def minor_dd(a1, a2, b1, b2):
    """a1 b2 - a2 b1 as an unevaluated sum hi + lo (error-free products, TwoSum)."""
    p = a1 * b2
    ep = fma(a1, b2, -p)
    q = a2 * b1
    eq = fma(a2, b1, -q)
    h = p - q
    bb = h - p
    eh = (p - (h - bb)) + (-q - bb)
    return h, eh + (ep - eq)


@njit(inline="always", **NJIT)
def chunk_moments(part, cnt, d, v, k, nch):
    """Sum, min, max and centred sum of squares of value v of design d from its
    chunks' (part (D, nch, V, 4), counts cnt (D, nch)), in chunk order, over its
    k > 0 points (Chan et al.'s pairwise update of the centred sum)."""
    s = 0.0
    lo = np.inf
    hi = -np.inf
    for c in range(nch):
        if cnt[d, c] > 0:
            s += part[d, c, v, 0]
            lo = min(lo, part[d, c, v, 1])
            hi = max(hi, part[d, c, v, 2])
    mu = s / k
    m2 = 0.0
    for c in range(nch):
        kc = cnt[d, c]
        if kc > 0:
            e = part[d, c, v, 0] / kc - mu
            m2 += part[d, c, v, 3] + kc * (e * e)
    return s, lo, hi, m2


@njit(inline="always", **NJIT)
def dot3_dd(x0, x1, x2, h0, l0, h1, l1, h2, l2):
    """x . (h + l) in about twice the working precision (products error-free, sums compensated)."""
    p0 = x0 * h0
    e0 = fma(x0, h0, -p0)
    p1 = x1 * h1
    e1 = fma(x1, h1, -p1)
    p2 = x2 * h2
    e2 = fma(x2, h2, -p2)
    s = p0 + p1
    bb = s - p0
    es = (p0 - (s - bb)) + (p1 - bb)
    t = s + p2
    bb = t - s
    et = (s - (t - bb)) + (p2 - bb)
    return t + ((es + et) + (e0 + e1 + e2) + (x0 * l0 + x1 * l1 + x2 * l2))
