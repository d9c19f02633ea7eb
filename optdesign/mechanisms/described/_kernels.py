"""Numba kernels of described mechanisms: one generic kernel for every leg
kind and pose type, driven by per-design constant arrays, compiled once per
size ``n`` (legs = pose coordinates).

Points are processed in blocks of BLK as structure-of-arrays: every
intermediate quantity is a row of BLK values (``A[i, k, :]`` for entry
(i, k) of a per-point matrix), and every stage is a loop over the block's
points whose body is straight-line code, so that LLVM vectorizes it across
points.  The size n reaches the kernels as the length of a tuple (``nt``), a
compile-time constant: loops over matrix indices inside the point loops are
unrolled (entries beyond a triangle are masked with selects, not skipped).

Per (design, workspace point), the formulas of the numpy path (:mod:`.poses`,
:mod:`.legs`, :mod:`.dynamics`), in the same order where the order decides
the reachable mask:

* the platform frame ``R`` and the rate map's Euler columns come from the
  numpy path itself (``FR``: computed once per call, per point, by the caller);
* per leg the closed-form inverse kinematics of its kind and branch, the rod
  ``d``, ``d.t`` and the twist row ``g_i = (d, r x d) / (d.t)``; J = G S
  (S: a selection of twist components, or the Euler columns);
* R of the QR factorization of J (Householder): ``|det J| = prod |R_kk|``,
  ``||J^-1||_F = ||R^-1||_F`` and the singular values of J^-1 are those of
  ``R^-1`` (Q is never formed);
* every singular value an index needs is the largest of some matrix:
  ``sigma_min(J)^2 = 1 / lambda_max(R^-1 R^-T)``, ``sigma_max(J)^2 =
  lambda_max(J^T J)``, and for the dynamic index ``M = J^-T M_p = Q R^-T M_p``
  so ``sigma_max(M)^2 = lambda_max(W^T W)`` with ``W = R^-T M_p``;
* lambda_max of a symmetric positive semi-definite n x n matrix: in closed
  form for n <= 3 (:func:`_lmax3`: no libm call, and no loss of digits at a
  double eigenvalue); for n >= 4 a Householder tridiagonalization, NEWTON
  steps on its characteristic polynomial that are exact for a pair of close
  eigenvalues (:func:`_lmax_tri`), then a Sturm-count check that the value is
  within TAU (relative) of lambda_max, and bisection for a point where it is not;
* the pose-space mass matrix from the bodies, without forming the bodies'
  velocity maps: ``M_p = S^T B S + sum_i [gamma_i J_i^T J_i + delta_i
  (J_i^T K_i + K_i^T J_i)]`` with B the rigid-body matrix of the platform and
  the bodies' shares that move with the platform points (see :func:`_leg_rod`,
  :func:`_leg_strut`), J_i the Jacobian row and K_i the row of ``t.bdot``;
* a reach code: 0 unreachable, 1 reachable, 2 reachable but ill-conditioned
  (``cond_F(J) >= HARD`` or anything not finite), left to the numpy path.

The reductions: fixed chunks of CHUNK points per design, each with its count,
sum, min, max and centred sum of squares in point order, combined in chunk
order, so results do not depend on the number of threads.

The memory layout (the row and column numbers above) is :mod:`._layout`; the
straight-line routines generated per size and spec are written by
:mod:`._codegen` (``optdesign kernel-source CONFIG`` prints them).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numba import uint64 as _u
from numba.extending import overload

from ...fast._jit import NJIT as _NJIT
from ...fast._jit import chunk_moments, lambda_max_psd
from ...fast._jit import dot3_dd as _dot3_dd
from ...fast._jit import minor_dd as _minor_dd
from . import _layout
from ._codegen import GLOBALS, KernelSpec, routine_source, size_of_type
from ._layout import (BA, BLK, BS, BW, CHUNK, COL0, CT_ROLL, DET, DYN, FCEN, FCOM, FIP, FMP, FRE, FRO, FRO_, FRR, GAL,
                      GDE, GG, GGA, GK, GR, HARD, IFRO, LA, LE1, LE2, LFROD, LI12, LIROD, LLA, LLR, LM1, LM2, LMACT,
                      LMROD, LP, LR0, LS0, LSG, LU, NB, NFR, NLG, NVAL, NVS, SMIN, SMIN2, TWO, VBETA, VDET, VI2, VLJ,
                      VLU, VLW, VMASK, VOK, VV0)
# the rest of the layout, read by compiled.py and the tests as K.<name>
from ._layout import CT_PITCH, FFIX, FR_ROWS, NEWTON, NEWTON_DYN, NF, NL, TAU, VF2, VS, VX  # noqa: F401

#: numba's cache of these kernels watches this file only, while the code of
#: _codegen.py and the numbers of _layout.py (and its ids from
#: optdesign/formulas.py) are compiled into them: this
#: file records their digest, so that editing them means editing this file
#: too (tests/test_kernel_generators.py checks it); until then the kernels
#: compile without the cache (a warning says so), never from a stale one
GENERATOR_DIGEST = "60661ad4bc796344"


def generator_digest() -> str:
    """sha256 (first 16 hex digits) of _codegen.py, _layout.py and the table of
    value ids optdesign/formulas.py as they are now."""
    import hashlib
    from pathlib import Path

    h = hashlib.sha256()
    for path in (Path(__file__).with_name("_codegen.py"), Path(__file__).with_name("_layout.py"),
                 Path(__file__).parents[2] / "formulas.py"):
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


if generator_digest() != GENERATOR_DIGEST:
    import warnings

    warnings.warn(f"{__name__}: _codegen.py, _layout.py or formulas.py changed (digest {generator_digest()}, recorded "
                  f"{GENERATOR_DIGEST}): the kernels compile without numba's cache until GENERATOR_DIGEST is updated",
                  RuntimeWarning, stacklevel=1)
    _NJIT = {**_NJIT, "cache": False}

#: the chunk reductions only: reassociation lets LLVM vectorize the sums (the
#: order is still fixed by the code, so results do not depend on threads)
_NJIT_RED = {**_NJIT, "fastmath": {"reassoc", "nsz"}}
#: options of the overloads (their code is compiled into the cached kernels that call them)
_GEN_OPTIONS = dict(error_model="numpy", fastmath=False)


# ---------------------------------------------------------------------- lambda_max
#: closed form for n = 3 (shared with the 3-P(4S) kernel)
_lmax3_point = lambda_max_psd


@njit(inline="always", **_NJIT)
def _count_below(T, j, n, x):
    """The number of eigenvalues of the (scaled) tridiagonal T (diagonal rows
    0..n-1, squared off-diagonal rows n..) below x: sign changes of the leading
    principal minors of T - x I (Sturm)."""
    p0 = 1.0
    p1 = T[j] - x
    cnt = 1 if p1 < 0.0 else 0
    for k in range(1, n):
        p2 = (T[_u(k * BLK + j)] - x) * p1 - T[_u((n + k - 1) * BLK + j)] * p0
        cnt += 1 if (p2 < 0.0) != (p1 < 0.0) else 0
        p0 = p1
        p1 = p2
    return cnt


@njit(**_NJIT)
def _bisect_flagged(T, out, V, nt, m):
    """out[j] for the points flagged in V's row VV0 (lambda_max not certified by
    the Newton steps): bisection of the scaled tridiagonal T to the last bit,
    then the scale (V's row VBETA)."""
    n = len(nt)
    for j in range(m):
        if V[_u(VV0 * BLK + j)] != 0.0:
            lo = 0.0
            hi = 1.0
            for _ in range(80):
                mid = 0.5 * (lo + hi)
                if mid <= lo or mid >= hi:
                    break
                if _count_below(T, j, n, mid) == n:
                    hi = mid
                else:
                    lo = mid
            out[j] = 0.5 * (lo + hi) * V[_u(VBETA * BLK + j)]


# ---------------------------------------------------------------------- dense small matrices




@njit(**_NJIT)
def _inverse_small(A, U, V, nt, m):
    """U = A^-1 for n <= 3 by the adjugate, its minors and the determinant in
    about twice the working precision (so U's entries are exact to a few ulps
    whatever cond(A): the cancellation of near-singular points stays out);
    V rows VDET <- |det A|, VI2 <- ||U||_F^2."""
    n = len(nt)
    if n == 1:
        for j in range(m):
            a = A[j]
            u = 1.0 / a
            U[j] = u
            V[VDET * BLK + j] = abs(a)
            V[VI2 * BLK + j] = u * u
    elif n == 2:
        for j in range(m):
            a = A[j]
            b = A[BLK + j]
            c = A[2 * BLK + j]
            d = A[3 * BLK + j]
            h, lo = _minor_dd(a, b, c, d)
            det = h + lo
            iv = 1.0 / det
            u00 = d * iv
            u01 = -b * iv
            u10 = -c * iv
            u11 = a * iv
            U[j] = u00
            U[BLK + j] = u01
            U[2 * BLK + j] = u10
            U[3 * BLK + j] = u11
            V[VDET * BLK + j] = abs(det)
            V[VI2 * BLK + j] = (u00 * u00 + u01 * u01) + (u10 * u10 + u11 * u11)
    else:
        for j in range(m):
            a0 = A[j]
            a1 = A[BLK + j]
            a2 = A[2 * BLK + j]
            b0 = A[3 * BLK + j]
            b1 = A[4 * BLK + j]
            b2 = A[5 * BLK + j]
            c0 = A[6 * BLK + j]
            c1 = A[7 * BLK + j]
            c2 = A[8 * BLK + j]
            # column k of A^-1: the cross product of the other two rows over det
            h00, l00 = _minor_dd(b1, b2, c1, c2)
            h01, l01 = _minor_dd(b2, b0, c2, c0)
            h02, l02 = _minor_dd(b0, b1, c0, c1)
            h10, l10 = _minor_dd(c1, c2, a1, a2)
            h11, l11 = _minor_dd(c2, c0, a2, a0)
            h12, l12 = _minor_dd(c0, c1, a0, a1)
            h20, l20 = _minor_dd(a1, a2, b1, b2)
            h21, l21 = _minor_dd(a2, a0, b2, b0)
            h22, l22 = _minor_dd(a0, a1, b0, b1)
            det = _dot3_dd(a0, a1, a2, h00, l00, h01, l01, h02, l02)
            iv = 1.0 / det
            u00 = (h00 + l00) * iv
            u10 = (h01 + l01) * iv
            u20 = (h02 + l02) * iv
            u01 = (h10 + l10) * iv
            u11 = (h11 + l11) * iv
            u21 = (h12 + l12) * iv
            u02 = (h20 + l20) * iv
            u12 = (h21 + l21) * iv
            u22 = (h22 + l22) * iv
            U[j] = u00
            U[BLK + j] = u01
            U[2 * BLK + j] = u02
            U[3 * BLK + j] = u10
            U[4 * BLK + j] = u11
            U[5 * BLK + j] = u12
            U[6 * BLK + j] = u20
            U[7 * BLK + j] = u21
            U[8 * BLK + j] = u22
            V[VDET * BLK + j] = abs(det)
            V[VI2 * BLK + j] = ((u00 * u00 + u01 * u01 + u02 * u02) + (u10 * u10 + u11 * u11 + u12 * u12)
                                + (u20 * u20 + u21 * u21 + u22 * u22))


# ---------------------------------------------------------------------- legs
def _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, cspec):
    """r = R P and b = (o + centre) + r at point j of the frame block (R = I
    for a translation pose, whose frame block has no R rows)."""


