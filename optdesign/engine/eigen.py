"""lambda_max of the Gram matrices the engine needs, with the size n known at
run time only: closed forms for n <= 3; for n >= 4 a Householder
tridiagonalization, Newton steps on the characteristic polynomial that are
exact for a pair of close eigenvalues, a Sturm check that the value is within
TAU (relative) of lambda_max, and bisection for a point where it is not.

Blocks of BLK points in structure-of-arrays form, as :mod:`.inverse` (the
same operations, in the same order, as the fixed-size code of
:mod:`.codegen`: tests/test_engine.py).  ``S``: scratch rows (layout.SROWS).
"""
from __future__ import annotations

import math

from numba import uint64 as _u

from ..fast._jit import lambda_max_psd as _lmax3_point
from .digest import keyed, leaf
from .layout import BLK, NMAX, TAU, VBETA, VMASK, VV0

__all__ = ["COLS", "ROWS", "lmax", "bisect_flagged"]

#: single rows of the scratch after the Gram matrix and the vectors (offsets in rows)
_S_, _BETA, _H, _SC, _SI, _X = range(6)

@leaf
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


@leaf
def bisect_flagged(T, out, V, n, m):
    """out[j] for the points flagged in V's row VV0 (lambda_max not certified by
    the Newton steps): bisection of the scaled tridiagonal T to the last bit,
    then the scale (V's row VBETA)."""
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


#: Gram modes: X^T X, X X^T, X X^T for an upper triangular X (read: its upper triangle)
COLS, ROWS, UROWS = 0, 1, 2


@leaf
def _gram(X, G, n, m, mode):
    """G's upper triangle (rows (a n + b) BLK, a <= b) = the Gram matrix of X."""
    for a in range(n):
        for b in range(a, n):
            o = (a * n + b) * BLK
            k0 = b if mode == UROWS else 0
            for k in range(k0, n):
                if mode == COLS:
                    oa = (k * n + a) * BLK
                    ob = (k * n + b) * BLK
                else:
                    oa = (a * n + k) * BLK
                    ob = (b * n + k) * BLK
                if k == k0:
                    for j in range(m):
                        G[_u(o + j)] = X[_u(oa + j)] * X[_u(ob + j)]
                else:
                    for j in range(m):
                        G[_u(o + j)] += X[_u(oa + j)] * X[_u(ob + j)]


@leaf
def _g(a, b, n):
    """The row offset of entry (a, b) of the symmetric G (its upper triangle is stored)."""
    return (min(a, b) * n + max(a, b)) * BLK


