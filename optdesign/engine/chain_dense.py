"""Small dense algebra of the chain kernel (:mod:`.chain_kernels`), scalar
code per point on small matrices (numba ``register_jitable``: compiled into
the kernels that call them): LU with partial pivoting, the least-squares
solves with the numpy path's singularity tests
(:func:`optdesign.mechanisms.described.chain_poe.lsq`), the sign of a
determinant as numpy computes it, Rodrigues' formula."""
from __future__ import annotations

import math

import numpy as np

from .chain_layout import HADAMARD, RCOND
from .digest import leaf

_LOG_HADAMARD = math.log(HADAMARD)
#: exp(x) is 0 below this (numpy's det is sign * exp(log |det|))
_LOG_TINY = -745.2


# ---------------------------------------------------------------------- small dense algebra
@leaf
def _finite(x):
    return x - x == 0.0


@leaf
def _lu(A, nr, piv):
    """LU with partial pivoting of A[:nr, :nr] in place (rows swapped, the
    multipliers below the diagonal); piv[k] the row swapped with k; returns
    the sign of the permutation."""
    sgn = 1.0
    for k in range(nr):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, nr):
            a = abs(A[i, k])
            if a > big:
                big = a
                p = i
        piv[k] = p
        if p != k:
            for c in range(nr):
                x = A[k, c]
                A[k, c] = A[p, c]
                A[p, c] = x
            sgn = -sgn
        akk = A[k, k]
        if akk == 0.0:
            continue
        for i in range(k + 1, nr):
            f = A[i, k] / akk
            A[i, k] = f
            if f != 0.0:
                for c in range(k + 1, nr):
                    A[i, c] -= f * A[k, c]
    return sgn


@leaf
def _lsq(A, B, m, nu, r, X, W, Wb, piv):
    """X[:nu, :r] = the least-squares solution of A[:m, :nu] X = B[:m, :r]
    (m >= nu, full column rank) as chain_poe.lsq: False where A or B is not
    finite or A is numerically singular (square: |det A| <= HADAMARD prod
    |row_i|; tall: min |R_ii| <= RCOND max |R_jj| of its Householder QR), and
    always when m < nu.  W (m, nu), Wb (m, r): scratch."""
    if m < nu:
        return False
    for i in range(m):
        for c in range(nu):
            if not _finite(A[i, c]):
                return False
        for c in range(r):
            if not _finite(B[i, c]):
                return False
    for i in range(m):
        for c in range(nu):
            W[i, c] = A[i, c]
        for c in range(r):
            Wb[i, c] = B[i, c]
    if m == nu:
        lognorm = 0.0
        for i in range(m):
            s = 0.0
            for c in range(nu):
                s += A[i, c] * A[i, c]
            lognorm += np.log(math.sqrt(s))
        _lu(W, nu, piv)
        logdet = 0.0
        for k in range(nu):
            a = abs(W[k, k])
            if a == 0.0:
                return False
            logdet += math.log(a)
        if not (logdet - lognorm > _LOG_HADAMARD):
            return False
        for k in range(nu):
            p = piv[k]
            if p != k:
                for c in range(r):
                    x = Wb[k, c]
                    Wb[k, c] = Wb[p, c]
                    Wb[p, c] = x
        for c in range(r):
            for i in range(nu):
                s = Wb[i, c]
                for k in range(i):
                    s -= W[i, k] * Wb[k, c]
                Wb[i, c] = s
            for i in range(nu - 1, -1, -1):
                s = Wb[i, c]
                for k in range(i + 1, nu):
                    s -= W[i, k] * X[k, c]
                X[i, c] = s / W[i, i]
        return True
    # tall: Householder QR of W, applied to Wb as it goes
    dmin = np.inf
    dmax = 0.0
    for k in range(nu):
        s = 0.0
        for i in range(k, m):
            s += W[i, k] * W[i, k]
        nrm = math.sqrt(s)
        x0 = W[k, k]
        al = -nrm if x0 >= 0.0 else nrm
        v0 = x0 - al
        den = nrm * nrm - al * x0           # v.v / 2
        if den > 0.0:
            for c in range(k + 1, nu):
                t = v0 * W[k, c]
                for i in range(k + 1, m):
                    t += W[i, k] * W[i, c]
                t /= den
                W[k, c] -= t * v0
                for i in range(k + 1, m):
                    W[i, c] -= t * W[i, k]
            for c in range(r):
                t = v0 * Wb[k, c]
                for i in range(k + 1, m):
                    t += W[i, k] * Wb[i, c]
                t /= den
                Wb[k, c] -= t * v0
                for i in range(k + 1, m):
                    Wb[i, c] -= t * W[i, k]
        W[k, k] = al
        a = abs(al)
        dmin = a if a < dmin else dmin
        dmax = a if a > dmax else dmax
    if not (dmin > RCOND * dmax):
        return False
    for c in range(r):
        for i in range(nu - 1, -1, -1):
            s = Wb[i, c]
            for k in range(i + 1, nu):
                s -= W[i, k] * X[k, c]
            X[i, c] = s / W[i, i]
    return True


@leaf
def _det_positive(G, nr, piv):
    """det G[:nr, :nr] > 0 as numpy computes it (sign exp(log |det|), 0 where that underflows)."""
    sgn = _lu(G, nr, piv)
    logdet = 0.0
    for k in range(nr):
        a = G[k, k]
        if a == 0.0:
            return False
        if a < 0.0:
            sgn = -sgn
        logdet += math.log(abs(a))
    return sgn > 0.0 and logdet > _LOG_TINY


@leaf
def _rodrigues(a0, a1, a2, t, D):
    """D = Rot(a, t) = cos t I + sin t skew(a) + (1 - cos t) a a^T."""
    s = math.sin(t)
    c = math.cos(t)
    k = 1.0 - c
    D[0, 0] = c + k * a0 * a0
    D[0, 1] = -s * a2 + k * a0 * a1
    D[0, 2] = s * a1 + k * a0 * a2
    D[1, 0] = s * a2 + k * a1 * a0
    D[1, 1] = c + k * a1 * a1
    D[1, 2] = -s * a0 + k * a1 * a2
    D[2, 0] = -s * a1 + k * a2 * a0
    D[2, 1] = s * a0 + k * a2 * a1
    D[2, 2] = c + k * a2 * a2