@overload(_platform_point, inline="always", jit_options=_GEN_OPTIONS)
def _ov_platform_point(FRb, j, P0, P1, P2, o0, o1, o2, cspec):
    if KernelSpec.of_type(cspec).rot:
        def impl(FRb, j, P0, P1, P2, o0, o1, o2, cspec):
            r0 = FRb[_u(FRR * BLK + j)] * P0 + FRb[_u((FRR + 1) * BLK + j)] * P1 + FRb[_u((FRR + 2) * BLK + j)] * P2
            r1 = FRb[_u((FRR + 3) * BLK + j)] * P0 + FRb[_u((FRR + 4) * BLK + j)] * P1 + FRb[_u((FRR + 5) * BLK + j)] * P2
            r2 = FRb[_u((FRR + 6) * BLK + j)] * P0 + FRb[_u((FRR + 7) * BLK + j)] * P1 + FRb[_u((FRR + 8) * BLK + j)] * P2
            b0 = (FRb[_u(FRO_ * BLK + j)] + o0) + r0
            b1 = (FRb[_u((FRO_ + 1) * BLK + j)] + o1) + r1
            b2 = (FRb[_u((FRO_ + 2) * BLK + j)] + o2) + r2
            return r0, r1, r2, b0, b1, b2
        return impl

    def impl(FRb, j, P0, P1, P2, o0, o1, o2, cspec):
        b0 = (FRb[_u(FRO_ * BLK + j)] + o0) + P0
        b1 = (FRb[_u((FRO_ + 1) * BLK + j)] + o1) + P1
        b2 = (FRb[_u((FRO_ + 2) * BLK + j)] + o2) + P2
        return P0, P1, P2, b0, b1, b2
    return impl