@leaf
def _lmax_big(X, out, T, V, S, n, m, mode, iters):
    """lambda_max of the Gram matrix of X (n >= 4): Householder
    tridiagonalization, the scaled tridiagonal into T (diagonal rows 0..n-1,
    squared off-diagonal rows n..2n-2), iters quadratic-model Newton steps from
    an upper bound (min of Gershgorin, Frobenius and Wolkowicz-Styan), the
    Sturm check; points not certified (and not masked out by VMASK) are flagged
    in V's row VV0 and bisected."""
    G = S
    vv = n * n * BLK            # vectors: v, p, w, e, f/d/h (six rows of n each from here)
    one = vv + 6 * NMAX * BLK   # single rows
    _gram(X, G, n, m, mode)
    for k in range(n - 2):
        # s = sum of g(i, k)^2 over i >= k + 2
        o = _g(k + 2, k, n)
        for j in range(m):
            x = G[_u(o + j)]
            S[_u(one + _S_ * BLK + j)] = x * x
        for i in range(k + 3, n):
            o = _g(i, k, n)
            for j in range(m):
                x = G[_u(o + j)]
                S[_u(one + _S_ * BLK + j)] += x * x
        o1 = _g(k + 1, k, n)
        for j in range(m):
            x1 = G[_u(o1 + j)]
            nr = x1 * x1 + S[_u(one + _S_ * BLK + j)]
            r = math.sqrt(nr)
            al = -r if x1 >= 0.0 else r
            den = nr - al * x1
            S[_u(one + _BETA * BLK + j)] = 1.0 / den if den > 0.0 else 0.0
            S[_u(vv + (3 * NMAX + k) * BLK + j)] = al                       # e_k
            S[_u(vv + (k + 1) * BLK + j)] = x1 - al                          # v_{k+1}
        for i in range(k + 2, n):
            o = _g(i, k, n)
            for j in range(m):
                S[_u(vv + i * BLK + j)] = G[_u(o + j)]
        # p_r = beta (sum_c g(r, c) v_c)
        for r in range(k + 1, n):
            op = vv + (NMAX + r) * BLK
            o = _g(r, k + 1, n)
            for j in range(m):
                S[_u(op + j)] = G[_u(o + j)] * S[_u(vv + (k + 1) * BLK + j)]
            for c in range(k + 2, n):
                o = _g(r, c, n)
                for j in range(m):
                    S[_u(op + j)] += G[_u(o + j)] * S[_u(vv + c * BLK + j)]
            for j in range(m):
                S[_u(op + j)] = S[_u(one + _BETA * BLK + j)] * S[_u(op + j)]
        # h = 0.5 beta (v . p)
        for j in range(m):
            S[_u(one + _H * BLK + j)] = S[_u(vv + (k + 1) * BLK + j)] * S[_u(vv + (NMAX + k + 1) * BLK + j)]
        for r in range(k + 2, n):
            for j in range(m):
                S[_u(one + _H * BLK + j)] += S[_u(vv + r * BLK + j)] * S[_u(vv + (NMAX + r) * BLK + j)]
        for j in range(m):
            S[_u(one + _H * BLK + j)] = 0.5 * S[_u(one + _BETA * BLK + j)] * S[_u(one + _H * BLK + j)]
        # w_r = p_r - h v_r
        for r in range(k + 1, n):
            for j in range(m):
                S[_u(vv + (2 * NMAX + r) * BLK + j)] = (S[_u(vv + (NMAX + r) * BLK + j)]
                                                        - S[_u(one + _H * BLK + j)] * S[_u(vv + r * BLK + j)])
        for r in range(k + 1, n):
            for c in range(k + 1, r + 1):
                o = _g(r, c, n)
                for j in range(m):
                    G[_u(o + j)] = G[_u(o + j)] - (S[_u(vv + r * BLK + j)] * S[_u(vv + (2 * NMAX + c) * BLK + j)]
                                                   + S[_u(vv + (2 * NMAX + r) * BLK + j)] * S[_u(vv + c * BLK + j)])
    # the tridiagonal: t_k into T's rows 0..n-1, e_k (vector row 3 NMAX + k)
    for k in range(n):
        o = _g(k, k, n)
        for j in range(m):
            T[_u(k * BLK + j)] = G[_u(o + j)]
    o = _g(n - 1, n - 2, n)
    for j in range(m):
        S[_u(vv + (3 * NMAX + n - 2) * BLK + j)] = G[_u(o + j)]
    ie = vv + 3 * NMAX * BLK
    # upper bound: min(Gershgorin, Frobenius, Wolkowicz-Styan); scale to it
    inv_n = 1.0 / n
    for j in range(m):
        gb = T[_u(j)] + abs(S[_u(ie + j)])
        for k in range(1, n):
            t = T[_u(k * BLK + j)] + abs(S[_u(ie + (k - 1) * BLK + j)])
            if k < n - 1:
                t = t + abs(S[_u(ie + k * BLK + j)])
            gb = max(gb, t)
        t0 = T[_u(j)]
        fr = t0 * t0
        for k in range(1, n):
            t = T[_u(k * BLK + j)]
            fr = fr + t * t
        for k in range(n - 1):
            e = S[_u(ie + k * BLK + j)]
            fr = fr + 2.0 * (e * e)
        su = t0
        for k in range(1, n):
            su = su + T[_u(k * BLK + j)]
        mu = su * inv_n
        sd2 = fr * inv_n - mu * mu
        ws = mu + math.sqrt((sd2 if sd2 > 0.0 else 0.0) * float(n - 1))
        x0 = min(min(gb, math.sqrt(fr)), ws)
        S[_u(one + _SC * BLK + j)] = x0 if x0 > 0.0 else 0.0
        S[_u(one + _SI * BLK + j)] = 1.0 / x0 if x0 > 0.0 else 0.0
    for k in range(n):
        for j in range(m):
            T[_u(k * BLK + j)] = T[_u(k * BLK + j)] * S[_u(one + _SI * BLK + j)]
    for k in range(n - 1):
        for j in range(m):
            es = S[_u(ie + k * BLK + j)] * S[_u(one + _SI * BLK + j)]
            T[_u((n + k) * BLK + j)] = es * es
    # Newton steps on the characteristic polynomial f (derivatives d, h: three-term recurrences)
    f0, f1, d0, d1, h0, h1 = (vv + 4 * NMAX * BLK, vv + (4 * NMAX + 1) * BLK, vv + (4 * NMAX + 2) * BLK,
                              vv + (4 * NMAX + 3) * BLK, vv + (4 * NMAX + 4) * BLK, vv + (4 * NMAX + 5) * BLK)
    ox = one + _X * BLK
    for j in range(m):
        S[_u(ox + j)] = 1.0
    for _ in range(iters):
        for j in range(m):
            S[_u(f0 + j)] = 1.0
            S[_u(f1 + j)] = S[_u(ox + j)] - T[_u(j)]
            S[_u(d0 + j)] = 0.0
            S[_u(d1 + j)] = 1.0
            S[_u(h0 + j)] = 0.0
            S[_u(h1 + j)] = 0.0
        for k in range(1, n):
            for j in range(m):
                z = S[_u(ox + j)] - T[_u(k * BLK + j)]
                c = T[_u((n + k - 1) * BLK + j)]
                a0 = S[_u(f0 + j)]
                a1 = S[_u(f1 + j)]
                b0 = S[_u(d0 + j)]
                b1 = S[_u(d1 + j)]
                g0 = S[_u(h0 + j)]
                g1 = S[_u(h1 + j)]
                S[_u(f0 + j)] = a1
                S[_u(f1 + j)] = z * a1 - c * a0
                S[_u(d0 + j)] = b1
                S[_u(d1 + j)] = a1 + z * b1 - c * b0
                S[_u(h0 + j)] = g1
                S[_u(h1 + j)] = 2.0 * b1 + z * g1 - c * g0
        # larger root of f + f' h + f'' h^2 / 2: h = -2 f / (f' + sqrt(f'^2 - 2 f f''))
        for j in range(m):
            a1 = S[_u(f1 + j)]
            b1 = S[_u(d1 + j)]
            disc = b1 * b1 - 2.0 * a1 * S[_u(h1 + j)]
            den = b1 + math.sqrt(disc if disc > 0.0 else 0.0)
            x = S[_u(ox + j)]
            S[_u(ox + j)] = x + (-2.0 * a1 / den if den != 0.0 else 0.0)
    # Sturm counts at x (1 +- TAU): x certified within TAU of lambda_max
    for j in range(m):
        x = S[_u(ox + j)]
        nhi = 0
        nlo = 0
        for side in range(2):
            y = x * (1.0 + TAU) if side == 0 else x * (1.0 - TAU)
            q0 = 1.0
            q1 = T[_u(j)] - y
            cnt = 1 if q1 < 0.0 else 0
            for k in range(1, n):
                q2 = (T[_u(k * BLK + j)] - y) * q1 - T[_u((n + k - 1) * BLK + j)] * q0
                cnt += 1 if (q2 < 0.0) != (q1 < 0.0) else 0
                q0 = q1
                q1 = q2
            if side == 0:
                nhi = cnt
            else:
                nlo = cnt
        good = (nhi == n) & (nlo < n)
        sc = S[_u(one + _SC * BLK + j)]
        out[j] = x * sc
        V[_u(VBETA * BLK + j)] = sc
        V[_u(VV0 * BLK + j)] = 0.0 if good or V[_u(VMASK * BLK + j)] == 0.0 or not sc > 0.0 else 1.0
    bisect_flagged(T, out, V, n, m)


