"""The benchmark reference: the fused numba kernel written by hand for the
3-P(4S) alone (inverse kinematics, Jacobian, mass matrix and the local
indices per (design, workspace point)), which was the mechanism's compiled
path until the 3-P(4S) moved onto the one engine (optdesign/engine, through
its description: optdesign/mechanisms/p4s/compiled.py).  Kept to measure the
engine against (benchmarks/bench_described.py); nothing in the package
imports it.  ``design_constants(mech)`` below builds its inputs.

Per point (design constants hoisted, see :func:`design_constants`):

* inverse kinematics exactly as :meth:`P4S.branch_state` computes it (same
  operations in the same order, so the reachable mask is bitwise the one of
  the numpy path): ``w_i = p + (rho - r_b) e_i``, ``b_i = m_i.w_i``,
  ``disc_i = L^2 - |w_i|^2 + b_i^2``, reachable iff every ``disc_i >= 0``;
* rod directions ``n_i = (w_i - q_i m_i) / L``, ``s_i = n_i.m_i = sqrt(disc_i) / L``,
  Jacobian rows ``u_i = n_i / s_i``;
* platform mass matrix in closed form (|n_i| = |m_i| = 1):
  ``M_p = c0 I + sum_i [alpha u_i u_i^T + beta (m_i u_i^T + u_i m_i^T)]`` with
  ``c0 = m_p + 3 (m_r/4 + I_r/L^2)``, ``alpha = m_s + m_r/4 + I_r/L^2``,
  ``beta = m_r/4 - I_r/L^2`` (m_r, I_r: mass and transverse inertia of the rods
  of one branch); this is ``m_p I + m_s J^T J + sum Jv^T m_r Jv + sum Jw^T I_r Jw``;
* ``J^-T`` through the adjugate: rows ``r_i = s_i (n_j x n_k) / det N``, with
  det N in compensated arithmetic (:func:`_det3_dd`);
* ``M = J^-T M_p`` row by row as ``c0 r_k + alpha u_k + beta m_k +
  beta sum_i (r_k.m_i) u_i`` (from ``R u_i = e_i``: M_p is never formed);
* dynamic index ``sigma_max(M) = sqrt(lambda_max(M M^T))``; stiffness
  ``sigma_min(J)^2 = 1 / lambda_max(J^-T J^-1)`` (the smallest eigenvalue
  through the inverse); Frobenius condition ``sqrt(sum |u_i|^2 sum |r_i|^2)``;
  2-norm condition ``sqrt(lambda_max(J J^T) lambda_max(J^-T J^-1))``;
* a reach code: 0 unreachable, 1 reachable, 2 reachable but cond(J) >= 1000 or
  singular, which the caller evaluates with the numpy (LAPACK) path.

Only largest eigenvalues of symmetric positive semi-definite 3 x 3 matrices are
needed; :func:`lambda_max_psd` computes them in closed form without libm calls
and without the loss of digits of the arccos form at a double eigenvalue.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from optdesign.fast._jit import NJIT as _NJIT
from optdesign.fast._jit import chunk_moments, dot3_dd, lambda_max_psd
from optdesign.fast._jit import minor_dd as _cross_dd
from optdesign.formulas import DYN, FRO, SMIN, SMIN2, TWO
from optdesign.mechanisms.p4s.geometry import E as _E

#: points per task: the unit of parallel work and of the partial reductions
CHUNK = 512
#: local values the kernels can produce (rows of the output: their ids in
#: optdesign.formulas, the table's first five)
NVAL = TWO + 1

# e_i components (the numpy constants, so that w_i is bitwise the numpy one)
E00, E01, E02 = float(_E[0, 0]), float(_E[0, 1]), float(_E[0, 2])
E10, E11, E12 = float(_E[1, 0]), float(_E[1, 1]), float(_E[1, 2])
E20, E21, E22 = float(_E[2, 0]), float(_E[2, 1]), float(_E[2, 2])


#: cond_2^2 beyond which J counts as numerically rank deficient: (1 / (3 eps))^2
_RANKDEF = (1.0 / (3.0 * 2.220446049250313e-16)) ** 2
#: points whose ||J||_F^2 ||J^-1||_2^2 (between cond_2^2 and 3 cond_2^2) exceeds
#: this are flagged (reach code 2) for the caller to evaluate with LAPACK, so
#: that the fast path equals the numpy path to 1e-12 everywhere: with the
#: compensated det N the closed form loses about eps cond(J) like the SVD, and
#: below cond_2 = 1000 it agrees with LAPACK to 2e-13 (docs/performance.md).
#: 1e6 flags every point with cond_2 >= 1000 (some from 577).
HARD = 1.0e6

# the chunk reductions only: reassociation lets LLVM vectorize the sums (the
# order is still fixed by the code, so results do not depend on threads)
_NJIT_RED = dict(cache=True, error_model="numpy", fastmath={"reassoc", "nsz"})




@njit(inline="always", **_NJIT)
def _det3_dd(n00, n01, n02, n10, n11, n12, n20, n21, n22):
    """det of the rows n0, n1, n2 in about twice the working precision
    (compensated cofactor expansion): the rods of near-singular poses are
    nearly coplanar and the plain expansion cancels to a few digits."""
    a0, l0 = _cross_dd(n11, n12, n21, n22)
    a1, l1 = _cross_dd(n12, n10, n22, n20)
    a2, l2 = _cross_dd(n10, n11, n20, n21)
    return dot3_dd(n00, n01, n02, a0, l0, a1, l1, a2, l2)




@njit(inline="always", **_NJIT)
def _point(x, y, z, off, iL, Lsq, c0, alpha, beta, m00, m01, m02, m10, m11, m12, m20, m21, m22, want_s1, want_two):
    """(reach code, dynamic, sigma_min(J)^2, sigma_min(J), cond_F(J), cond_2(J)) at one point."""
    # ---- inverse kinematics (the operations of P4S.branch_state, in order)
    w00 = x + off * E00
    w01 = y + off * E01
    w02 = z + off * E02
    w10 = x + off * E10
    w11 = y + off * E11
    w12 = z + off * E12
    w20 = x + off * E20
    w21 = y + off * E21
    w22 = z + off * E22
    b0 = m00 * w00 + m01 * w01 + m02 * w02
    b1 = m10 * w10 + m11 * w11 + m12 * w12
    b2 = m20 * w20 + m21 * w21 + m22 * w22
    d0 = Lsq - (w00 * w00 + w01 * w01 + w02 * w02) + b0 * b0
    d1 = Lsq - (w10 * w10 + w11 * w11 + w12 * w12) + b1 * b1
    d2 = Lsq - (w20 * w20 + w21 * w21 + w22 * w22) + b2 * b2
    reach = (d0 >= 0.0) & (d1 >= 0.0) & (d2 >= 0.0)
    r0 = math.sqrt(d0 if d0 > 0.0 else 0.0)
    r1 = math.sqrt(d1 if d1 > 0.0 else 0.0)
    r2 = math.sqrt(d2 if d2 > 0.0 else 0.0)
    q0 = b0 - r0
    q1 = b1 - r1
    q2 = b2 - r2
    n00 = (w00 - q0 * m00) * iL
    n01 = (w01 - q0 * m01) * iL
    n02 = (w02 - q0 * m02) * iL
    n10 = (w10 - q1 * m10) * iL
    n11 = (w11 - q1 * m11) * iL
    n12 = (w12 - q1 * m12) * iL
    n20 = (w20 - q2 * m20) * iL
    n21 = (w21 - q2 * m21) * iL
    n22 = (w22 - q2 * m22) * iL
    s0 = r0 * iL
    s1 = r1 * iL
    s2 = r2 * iL
    # 1 / s_i with one division (the singular case is replaced below)
    s01 = s0 * s1
    s012 = s01 * s2
    sing = s012 == 0.0
    ip = 1.0 / (s012 if not sing else 1.0)
    is2 = s01 * ip
    t = s2 * ip
    is0 = s1 * t
    is1 = s0 * t
    # ---- Jacobian rows u_i = n_i / s_i
    u00 = n00 * is0
    u01 = n01 * is0
    u02 = n02 * is0
    u10 = n10 * is1
    u11 = n11 * is1
    u12 = n12 * is1
    u20 = n20 * is2
    u21 = n21 * is2
    u22 = n22 * is2
    # ---- J^-T rows r_i = s_i (n_j x n_k) / det N
    a00 = n11 * n22 - n12 * n21
    a01 = n12 * n20 - n10 * n22
    a02 = n10 * n21 - n11 * n20
    a10 = n21 * n02 - n22 * n01
    a11 = n22 * n00 - n20 * n02
    a12 = n20 * n01 - n21 * n00
    a20 = n01 * n12 - n02 * n11
    a21 = n02 * n10 - n00 * n12
    a22 = n00 * n11 - n01 * n10
    detN = _det3_dd(n00, n01, n02, n10, n11, n12, n20, n21, n22)
    flat = detN == 0.0
    idet = 1.0 / (detN if not flat else 1.0)
    f0 = s0 * idet
    f1 = s1 * idet
    f2 = s2 * idet
    r00 = a00 * f0
    r01 = a01 * f0
    r02 = a02 * f0
    r10 = a10 * f1
    r11 = a11 * f1
    r12 = a12 * f1
    r20 = a20 * f2
    r21 = a21 * f2
    r22 = a22 * f2
    # ---- dynamic: M = J^-T M_p.  With R = J^-T (rows r_k), R u_i = e_i exactly,
    # so M = c0 R + sum_i [alpha e_i u_i^T + beta (R m_i) u_i^T + beta e_i m_i^T]:
    # row k = c0 r_k + alpha u_k + beta m_k + beta sum_i (r_k.m_i) u_i, which
    # keeps the cancellation of R against the large u_i u_i^T terms of M_p out.
    g00 = r00 * m00 + r01 * m01 + r02 * m02
    g01 = r00 * m10 + r01 * m11 + r02 * m12
    g02 = r00 * m20 + r01 * m21 + r02 * m22
    g10 = r10 * m00 + r11 * m01 + r12 * m02
    g11 = r10 * m10 + r11 * m11 + r12 * m12
    g12 = r10 * m20 + r11 * m21 + r12 * m22
    g20 = r20 * m00 + r21 * m01 + r22 * m02
    g21 = r20 * m10 + r21 * m11 + r22 * m12
    g22 = r20 * m20 + r21 * m21 + r22 * m22
    M00 = c0 * r00 + alpha * u00 + beta * (m00 + g00 * u00 + g01 * u10 + g02 * u20)
    M01 = c0 * r01 + alpha * u01 + beta * (m01 + g00 * u01 + g01 * u11 + g02 * u21)
    M02 = c0 * r02 + alpha * u02 + beta * (m02 + g00 * u02 + g01 * u12 + g02 * u22)
    M10 = c0 * r10 + alpha * u10 + beta * (m10 + g10 * u00 + g11 * u10 + g12 * u20)
    M11 = c0 * r11 + alpha * u11 + beta * (m11 + g10 * u01 + g11 * u11 + g12 * u21)
    M12 = c0 * r12 + alpha * u12 + beta * (m12 + g10 * u02 + g11 * u12 + g12 * u22)
    M20 = c0 * r20 + alpha * u20 + beta * (m20 + g20 * u00 + g21 * u10 + g22 * u20)
    M21 = c0 * r21 + alpha * u21 + beta * (m21 + g20 * u01 + g21 * u11 + g22 * u21)
    M22 = c0 * r22 + alpha * u22 + beta * (m22 + g20 * u02 + g21 * u12 + g22 * u22)
    G00 = M00 * M00 + M01 * M01 + M02 * M02
    G11 = M10 * M10 + M11 * M11 + M12 * M12
    G22 = M20 * M20 + M21 * M21 + M22 * M22
    G01 = M00 * M10 + M01 * M11 + M02 * M12
    G02 = M00 * M20 + M01 * M21 + M02 * M22
    G12 = M10 * M20 + M11 * M21 + M12 * M22
    dyn = math.sqrt(lambda_max_psd(G00, G11, G22, G01, G02, G12))
    # ---- stiffness: sigma_min(J)^2 = 1 / lambda_max(R R^T)
    h00 = r00 * r00 + r01 * r01 + r02 * r02
    h11 = r10 * r10 + r11 * r11 + r12 * r12
    h22 = r20 * r20 + r21 * r21 + r22 * r22
    h01 = r00 * r10 + r01 * r11 + r02 * r12
    h02 = r00 * r20 + r01 * r21 + r02 * r22
    h12 = r10 * r20 + r11 * r21 + r12 * r22
    lh = lambda_max_psd(h00, h11, h22, h01, h02, h12)
    st2 = 1.0 / lh
    st1 = math.sqrt(st2) if want_s1 else 0.0
    # ---- isotropy
    uu0 = u00 * u00 + u01 * u01 + u02 * u02
    uu1 = u10 * u10 + u11 * u11 + u12 * u12
    uu2 = u20 * u20 + u21 * u21 + u22 * u22
    fsq = uu0 + uu1 + uu2
    fro = math.sqrt(fsq * (h00 + h11 + h22))
    if want_two:
        k01 = u00 * u10 + u01 * u11 + u02 * u12
        k02 = u00 * u20 + u01 * u21 + u02 * u22
        k12 = u10 * u20 + u11 * u21 + u12 * u22
        c2sq = lambda_max_psd(uu0, uu1, uu2, k01, k02, k12) * lh
        two = math.sqrt(c2sq)
    else:
        c2sq = fsq * lh  # within a factor 3 of cond_2^2
        two = 0.0
    # numerically rank deficient as numpy.linalg.matrix_rank (and indices.cond_*)
    # decides: sigma_min <= 3 eps sigma_max
    rankdef = c2sq >= _RANKDEF
    fro = np.inf if rankdef else fro
    two = np.inf if rankdef else two
    bad = sing | flat
    inf = np.inf
    dyn = inf if bad else dyn
    st2 = 0.0 if bad else st2
    st1 = 0.0 if bad else st1
    fro = inf if bad else fro
    two = inf if bad else two
    # reach code: 0 unreachable, 1 reachable, 2 reachable but ill-conditioned
    # (or singular): left to the LAPACK path by the caller
    easy = (c2sq < HARD) & (not bad)
    code = (1.0 if easy else 2.0) if reach else 0.0
    return code, dyn, st2, st1, fro, two


@njit(**_NJIT)
def _load_chunk(X, lo, hi, inb):
    """Points lo..hi-1 of X (N, 3) into inb (3 CHUNK) as rows x, y, z: the
    point loop then reads unit-stride rows (the caller's (N, 3) array is not
    transposed, which for 10^6 points cost as much as a fifth of the kernel)."""
    Xc = X[lo:hi]
    for j in range(hi - lo):
        inb[j] = Xc[j, 0]
        inb[CHUNK + j] = Xc[j, 1]
        inb[2 * CHUNK + j] = Xc[j, 2]


@njit(inline="always", **_NJIT)
def _chunk_body(P, d, inb, n, want_two, buf):
    """Local values of design d at the n points of inb (rows x, y, z of CHUNK,
    see _load_chunk) into the flat buffer buf (6 CHUNK): rows of CHUNK each,
    the reach code 0/1/2 as a float, then value id v (dynamic, sigma_min^2,
    sigma_min, cond_F, cond_2) in row 1 + v.  One write array at constant row
    offsets and no calls in the loop: LLVM vectorizes it.  The loop reads slices indexed from 0 (no wraparound
    select on a negative index, which made LLVM load the inputs with gathers).
    want_two must be a constant (see _chunk)."""
    off = P[d, 0]
    iL = 1.0 / P[d, 1]
    Lsq = P[d, 2]
    c0 = P[d, 3]
    alpha = P[d, 4]
    beta = P[d, 5]
    m00 = P[d, 6]
    m01 = P[d, 7]
    m02 = P[d, 8]
    m10 = P[d, 9]
    m11 = P[d, 10]
    m12 = P[d, 11]
    m20 = P[d, 12]
    m21 = P[d, 13]
    m22 = P[d, 14]
    xa = inb[0:n]
    ya = inb[CHUNK:CHUNK + n]
    za = inb[2 * CHUNK:2 * CHUNK + n]
    for j in range(n):
        r, a, b, c, e, f = _point(xa[j], ya[j], za[j], off, iL, Lsq, c0, alpha, beta,
                                  m00, m01, m02, m10, m11, m12, m20, m21, m22, True, want_two)
        buf[j] = r
        buf[(1 + DYN) * CHUNK + j] = a
        buf[(1 + SMIN2) * CHUNK + j] = b
        buf[(1 + SMIN) * CHUNK + j] = c
        buf[(1 + FRO) * CHUNK + j] = e
        buf[(1 + TWO) * CHUNK + j] = f


@njit(**_NJIT)
def _chunk_fro(P, d, inb, n, buf):
    _chunk_body(P, d, inb, n, False, buf)


@njit(**_NJIT)
def _chunk_two(P, d, inb, n, buf):
    _chunk_body(P, d, inb, n, True, buf)


@njit(**_NJIT)
def _chunk(P, d, inb, n, two, buf):
    """_chunk_body with "2-norm condition wanted" a compile-time constant: a
    run-time flag was if-converted, not unswitched, so every point paid for
    the third eigenvalue (cond_2) whether it was wanted or not.  ``two`` is
    None (Frobenius condition only) or True; the branch on ``two is None`` is
    resolved from its type when numba compiles, so a signature with None
    compiles (and caches) only the Frobenius loop, and one with a boolean only
    the other."""
    if two is None:
        _chunk_fro(P, d, inb, n, buf)
    else:
        _chunk_two(P, d, inb, n, buf)


def p4s_local(P, X, want_two):
    """See _p4s_local; ``want_two`` a bool (the 2-norm condition number wanted)."""
    return _p4s_local(P, X, True if want_two else None)


@njit(parallel=True, **_NJIT)
def _p4s_local(P, X, two):
    """Local values (NVAL, D, N) and the reach codes (D, N) (0 unreachable,
    1 reachable, 2 reachable but ill-conditioned) for D designs (rows of P, see
    design_constants) at the N points X (N, 3)."""
    D = P.shape[0]
    N = X.shape[0]
    vals = np.empty((NVAL, D, N))
    reach = np.empty((D, N), dtype=np.int8)
    nch = (N + CHUNK - 1) // CHUNK
    for t in prange(D * nch):
        d = t // nch
        lo = (t % nch) * CHUNK
        hi = min(lo + CHUNK, N)
        buf = np.empty(6 * CHUNK)
        inb = np.empty(3 * CHUNK)
        _load_chunk(X, lo, hi, inb)
        _chunk(P, d, inb, hi - lo, two, buf)
        for j in range(hi - lo):
            reach[d, lo + j] = np.int8(buf[j])
            for v in range(NVAL):
                vals[v, d, lo + j] = buf[(v + 1) * CHUNK + j]
    return vals, reach


def p4s_pairs(P, X, want_two):
    """See _p4s_pairs; ``want_two`` a bool (the 2-norm condition number wanted)."""
    return _p4s_pairs(P, X, True if want_two else None)


@njit(**_NJIT)
def _p4s_pairs(P, X, two):
    """Local values (NVAL, D, K) and the reach codes (D, K) (as _p4s_local) of
    each design d (rows of P) at its own K points X[d] (D, K, 3): the
    worst-case search's poses, one set per design.  Serial: a search level
    holds a few thousand poses, which a parallel loop's start-up costs more
    than (on a loaded machine, several times more)."""
    D = P.shape[0]
    K = X.shape[1]
    vals = np.empty((NVAL, D, K))
    reach = np.empty((D, K), dtype=np.int8)
    buf = np.empty(6 * CHUNK)
    inb = np.empty(3 * CHUNK)
    for d in range(D):
        for lo in range(0, K, CHUNK):
            hi = min(lo + CHUNK, K)
            _load_chunk(X[d], lo, hi, inb)
            _chunk(P, d, inb, hi - lo, two, buf)
            for j in range(hi - lo):
                reach[d, lo + j] = np.int8(buf[j])
                for v in range(NVAL):
                    vals[v, d, lo + j] = buf[(v + 1) * CHUNK + j]
    return vals, reach


@njit(inline="always", **_NJIT)
def _next_wanted(want, v):
    """The first wanted value index >= v, NVAL if none."""
    while v < NVAL and not want[v]:
        v += 1
    return v


@njit(**_NJIT)
def _sum_min_max(buf, n, o1, o2, o3, out1, out2, out3):
    """Sum, min and max over the points of reach code 1 (buf[j] == 1) of the
    rows at o1, o2 and o3 of buf into out1..3[0:3]: one scalar pass, the sums
    in point order (compiled without reassociation, so each sum is the
    sequential one), three independent chains instead of one loop each."""
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    l1 = np.inf
    l2 = np.inf
    l3 = np.inf
    h1 = -np.inf
    h2 = -np.inf
    h3 = -np.inf
    ra = buf[0:n]
    x1a = buf[o1:o1 + n]
    x2a = buf[o2:o2 + n]
    x3a = buf[o3:o3 + n]
    for j in range(n):
        r = ra[j] == 1.0
        x1 = x1a[j]
        x2 = x2a[j]
        x3 = x3a[j]
        s1 += x1 if r else 0.0
        s2 += x2 if r else 0.0
        s3 += x3 if r else 0.0
        xl = x1 if r else np.inf
        xh = x1 if r else -np.inf
        l1 = xl if xl < l1 else l1
        h1 = xh if xh > h1 else h1
        xl = x2 if r else np.inf
        xh = x2 if r else -np.inf
        l2 = xl if xl < l2 else l2
        h2 = xh if xh > h2 else h2
        xl = x3 if r else np.inf
        xh = x3 if r else -np.inf
        l3 = xl if xl < l3 else l3
        h3 = xh if xh > h3 else h3
    out1[0] = s1
    out1[1] = l1
    out1[2] = h1
    out2[0] = s2
    out2[1] = l2
    out2[2] = h2
    out3[0] = s3
    out3[1] = l3
    out3[2] = h3


@njit(**_NJIT_RED)
def _chunk_stats(P, d, X, lo, hi, want, two, reach, inb, buf, out, hard):
    """Values of design d at points lo..hi-1 (reach codes written), then for
    each wanted value its sum, min, max and centred sum of squares over the
    points of code 1 into out (NVAL, 4); returns their count (and the count of
    code-2 points in hard[0])."""
    n = hi - lo
    _load_chunk(X, lo, hi, inb)
    _chunk(P, d, inb, n, two, buf)
    k = 0
    nh = 0
    for j in range(n):
        r = buf[j]
        reach[j] = np.int8(r)
        k += 1 if r == 1.0 else 0
        nh += 1 if r == 2.0 else 0
    hard[0] = nh
    # sums, minima and maxima: up to three wanted values per pass over the
    # points (_sum_min_max: in order, no reassociation)
    v1 = _next_wanted(want, 0)
    while v1 < NVAL:
        v2 = _next_wanted(want, v1 + 1)
        v2 = v1 if v2 == NVAL else v2
        v3 = _next_wanted(want, v2 + 1)
        v3 = v2 if v3 == NVAL else v3
        _sum_min_max(buf, n, (v1 + 1) * CHUNK, (v2 + 1) * CHUNK, (v3 + 1) * CHUNK, out[v1], out[v2], out[v3])
        v1 = _next_wanted(want, v3 + 1)
    for v in range(NVAL):
        if not want[v]:
            continue
        o = (v + 1) * CHUNK
        s = out[v, 0]
        m2 = 0.0
        if k > 0:
            mu = s / k
            for j in range(n):
                e = buf[o + j] - mu
                m2 += e * e if buf[j] == 1.0 else 0.0
        out[v, 3] = m2
    return k


def p4s_summary(P, X, want, want_two):
    """See _p4s_summary; ``want_two`` a bool (the 2-norm condition number
    wanted).  Each value of it compiles its own specialization on first use."""
    return _p4s_summary(P, X, want, True if want_two else None)


@njit(parallel=True, **_NJIT)
def _p4s_summary(P, X, want, two):
    """Per-design sums over the points of reach code 1 of the wanted local
    values (want: NVAL booleans): returns stats (NVAL, 4, D) with stats[:, 0..3]
    = sum, min, max and centred sum of squares, the counts (D,) of code-1
    points, the reach codes (D, N) (see p4s_local) and the counts (D,) of
    code-2 points.  X: the N points (N, 3), C-contiguous.

    Work is split in fixed chunks of CHUNK points per design; each chunk keeps
    its count, sum, min, max and centred sum of squares, and the chunks of a
    design are combined in order, so results do not depend on the number of
    threads.
    """
    D = P.shape[0]
    N = X.shape[0]
    nch = (N + CHUNK - 1) // CHUNK
    reach = np.empty((D, N), dtype=np.int8)
    part = np.empty((D, nch, NVAL, 4))
    # np.empty, not np.zeros: every task writes its entries, and each
    # np.zeros would be a parallel region of its own (a fork/join per call)
    cnt = np.empty((D, nch), dtype=np.int64)
    hard = np.empty((D, nch), dtype=np.int64)
    for t in prange(D * nch):
        d = t // nch
        c = t % nch
        lo = c * CHUNK
        hi = min(lo + CHUNK, N)
        buf = np.empty(6 * CHUNK)
        inb = np.empty(3 * CHUNK)
        cnt[d, c] = _chunk_stats(P, d, X, lo, hi, want, two, reach[d, lo:hi], inb, buf, part[d, c],
                                 hard[d, c:c + 1])
    stats = np.full((NVAL, 4, D), np.nan)
    counts = np.empty(D, dtype=np.int64)
    # serially: a few operations per chunk, less than waking the threads again
    for d in range(D):
        _combine(d, nch, want, cnt, part, stats, counts)
    return stats, counts, reach, hard.sum(axis=1)


@njit(**_NJIT)
def _combine(d, nch, want, cnt, part, stats, counts):
    """Chunks of design d in order: count, sum, min, max, and the centred sum
    of squares (Chan et al.'s pairwise update)."""
    k = 0
    for c in range(nch):
        k += cnt[d, c]
    counts[d] = k
    if k == 0:
        return
    for v in range(NVAL):
        if not want[v]:
            continue
        s, lo_v, hi_v, m2 = chunk_moments(part, cnt, d, v, k, nch)
        stats[v, 0, d] = s
        stats[v, 1, d] = lo_v
        stats[v, 2, d] = hi_v
        stats[v, 3, d] = m2


# ---------------------------------------------------------------------- inputs (the former compiled path's)
def design_constants(mech) -> np.ndarray:
    """Per-design constants (D, 15) of a P4S whose parameters are scalars, (D,)
    or (D, 1): ``rho - r_b``, L, L^2, the mass-matrix coefficients c0, alpha,
    beta and the nine components of the rail directions m_i (the numpy model's
    own expressions)."""
    from optdesign.mechanisms.p4s.dynamics import mass_coefficients

    shape = mech.design_shape
    D = int(np.prod(shape)) if len(shape) else 1
    rho = np.asarray(mech.rho, dtype=float)
    off = np.broadcast_to(rho - np.asarray(mech.r_b, dtype=float), shape).reshape(D)
    L = np.broadcast_to(np.asarray(mech.L, dtype=float), shape).reshape(D)
    m = np.broadcast_to(mech.rail_directions(), shape + (3, 3)).reshape(D, 9)
    c0, alpha, beta = (np.broadcast_to(c, shape).reshape(D) for c in mass_coefficients(mech))
    P = np.empty((D, 15))
    P[:, 0] = off
    P[:, 1] = L
    P[:, 2] = L ** 2
    P[:, 3] = c0
    P[:, 4] = alpha
    P[:, 5] = beta
    P[:, 6:15] = m
    return np.ascontiguousarray(P)


def summary_means(mech, X, want=(True, True, False, True, False)):
    """Means over the reachable points of the kernel's values (dynamic,
    sigma_min^2, sigma_min, cond_fro, cond_2) for the designs of mech, the
    ill-conditioned points left out (the benchmark's bare call)."""
    sums, counts, _, _ = p4s_summary(design_constants(mech), np.ascontiguousarray(X, dtype=float),
                                     np.array(want, dtype=np.bool_), bool(want[4]))
    with np.errstate(all="ignore"):
        return sums[:, 0] / counts