@njit(inline="always", **_NJIT)
def _twist_row(Li, j, r0, r1, r2, d0, d1, d2, den):
    """g_i = (d, r x d) / den."""
    iv = 1.0 / den
    Li[GG * BLK + j] = d0 * iv
    Li[(GG + 1) * BLK + j] = d1 * iv
    Li[(GG + 2) * BLK + j] = d2 * iv
    Li[(GG + 3) * BLK + j] = (r1 * d2 - r2 * d1) * iv
    Li[(GG + 4) * BLK + j] = (r2 * d0 - r0 * d2) * iv
    Li[(GG + 5) * BLK + j] = (r0 * d1 - r1 * d0) * iv


@njit(inline="always", **_NJIT)
def _rod_coefficients(Li, j, r0, r1, r2, t0, t1, t2, mr, ir, f, l2, ma):
    """The leg's bodies in M_p (rod of mass mr centred at a + f d, transverse
    inertia ir, actuator body ma): with bdot = Vb xi, qdot = J xi and K = t.bdot,
    the rod's centre moves with (1 - f) t J + f Vb and turns with
    d x (Vb - t J) / l^2; as d.(Vb - t J) = 0 and |d| = l,

        mr |(1-f) t J + f Vb|^2 + ir |Vb - t J|^2 / l^2 + ma J^2
          = alpha |Vb|^2 + gamma J^2 + delta 2 J K,

    alpha = mr f^2 + ir / l^2, gamma = mr (1-f)^2 |t|^2 + ir |t|^2 / l^2 + ma,
    delta = mr f (1-f) - ir / l^2.  Stores K's twist row (t, r x t)."""
    tt = t0 * t0 + t1 * t1 + t2 * t2
    il = ir / l2
    g = 1.0 - f
    Li[GAL * BLK + j] = mr * f * f + il
    Li[GGA * BLK + j] = (mr * g * g + il) * tt + ma
    Li[GDE * BLK + j] = mr * f * g - il
    Li[GK * BLK + j] = t0
    Li[(GK + 1) * BLK + j] = t1
    Li[(GK + 2) * BLK + j] = t2
    Li[(GK + 3) * BLK + j] = r1 * t2 - r2 * t1
    Li[(GK + 4) * BLK + j] = r2 * t0 - r0 * t2
    Li[(GK + 5) * BLK + j] = r0 * t1 - r1 * t0


@njit(**_NJIT)
def _leg_prismatic(L, F, d, i, ptype, FRb, br, m, Li, V, dyn, cspec):
    """Slider at a = A + q u, rod of length l: q = u.w -+ sqrt((u.w)^2 - |w|^2 + l^2)."""
    A0 = L[d, i, LA]
    A1 = L[d, i, LA + 1]
    A2 = L[d, i, LA + 2]
    u0 = L[d, i, LU]
    u1 = L[d, i, LU + 1]
    u2 = L[d, i, LU + 2]
    Lr = L[d, i, LLR]
    mr = L[d, i, LMROD]
    ir = L[d, i, LIROD]
    f = L[d, i, LFROD]
    ma = L[d, i, LMACT]
    P0 = L[d, i, LP]
    P1 = L[d, i, LP + 1]
    P2 = L[d, i, LP + 2]
    o0 = F[d, FCEN] if ptype == 2 else 0.0
    o1 = F[d, FCEN + 1] if ptype == 2 else 0.0
    o2 = F[d, FCEN + 2] if ptype == 2 else 0.0
    for j in range(m):
        r0, r1, r2, b0, b1, b2 = _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, cspec)
        Li[GR * BLK + j] = r0
        Li[(GR + 1) * BLK + j] = r1
        Li[(GR + 2) * BLK + j] = r2
        w0 = b0 - A0
        w1 = b1 - A1
        w2 = b2 - A2
        ww = w0 * w0 + w1 * w1 + w2 * w2
        uw = u0 * w0 + u1 * w1 + u2 * w2
        disc = Lr * Lr - ww + uw * uw
        closes = disc >= 0.0
        V[VOK * BLK + j] = V[VOK * BLK + j] if closes else 0.0
        root = math.sqrt(disc if closes else 0.0)
        qm = uw - root
        qp = uw + root
        am0 = A0 + qm * u0
        am1 = A1 + qm * u1
        am2 = A2 + qm * u2
        ap0 = A0 + qp * u0
        ap1 = A1 + qp * u1
        ap2 = A2 + qp * u2
        far = ap0 * ap0 + ap1 * ap1 + ap2 * ap2 > am0 * am0 + am1 * am1 + am2 * am2
        plus = (br == 1) | ((br == 2) & far) | ((br == 3) & (not far))
        q = qp if plus else qm
        den = -root if plus else root
        d0 = b0 - (A0 + q * u0)
        d1 = b1 - (A1 + q * u1)
        d2 = b2 - (A2 + q * u2)
        _twist_row(Li, j, r0, r1, r2, d0, d1, d2, den)
        if dyn:
            _rod_coefficients(Li, j, r0, r1, r2, u0, u1, u2, mr, ir, f, Lr * Lr, ma)