@keyed
def lmax(X, out, T, V, S, n, m, mode, iters, sel):
    """out[j] = lambda_max of the Gram matrix of X's n x n matrix at point j
    (mode COLS: X^T X; ROWS: X X^T for X from :func:`inverse`, upper
    triangular for n >= 4, whose lower triangle is not read):
    closed forms for n <= 3, :func:`_lmax_big` beyond (iters Newton steps).
    sel: the kernel's selector, not read; this function is the overload of
    ``kernels.lmax_sel`` for the generic tier, compiled as it is."""
    if n >= 4:
        _lmax_big(X, out, T, V, S, n, m, UROWS if mode == ROWS else mode, iters)
        return
    _gram(X, S, n, m, COLS if mode == COLS else ROWS)
    if n == 1:
        for j in range(m):
            out[j] = S[_u(j)]
    elif n == 2:
        for j in range(m):
            g00 = S[_u(j)]
            g01 = S[_u(BLK + j)]
            g11 = S[_u(3 * BLK + j)]
            hh = 0.5 * (g00 - g11)
            out[j] = 0.5 * (g00 + g11) + math.sqrt(hh * hh + g01 * g01)
    else:
        for j in range(m):
            out[j] = _lmax3_point(S[_u(j)], S[_u(4 * BLK + j)], S[_u(8 * BLK + j)], S[_u(BLK + j)],
                                  S[_u(2 * BLK + j)], S[_u(5 * BLK + j)])
