"""Rigorous upper bounds of condition numbers of interval matrices (batched).

A matrix is a list of rows of :class:`~.interval.Interval` entries, each of
shape (K,) (K boxes).  For the Frobenius condition number

    cond_F(J) = ||J||_F ||J^-1||_F <= ||J||_F^up * ||C||_F / (1 - ||I - C J||_F)

for every J in the interval matrix, with C = inv(mid J) (any float matrix:
if ||I - C J|| < 1 in a submultiplicative norm, every J is regular and
J^-1 = (I - E)^-1 C, E = I - C J, so ||J^-1||_F <= ||(I - E)^-1||_2 ||C||_F).
Where the bound cannot be made (E not contracting, C not finite) it is inf.
"""
from __future__ import annotations

import numpy as np

from .interval import Interval, norm_upper

__all__ = ["cond_fro_upper", "cond_2_upper", "mid_matrix"]


def mid_matrix(J) -> np.ndarray:
    """(K, n, n) float midpoints of an interval matrix."""
    return np.stack([np.stack([e.mid for e in row], -1) for row in J], -2)


def _down(a):
    return np.nextafter(a, -np.inf)


def _up(a):
    return np.nextafter(a, np.inf)


def _preconditioner(J):
    """C = inv(mid J) (K, n, n) and where it exists (K,) (elsewhere C = 0)."""
    n = len(J)
    Jm = mid_matrix(J)
    good = np.all(np.isfinite(Jm), axis=(-1, -2))
    Jm = np.where(good[:, None, None], Jm, np.eye(n))
    with np.errstate(all="ignore"):
        det = np.linalg.det(Jm)
        good &= np.isfinite(det) & (det != 0.0)
        C = np.linalg.inv(np.where(good[:, None, None], Jm, np.eye(n)))
    good &= np.all(np.isfinite(C), axis=(-1, -2))
    return np.where(good[:, None, None], C, 0.0), good


def inverse_fro_upper(J) -> np.ndarray:
    """(K,) upper bounds of max ||J^-1||_F over each interval matrix (inf where not proved regular)."""
    n = len(J)
    C, good = _preconditioner(J)
    mags = []
    for i in range(n):
        for j in range(n):
            acc = None
            for k in range(n):
                t = J[k][j] * C[:, i, k]
                acc = t if acc is None else acc + t
            e = (1.0 if i == j else 0.0) - acc
            mags.append(e.mag)
    with np.errstate(all="ignore"):
        e = norm_upper(mags)
        cf = norm_upper([C[:, i, j] for i in range(n) for j in range(n)])
        den = _down(1.0 - e)
        out = _up(cf / den)
    ok = good & (e < 1.0) & np.isfinite(out) & (den > 0)
    return np.where(ok, out, np.inf)


def cond_fro_upper(J) -> np.ndarray:
    """(K,) upper bounds of max cond_F over each interval matrix."""
    nj = norm_upper([e.mag for row in J for e in row])
    with np.errstate(all="ignore"):
        out = _up(nj * inverse_fro_upper(J))
    return np.where(np.isfinite(out), out, np.inf)


def _sigma_max_upper(A) -> np.ndarray:
    """(K,) upper bounds of the largest singular value over an interval matrix
    A (rows of Interval (K,)): the smaller of the square roots of Gershgorin's
    bounds of lambda_max(A^T A) and lambda_max(A A^T), the products in
    interval arithmetic (tight where A's columns or rows are near orthogonal,
    unlike sqrt(n) ||A||-type bounds)."""
    At = [[A[i][j] for i in range(len(A))] for j in range(len(A[0]))]
    return np.minimum(_gram_bound(A), _gram_bound(At))


def _gram_bound(A) -> np.ndarray:
    n_r, n_c = len(A), len(A[0])
    B = [[None] * n_c for _ in range(n_c)]
    for i in range(n_c):
        for j in range(i, n_c):
            acc = None
            for k in range(n_r):
                t = A[k][i].sqr() if i == j else A[k][i] * A[k][j]
                acc = t if acc is None else acc + t
            B[i][j] = B[j][i] = acc
    best = None
    for i in range(n_c):
        s = B[i][i].hi
        for j in range(n_c):
            if j != i:
                s = _up(s + B[i][j].mag)
        best = s if best is None else np.maximum(best, s)
    with np.errstate(invalid="ignore"):
        return _up(np.sqrt(np.maximum(best, 0.0)))


def cond_2_upper(J) -> np.ndarray:
    """(K,) upper bounds of max cond_2 over each interval matrix:
    sigma_max(J) sigma_max(C) / (1 - sigma_max(I - C J)), C = inv(mid J), each
    sigma_max bounded by :func:`_sigma_max_upper`; never above the Frobenius
    bound (cond_2 <= cond_F)."""
    n = len(J)
    C, good = _preconditioner(J)
    E = []
    for i in range(n):
        row = []
        for j in range(n):
            acc = None
            for k in range(n):
                t = J[k][j] * C[:, i, k]
                acc = t if acc is None else acc + t
            row.append((1.0 if i == j else 0.0) - acc)
        E.append(row)
    Ci = [[Interval(C[:, i, j]) for j in range(n)] for i in range(n)]
    with np.errstate(all="ignore"):
        e = np.minimum(_sigma_max_upper(E), norm_upper([x.mag for row in E for x in row]))
        den = _down(1.0 - e)
        out = _up(_up(_sigma_max_upper(J) * _sigma_max_upper(Ci)) / den)
    ok = good & (e < 1.0) & np.isfinite(out) & (den > 0)
    out = np.where(ok, out, np.inf)
    return np.minimum(out, cond_fro_upper(J))