@njit(inline="always", **_NJIT)
def _wrap(q):
    return q - 2.0 * math.pi * np.round(q / (2.0 * math.pi))


@njit(**_NJIT)
def _leg_revolute(L, F, d, i, ptype, FRb, br, m, Li, V, dyn, cspec):
    """Crank of length L_a about k through A (tip A + L_a (cos q r0 + sin q s0)),
    rod of length l: q = atan2(Q, P) +- atan2(sqrt(P^2 + Q^2 - C^2), C)."""
    A0 = L[d, i, LA]
    A1 = L[d, i, LA + 1]
    A2 = L[d, i, LA + 2]
    La = L[d, i, LLA]
    Lr = L[d, i, LLR]
    R00 = L[d, i, LR0]
    R01 = L[d, i, LR0 + 1]
    R02 = L[d, i, LR0 + 2]
    S00 = L[d, i, LS0]
    S01 = L[d, i, LS0 + 1]
    S02 = L[d, i, LS0 + 2]
    mr = L[d, i, LMROD]
    ir = L[d, i, LIROD]
    f = L[d, i, LFROD]
    ma = L[d, i, LMACT]
    sg = L[d, i, LSG]          # the root settled per design (Constants.sign)
    P0 = L[d, i, LP]
    P1 = L[d, i, LP + 1]
    P2 = L[d, i, LP + 2]
    o0 = F[d, FCEN] if ptype == 2 else 0.0
    o1 = F[d, FCEN + 1] if ptype == 2 else 0.0
    o2 = F[d, FCEN + 2] if ptype == 2 else 0.0
    for j in range(m):
        r0, r1, r2, b0, b1, b2 = _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, cspec)
        Li[GR * BLK + j] = r0
        Li[(GR + 1) * BLK + j] = r1
        Li[(GR + 2) * BLK + j] = r2
        w0 = b0 - A0
        w1 = b1 - A1
        w2 = b2 - A2
        ww = w0 * w0 + w1 * w1 + w2 * w2
        Pc = w0 * R00 + w1 * R01 + w2 * R02
        Qc = w0 * S00 + w1 * S01 + w2 * S02
        Cc = (ww + La * La - Lr * Lr) / (2.0 * La)
        h2 = Pc * Pc + Qc * Qc - Cc * Cc
        closes = (h2 >= 0.0) and (sg == sg)       # sg NaN: outer / inner not defined for this design
        V[VOK * BLK + j] = V[VOK * BLK + j] if closes else 0.0
        h = math.sqrt(h2 if closes else 0.0)
        phi0 = math.atan2(Qc, Pc)
        dl = math.atan2(h, Cc)
        qp = _wrap(phi0 + dl)
        qm = _wrap(phi0 - dl)
        cpp = math.cos(qp)
        spp = math.sin(qp)
        cmm = math.cos(qm)
        smm = math.sin(qm)
        plus = sg > 0.0
        cq = cpp if plus else cmm
        sq = spp if plus else smm
        c0 = cq * R00 + sq * S00
        c1 = cq * R01 + sq * S01
        c2 = cq * R02 + sq * S02
        den = -La * h if plus else La * h
        d0 = b0 - (A0 + La * c0)
        d1 = b1 - (A1 + La * c1)
        d2 = b2 - (A2 + La * c2)
        _twist_row(Li, j, r0, r1, r2, d0, d1, d2, den)
        if dyn:
            t0 = La * (-sq * R00 + cq * S00)
            t1 = La * (-sq * R01 + cq * S01)
            t2 = La * (-sq * R02 + cq * S02)
            _rod_coefficients(Li, j, r0, r1, r2, t0, t1, t2, mr, ir, f, Lr * Lr, ma)


@njit(**_NJIT)
def _leg_strut(L, F, d, i, ptype, FRb, m, Li, dyn, cspec):
    """Strut of actuated length q = |w|.  Bodies: the lower part (mass m1,
    centre e1 from A) and the upper part (m2, centre e2 from b), inertia I12
    between them, all turning with n x bdot / q; with p = (bdot - n (n.bdot)) / q
    (so |n x bdot|^2 / q^2 = |p|^2, bdot.p = q |p|^2) their energy is

        m1 e1^2 |p|^2 + m2 |bdot - e2 p|^2 + I12 |p|^2 = alpha |bdot|^2 + gamma (n.bdot)^2,

    c = m1 e1^2 + I12 + m2 (e2^2 - 2 e2 q), alpha = m2 + c / q^2, gamma = -c / q^2
    (n.bdot = J xi: the strut's row)."""
    A0 = L[d, i, LA]
    A1 = L[d, i, LA + 1]
    A2 = L[d, i, LA + 2]
    m1 = L[d, i, LM1]
    e1 = L[d, i, LE1]
    m2 = L[d, i, LM2]
    e2 = L[d, i, LE2]
    i12 = L[d, i, LI12]
    c_ = m1 * e1 * e1 + i12 + m2 * e2 * e2
    P0 = L[d, i, LP]
    P1 = L[d, i, LP + 1]
    P2 = L[d, i, LP + 2]
    o0 = F[d, FCEN] if ptype == 2 else 0.0
    o1 = F[d, FCEN + 1] if ptype == 2 else 0.0
    o2 = F[d, FCEN + 2] if ptype == 2 else 0.0
    for j in range(m):
        r0, r1, r2, b0, b1, b2 = _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, cspec)
        Li[GR * BLK + j] = r0
        Li[(GR + 1) * BLK + j] = r1
        Li[(GR + 2) * BLK + j] = r2
        w0 = b0 - A0
        w1 = b1 - A1
        w2 = b2 - A2
        q = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        iq = 1.0 / q
        Li[GG * BLK + j] = w0 * iq
        Li[(GG + 1) * BLK + j] = w1 * iq
        Li[(GG + 2) * BLK + j] = w2 * iq
        Li[(GG + 3) * BLK + j] = (r1 * w2 - r2 * w1) * iq
        Li[(GG + 4) * BLK + j] = (r2 * w0 - r0 * w2) * iq
        Li[(GG + 5) * BLK + j] = (r0 * w1 - r1 * w0) * iq
        if dyn:
            c = c_ - 2.0 * m2 * e2 * q
            iq = c * (iq * iq)
            Li[GAL * BLK + j] = m2 + iq
            Li[GGA * BLK + j] = -iq
    if dyn:
        # no rod: delta = 0 and K = 0 (read only where another leg has a rod)
        for k in range(7):
            for j in range(m):
                Li[(GDE if k == 6 else GK + k) * BLK + j] = 0.0


