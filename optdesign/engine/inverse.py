"""The engine's inverse of J with the size n known at run time only: the
adjugate with compensated minors for n <= 3, R^-1 of the Householder QR for
n >= 4 (with |det J| and ||J^-1||_F).

Every matrix is a block of BLK points in structure-of-arrays form: entry (r,
c) of point j at ``A[(r n + c) BLK + j]``, and every stage is a loop over the
block's points (the innermost loop, which LLVM vectorizes), so one compiled
routine serves every n.  Each routine does the operations of the fixed-size
code :mod:`.codegen` writes for a given n (the specialized tier), in the same
order, so both give the same bits (tests/test_engine.py checks it); a sum
starts from its first term, never from 0.0 (0.0 + -0.0 would change a sign).
"""
from __future__ import annotations

import math

from numba import uint64 as _u

from ..fast._jit import dot3_dd as _dot3_dd
from ..fast._jit import minor_dd as _minor_dd
from .digest import keyed, leaf
from .layout import BLK, VDET, VI2

__all__ = ["inverse"]

@leaf
def _inverse_small(A, U, V, n, m):
    """U = A^-1 for n <= 3 by the adjugate, its minors and the determinant in
    about twice the working precision (so U's entries are exact to a few ulps
    whatever cond(A): the cancellation of near-singular points stays out);
    V rows VDET <- |det A|, VI2 <- ||U||_F^2."""
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


@leaf
def _qr_inverse(A, U, V, S, n, m):
    """U = R^-1 (upper triangle) for R of the Householder QR of A, |det A| =
    prod |R_kk| and ||U||_F^2 into V's rows VDET, VI2 (n >= 4).  S rows: 0 the
    running sum, 1 beta, 2 v0, 3 the determinant, from 4 R (A is not changed)."""
    A0 = A
    A = S[4 * BLK:(4 + n * n) * BLK]
    for i in range(n * n * BLK):
        A[_u(i)] = A0[_u(i)]
    for j in range(m):
        S[_u(3 * BLK + j)] = 1.0
    for k in range(n):
        okk = (k * n + k) * BLK
        if k + 1 < n:
            o = ((k + 1) * n + k) * BLK
            for j in range(m):
                x = A[_u(o + j)]
                S[_u(j)] = x * x
            for i in range(k + 2, n):
                o = (i * n + k) * BLK
                for j in range(m):
                    x = A[_u(o + j)]
                    S[_u(j)] += x * x
        else:
            for j in range(m):
                S[_u(j)] = 0.0
        for j in range(m):
            x0 = A[_u(okk + j)]
            nr = x0 * x0 + S[_u(j)]
            r = math.sqrt(nr)
            al = -r if x0 >= 0.0 else r
            den = nr - al * x0
            S[_u(BLK + j)] = 1.0 / den if den > 0.0 else 0.0
            S[_u(2 * BLK + j)] = x0 - al
            A[_u(okk + j)] = al
            S[_u(3 * BLK + j)] *= r
        for c in range(k + 1, n):
            okc = (k * n + c) * BLK
            for j in range(m):
                S[_u(j)] = S[_u(2 * BLK + j)] * A[_u(okc + j)]
            for i in range(k + 1, n):
                oi = (i * n + k) * BLK
                oc = (i * n + c) * BLK
                for j in range(m):
                    S[_u(j)] += A[_u(oi + j)] * A[_u(oc + j)]
            for j in range(m):
                s = S[_u(j)] * S[_u(BLK + j)]
                S[_u(j)] = s
                A[_u(okc + j)] -= s * S[_u(2 * BLK + j)]
            for i in range(k + 1, n):
                oi = (i * n + k) * BLK
                oc = (i * n + c) * BLK
                for j in range(m):
                    A[_u(oc + j)] -= S[_u(j)] * A[_u(oi + j)]
    # U = R^-1, column by column from the diagonal up
    for k in range(n):
        o = (k * n + k) * BLK
        for j in range(m):
            U[_u(o + j)] = 1.0 / A[_u(o + j)]
    for c in range(n):
        for r in range(c - 1, -1, -1):
            oa = (r * n + r + 1) * BLK
            ou = ((r + 1) * n + c) * BLK
            for j in range(m):
                S[_u(j)] = A[_u(oa + j)] * U[_u(ou + j)]
            for k in range(r + 2, c + 1):
                oa = (r * n + k) * BLK
                ou = (k * n + c) * BLK
                for j in range(m):
                    S[_u(j)] += A[_u(oa + j)] * U[_u(ou + j)]
            o = (r * n + c) * BLK
            orr = (r * n + r) * BLK
            for j in range(m):
                U[_u(o + j)] = -S[_u(j)] * U[_u(orr + j)]
    for j in range(m):
        V[_u(VDET * BLK + j)] = S[_u(3 * BLK + j)]
        x = U[_u(j)]
        S[_u(j)] = x * x
    for r in range(n):
        for c in range(r, n):
            if r + c > 0:
                o = (r * n + c) * BLK
                for j in range(m):
                    x = U[_u(o + j)]
                    S[_u(j)] += x * x
    for j in range(m):
        V[_u(VI2 * BLK + j)] = S[_u(j)]


@keyed
def inverse(A, U, V, S, n, m, sel):
    """U = A^-1 (n <= 3) or R^-1 of A = QR (n >= 4: upper triangular, with the
    singular values of A^-1; Q is never formed); V rows VDET <- |det A|,
    VI2 <- ||A^-1||_F^2.  sel: the kernel's selector, not read; this function
    is the overload of ``kernels.inverse_sel`` for the generic tier."""
    if n <= 3:
        _inverse_small(A, U, V, n, m)
    else:
        _qr_inverse(A, U, V, S, n, m)