@njit(**_NJIT)
def _pose_rows(Lg, src, ct, FRb, m, J, nt):
    """J[i, c] = (twist row src of leg i) . (column c of S)."""
    n = len(nt)
    for i in range(n):
        Li = Lg[i]
        for c in range(n):
            k = ct[c]
            o = (i * n + c) * BLK
            if k < 6:
                for j in range(m):
                    J[o + j] = Li[(src + k) * BLK + j]
            elif k == CT_ROLL:
                for j in range(m):
                    J[o + j] = ((Li[(src + 3) * BLK + j] * FRb[_u(FRE * BLK + j)]
                                 + Li[(src + 4) * BLK + j] * FRb[_u((FRE + 1) * BLK + j)])
                                + Li[(src + 5) * BLK + j] * FRb[_u((FRE + 2) * BLK + j)])
            else:
                for j in range(m):
                    J[o + j] = (Li[(src + 3) * BLK + j] * FRb[_u((FRE + 3) * BLK + j)]
                                + Li[(src + 4) * BLK + j] * FRb[_u((FRE + 4) * BLK + j)])


# ---------------------------------------------------------------------- mass matrix
@njit(**_NJIT)
def _rigid(ptype, F, d, FRb, m, Lg, B, nt, rot):
    """The rigid-body matrix sum_b m_b [I, -[r_b]x; [r_b]x, |r_b|^2 I - r_b r_b^T]
    of the platform (mass at R c) and the legs' shares alpha_i at r_i, plus the
    platform's R I_p R^T (rot: the pose has angles), as its ten numbers: rows
    BA (the mass), BS..BS+2 (the first moment s: the block -[s]x), BW..BW+5
    (the angular block: 00, 11, 22, 01, 02, 12).  Translation: the mass only."""
    n = len(nt)
    mp = F[d, FMP]
    if ptype == 0:
        for j in range(m):
            a = mp
            for i in range(n):
                a += Lg[i, GAL * BLK + j]
            B[BA * BLK + j] = a
        return
    k0 = F[d, FCOM]
    k1 = F[d, FCOM + 1]
    k2 = F[d, FCOM + 2]
    I00 = F[d, FIP]
    I01 = F[d, FIP + 1]
    I02 = F[d, FIP + 2]
    I11 = F[d, FIP + 4]
    I12 = F[d, FIP + 5]
    I22 = F[d, FIP + 8]
    for j in range(m):
        R00 = FRb[_u(FRR * BLK + j)]
        R01 = FRb[_u((FRR + 1) * BLK + j)]
        R02 = FRb[_u((FRR + 2) * BLK + j)]
        R10 = FRb[_u((FRR + 3) * BLK + j)]
        R11 = FRb[_u((FRR + 4) * BLK + j)]
        R12 = FRb[_u((FRR + 5) * BLK + j)]
        R20 = FRb[_u((FRR + 6) * BLK + j)]
        R21 = FRb[_u((FRR + 7) * BLK + j)]
        R22 = FRb[_u((FRR + 8) * BLK + j)]
        c0 = R00 * k0 + R01 * k1 + R02 * k2
        c1 = R10 * k0 + R11 * k1 + R12 * k2
        c2 = R20 * k0 + R21 * k1 + R22 * k2
        a = mp
        s0 = mp * c0
        s1 = mp * c1
        s2 = mp * c2
        q00 = mp * (c0 * c0)
        q11 = mp * (c1 * c1)
        q22 = mp * (c2 * c2)
        q01 = mp * (c0 * c1)
        q02 = mp * (c0 * c2)
        q12 = mp * (c1 * c2)
        for i in range(n):
            al = Lg[i, GAL * BLK + j]
            r0 = Lg[i, GR * BLK + j]
            r1 = Lg[i, (GR + 1) * BLK + j]
            r2 = Lg[i, (GR + 2) * BLK + j]
            a += al
            s0 += al * r0
            s1 += al * r1
            s2 += al * r2
            q00 += al * (r0 * r0)
            q11 += al * (r1 * r1)
            q22 += al * (r2 * r2)
            q01 += al * (r0 * r1)
            q02 += al * (r0 * r2)
            q12 += al * (r1 * r2)
        tr = q00 + q11 + q22
        w00 = tr - q00
        w11 = tr - q11
        w22 = tr - q22
        w01 = -q01
        w02 = -q02
        w12 = -q12
        if rot:
            # R I_p R^T
            x00 = R00 * I00 + R01 * I01 + R02 * I02
            x01 = R00 * I01 + R01 * I11 + R02 * I12
            x02 = R00 * I02 + R01 * I12 + R02 * I22
            x10 = R10 * I00 + R11 * I01 + R12 * I02
            x11 = R10 * I01 + R11 * I11 + R12 * I12
            x12 = R10 * I02 + R11 * I12 + R12 * I22
            x20 = R20 * I00 + R21 * I01 + R22 * I02
            x21 = R20 * I01 + R21 * I11 + R22 * I12
            x22 = R20 * I02 + R21 * I12 + R22 * I22
            w00 += x00 * R00 + x01 * R01 + x02 * R02
            w11 += x10 * R10 + x11 * R11 + x12 * R12
            w22 += x20 * R20 + x21 * R21 + x22 * R22
            w01 += x00 * R10 + x01 * R11 + x02 * R12
            w02 += x00 * R20 + x01 * R21 + x02 * R22
            w12 += x10 * R20 + x11 * R21 + x12 * R22
        B[BA * BLK + j] = a
        B[BS * BLK + j] = s0
        B[(BS + 1) * BLK + j] = s1
        B[(BS + 2) * BLK + j] = s2
        B[BW * BLK + j] = w00
        B[(BW + 1) * BLK + j] = w11
        B[(BW + 2) * BLK + j] = w22
        B[(BW + 3) * BLK + j] = w01
        B[(BW + 4) * BLK + j] = w02
        B[(BW + 5) * BLK + j] = w12


# ---------------------------------------------------------------------- generated fixed-size code
# The routines whose loops over matrix indices would otherwise run with
# run-time bounds are generated as straight-line code for the size n (the
# length of the tuple nt) and the spec (cspec) when numba first types a call
# (:mod:`._codegen` writes the source; ``optdesign kernel-source`` prints it).
# Each is an @overload of a stub below; the code is compiled into (and cached
# with) the kernel that calls it (numba's cache: see GENERATOR_DIGEST).
_GEN_NAMES = {"math": math, "np": np, "_u": _u, "_lmax3_point": _lmax3_point, "_bisect_flagged": _bisect_flagged,
              **{k: getattr(_layout, k) for k in GLOBALS if hasattr(_layout, k)}}


def _compile(source):
    """The function ``impl`` defined by the generated source."""
    ns = dict(_GEN_NAMES)
    exec(compile(source, "<optdesign described kernel (generated)>", "exec"), ns)
    return ns["impl"]


def _inverse(A, U, V, nt, m):
    """U = A^-1 (n <= 3) or R^-1 of A = QR (n >= 4: upper triangular, with the
    singular values of A^-1; Q is never formed); V rows VDET <- |det A|,
    VI2 <- ||A^-1||_F^2."""


@overload(_inverse, jit_options=_GEN_OPTIONS)
def _ov_inverse(A, U, V, nt, m):
    n = size_of_type(nt)
    if n <= 3:
        def impl(A, U, V, nt, m):
            _inverse_small(A, U, V, nt, m)
        return impl
    return _compile(routine_source("_inverse", n))


def _lmax_cols(X, out, T, V, nt, m):
    """out[j] = lambda_max(X^T X) (X n x n)."""


def _lmax_rows(X, out, T, V, nt, m):
    """out[j] = lambda_max(X X^T) for X from _inverse (upper triangular for n >= 4)."""


def _lmax_dyn(X, out, T, V, nt, m):
    """out[j] = lambda_max(X^T X) for the dynamic index's W (NEWTON_DYN steps)."""


@overload(_lmax_cols, jit_options=_GEN_OPTIONS)
def _ov_lmax_cols(X, out, T, V, nt, m):
    return _compile(routine_source("_lmax_cols", size_of_type(nt)))


@overload(_lmax_rows, jit_options=_GEN_OPTIONS)
def _ov_lmax_rows(X, out, T, V, nt, m):
    return _compile(routine_source("_lmax_rows", size_of_type(nt)))


@overload(_lmax_dyn, jit_options=_GEN_OPTIONS)
def _ov_lmax_dyn(X, out, T, V, nt, m):
    if routine_source("_lmax_dyn", size_of_type(nt)) == routine_source("_lmax_cols", size_of_type(nt)):
        # the same code (NEWTON_DYN == NEWTON): compiled once, as _lmax_cols, and called
        def impl(X, out, T, V, nt, m):
            _lmax_cols(X, out, T, V, nt, m)
        return impl
    return _compile(routine_source("_lmax_dyn", size_of_type(nt)))


def _dyn_w(B, Lg, J, Kp, FRb, U, W, nt, cspec, m):
    """W = U^T M_p (U from _inverse), see _codegen.dyn_source; cspec: the
    KernelSpec as a type (KernelSpec.numba_args)."""


@overload(_dyn_w, jit_options=_GEN_OPTIONS)
def _ov_dyn_w(B, Lg, J, Kp, FRb, U, W, nt, cspec, m):
    return _compile(routine_source("_dyn_w", size_of_type(nt), KernelSpec.of_type(cspec)))


def _mass_p(B, Lg, J, Kp, FRb, U, W, nt, cspec, m):
    """W = M_p (full), see _codegen.dyn_source."""


@overload(_mass_p, jit_options=_GEN_OPTIONS)
def _ov_mass_p(B, Lg, J, Kp, FRb, U, W, nt, cspec, m):
    return _compile(routine_source("_mass_p", size_of_type(nt), KernelSpec.of_type(cspec)))


# ---------------------------------------------------------------------- one block of points
@njit(**_NJIT)
def _alloc(nt):
    """The scratch of one worker (flat rows of BLK, zeros: code that computes a
    whole block reads finite numbers beyond m): legs (n, NLG BLK), four n x n
    matrices (J, J^-1 or R^-1, K, W), the rigid-body B (NB rows), the
    tridiagonal (2 n rows), vectors (NVS + 3 n rows)."""
    n = len(nt)
    return (np.zeros((n, NLG * BLK)), np.zeros((4, n * n * BLK)), np.zeros(NB * BLK), np.zeros(2 * n * BLK),
            np.zeros((NVS + 3 * n) * BLK))


@njit(**_NJIT)
def _block(nt, cspec, ptype, ct, kind, branch, L, F, d, FRb, m, want, flags, scratch, vb, cb):
    """Values and reach codes of design d at the m points of the frame block
    FRb: value v of point j into vb[v CHUNK + j], its code (as a float) into cb[j]."""
    n = len(nt)
    dyn, sv_inv, sv_j, cols, rods, rot = flags
    Lg, mats, B, T, V = scratch
    J = mats[0]
    U = mats[1]
    Kp = mats[2]
    Wm = mats[3]
    for j in range(m):
        V[VOK * BLK + j] = 1.0
    for i in range(n):
        Li = Lg[i]
        k = kind[i]
        if k == 0:
            _leg_prismatic(L, F, d, i, ptype, FRb, branch[i], m, Li, V, dyn, cspec)
        elif k == 1:
            _leg_revolute(L, F, d, i, ptype, FRb, branch[i], m, Li, V, dyn, cspec)
        else:
            _leg_strut(L, F, d, i, ptype, FRb, m, Li, dyn, cspec)
    _pose_rows(Lg, GG, ct, FRb, m, J, nt)
    if cols:
        for c in range(n):
            for j in range(m):
                s = 0.0
                for i in range(n):
                    x = J[(i * n + c) * BLK + j]
                    s += x * x
                vb[(COL0 + c) * CHUNK + j] = s
    _inverse(J, U, V, nt, m)
    for j in range(m):
        s = 0.0
        for i in range(n * n):
            x = J[i * BLK + j]
            s += x * x
        cf = math.sqrt(s * V[VI2 * BLK + j])
        det = V[VDET * BLK + j]
        good = (V[VOK * BLK + j] != 0.0) & (det > 0.0) & (cf < HARD)
        V[VMASK * BLK + j] = 1.0 if good else 0.0
        cb[j] = (1.0 if good else 2.0) if V[VOK * BLK + j] != 0.0 else 0.0
        vb[FRO * CHUNK + j] = cf
        vb[IFRO * CHUNK + j] = 1.0 / cf
        vb[DET * CHUNK + j] = det
    if sv_inv:
        _lmax_rows(U, V[VLU * BLK:(VLU + 1) * BLK], T, V, nt, m)
        for j in range(m):
            s2 = 1.0 / V[VLU * BLK + j]
            vb[SMIN2 * CHUNK + j] = s2
            vb[SMIN * CHUNK + j] = math.sqrt(s2)
        if sv_j:
            _lmax_cols(J, V[VLJ * BLK:(VLJ + 1) * BLK], T, V, nt, m)
            for j in range(m):
                vb[TWO * CHUNK + j] = math.sqrt(V[VLJ * BLK + j] * V[VLU * BLK + j])
    if dyn:
        if rods:
            _pose_rows(Lg, GK, ct, FRb, m, Kp, nt)
        _rigid(ptype, F, d, FRb, m, Lg, B, nt, rot)
        _dyn_w(B, Lg, J, Kp, FRb, U, Wm, nt, cspec, m)
        _lmax_dyn(Wm, V[VLW * BLK:(VLW + 1) * BLK], T, V, nt, m)
        for j in range(m):
            vb[DYN * CHUNK + j] = math.sqrt(V[VLW * BLK + j])
    for v in range(NVAL):
        if want[v]:
            for j in range(m):
                x = vb[v * CHUNK + j]
                cb[j] = 2.0 if (cb[j] == 1.0) & (not (x < np.inf and x > -np.inf)) else cb[j]


@njit(**_NJIT_RED)
def _chunk_stats(vals, cb, n_pts, want, out):
    """For each wanted value its sum, min, max and centred sum of squares over
    the points of code 1 (cb[j] == 1) into out (NVAL, 4); returns their count.
    Compiled with reassociation so that the sums vectorize: the order is still
    the compiled code's, the same for every thread count."""
    k = 0
    for j in range(n_pts):
        k += 1 if cb[j] == 1.0 else 0
    if k == 0:
        return 0
    for v in range(NVAL):
        if not want[v]:
            continue
        x = vals[v * CHUNK:v * CHUNK + n_pts]
        s = 0.0
        mn = np.inf
        mx = -np.inf
        for j in range(n_pts):
            r = cb[j] == 1.0
            xj = x[j]
            s += xj if r else 0.0
            lo = xj if r else np.inf
            hi = xj if r else -np.inf
            mn = lo if lo < mn else mn
            mx = hi if hi > mx else mx
        mu = s / k
        m2 = 0.0
        for j in range(n_pts):
            e = x[j] - mu
            m2 += e * e if cb[j] == 1.0 else 0.0
        out[v, 0] = s
        out[v, 1] = mn
        out[v, 2] = mx
        out[v, 3] = m2
    return k


@njit(**_NJIT)
def _load_block(FRd, lo, m, FRb):
    """The frame data of points lo..lo+m-1 (rows of FRd (N, rows)) into the rows of the block FRb."""
    rows = FRd.shape[1]
    src = FRd[lo:lo + m]
    for k in range(rows):
        for j in range(m):
            FRb[_u(k * BLK + j)] = src[j, k]


@njit(**_NJIT)
def _task(nt, cspec, ptype, ct, kind, branch, L, F, d, FRd, lo, n_pts, want, flags, scratch, FRb, vals, cb, out):
    """Codes of the n_pts points from lo into cb (as floats) and the chunk's
    (sum, min, max, centred sum of squares) per wanted value into out (NVAL, 4);
    returns the count of code-1 points."""
    for b in range(0, n_pts, BLK):
        m = min(BLK, n_pts - b)
        _load_block(FRd, lo + b, m, FRb)
        _block(nt, cspec, ptype, ct, kind, branch, L, F, d, FRb, m, want, flags, scratch, vals[b:], cb[b:])
    return _chunk_stats(vals, cb, n_pts, want, out)


@njit(parallel=True, **_NJIT)
def summary(nt, cspec, ptype, ct, kind, branch, L, F, FR, N, want, flags, workers, keep):
    """Per-design statistics (D, NVAL, 4: sum, min, max, centred sum of squares)
    over the points of code 1, their counts (D,), the codes (D, N) (int8).

    nt: a tuple of n zeros (its length, the size, is a compile-time constant);
    cspec: the KernelSpec as a type (KernelSpec.numba_args: compile-time
    too); ct (n,): the pose-column kinds; kind, branch (n,); L (D, n, NL), F (D, NF);
    FR (1 or D, N, FR_ROWS[ptype]): the frame data of the N points; want (NVAL,) booleans; flags: (dynamic, sigma_min,
    sigma_max, column norms, rods, rotations) booleans.  Work: tasks of CHUNK
    points of one design, shared among ``workers`` parallel loops (numba's
    thread count) in a fixed pattern; each task's results are its own.
    keep: (D, NVAL, N) to receive every point's wanted values too (the
    worst-case search's quantity: FR per design, each design at its own
    points), or an empty (0, 0, 0) array."""
    D = L.shape[0]
    nch = (N + CHUNK - 1) // CHUNK
    ntask = D * nch
    codes = np.empty((D, N), dtype=np.int8)
    part = np.empty((D, nch, NVAL, 4))
    cnt = np.empty((D, nch), dtype=np.int64)
    nw = max(1, min(workers, ntask))
    per_design = FR.shape[0] > 1
    for w in prange(nw):
        scratch = _alloc(nt)
        FRb = np.zeros(NFR * BLK)
        vals = np.zeros(NVAL * CHUNK)
        cbuf = np.empty(CHUNK)
        for t in range(w, ntask, nw):
            d = t // nch
            c = t % nch
            lo = c * CHUNK
            hi = min(lo + CHUNK, N)
            FRd = FR[d] if per_design else FR[0]
            cnt[d, c] = _task(nt, cspec, ptype, ct, kind, branch, L, F, d, FRd, lo, hi - lo, want, flags, scratch, FRb,
                              vals, cbuf, part[d, c])
            cd = codes[d, lo:hi]
            for j in range(hi - lo):
                cd[j] = np.int8(cbuf[j])
            if keep.shape[0] > 0:
                for v in range(NVAL):
                    if want[v]:
                        kv = keep[d, v, lo:hi]
                        for j in range(hi - lo):
                            kv[j] = vals[v * CHUNK + j]
    stats = np.full((D, NVAL, 4), np.nan)
    counts = np.zeros(D, dtype=np.int64)
    for d in range(D):
        k = 0
        for c in range(nch):
            k += cnt[d, c]
        counts[d] = k
        if k == 0:
            continue
        for v in range(NVAL):
            if not want[v]:
                continue
            s, mn, mx, m2 = chunk_moments(part, cnt, d, v, k, nch)
            stats[d, v, 0] = s
            stats[d, v, 1] = mn
            stats[d, v, 2] = mx
            stats[d, v, 3] = m2
    return stats, counts, codes


@njit(**_NJIT)
def mass_blocks(nt, cspec, ptype, ct, kind, branch, L, F, FRg, bd):
    """The pose-space mass matrices M_p (blocks, n n BLK; row-major entries,
    rows of BLK) at the points of FRg (blocks BLK, rows), block b (its BLK
    points) of design bd[b]: for the points the kernel leaves to the numpy
    path, whose J that path computes itself (bitwise its own) while M_p enters
    the dynamic index through J^-T M_p, insensitive to its round-off.  Serial:
    the points are few, and a parallel region started right after numpy's
    LAPACK calls waits for the BLAS threads still spinning."""
    n = len(nt)
    nb = FRg.shape[0] // BLK
    out = np.zeros((nb, n * n * BLK))
    rods = False
    for i in range(n):
        rods = rods or kind[i] != 2
    Lg, mats, B, T, V = _alloc(nt)
    J = mats[0]
    Kp = mats[2]
    FRb = np.zeros(NFR * BLK)
    for b in range(nb):
        d = bd[b]
        _load_block(FRg, b * BLK, BLK, FRb)
        for j in range(BLK):
            V[VOK * BLK + j] = 1.0
        for i in range(n):
            Li = Lg[i]
            k = kind[i]
            if k == 0:
                _leg_prismatic(L, F, d, i, ptype, FRb, branch[i], BLK, Li, V, True, cspec)
            elif k == 1:
                _leg_revolute(L, F, d, i, ptype, FRb, branch[i], BLK, Li, V, True, cspec)
            else:
                _leg_strut(L, F, d, i, ptype, FRb, BLK, Li, True, cspec)
        _pose_rows(Lg, GG, ct, FRb, BLK, J, nt)
        if rods:
            _pose_rows(Lg, GK, ct, FRb, BLK, Kp, nt)
        _rigid(ptype, F, d, FRb, BLK, Lg, B, nt, ptype != 0)
        _mass_p(B, Lg, J, Kp, FRb, mats[1], out[b], nt, cspec, BLK)
    return out


@njit(**_NJIT)
def gram_lambda_max_stack(X, nt, rows):
    """lambda_max of X^T X (rows False) or of X X^T (rows True; X upper
    triangular for n >= 4, as _inverse leaves it) for each X of the stack
    (K, n, n), by the kernel's own routines (for tests); nt: a tuple of n zeros."""
    n = len(nt)
    K = X.shape[0]
    out = np.empty(K)
    G = np.empty(n * n * BLK)
    T = np.empty(2 * n * BLK)
    V = np.empty((NVS + 3 * n) * BLK)
    lam = np.empty(BLK)
    for b in range(0, K, BLK):
        m = min(BLK, K - b)
        for j in range(m):
            for r in range(n):
                for c in range(n):
                    G[(r * n + c) * BLK + j] = X[b + j, r, c]
            V[VMASK * BLK + j] = 1.0
        if rows:
            _lmax_rows(G, lam, T, V, nt, m)
        else:
            _lmax_cols(G, lam, T, V, nt, m)
        for j in range(m):
            out[b + j] = lam[j]
    return out


@njit(**_NJIT)
def inverse_stack(A, nt):
    """(|det|, ||A^-1||_F^2, U) of each square matrix of the stack A (K, n, n)
    by the kernel's _inverse (U = A^-1 for n <= 3, R^-1 of A = QR for n >= 4;
    for tests)."""
    n = len(nt)
    K = A.shape[0]
    det = np.empty(K)
    i2 = np.empty(K)
    Ui = np.empty((K, n, n))
    Rq = np.empty(n * n * BLK)
    U = np.zeros(n * n * BLK)
    V = np.empty((NVS + 3 * n) * BLK)
    for b in range(0, K, BLK):
        m = min(BLK, K - b)
        for j in range(m):
            for r in range(n):
                for c in range(n):
                    Rq[(r * n + c) * BLK + j] = A[b + j, r, c]
        _inverse(Rq, U, V, nt, m)
        for j in range(m):
            det[b + j] = V[VDET * BLK + j]
            i2[b + j] = V[VI2 * BLK + j]
            for r in range(n):
                for c in range(n):
                    Ui[b + j, r, c] = U[(r * n + c) * BLK + j]
    return det, i2, Ui
