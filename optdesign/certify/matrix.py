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

__all__ = ["cond_fro_upper", "mid_matrix"]


def mid_matrix(J) -> np.ndarray:
    """(K, n, n) float midpoints of an interval matrix."""
    return np.stack([np.stack([e.mid for e in row], -1) for row in J], -2)


def _down(a):
    return np.nextafter(a, -np.inf)


def _up(a):
    return np.nextafter(a, np.inf)


def inverse_fro_upper(J) -> np.ndarray:
    """(K,) upper bounds of max ||J^-1||_F over each interval matrix (inf where not proved regular)."""
    n = len(J)
    Jm = mid_matrix(J)
    good = np.all(np.isfinite(Jm), axis=(-1, -2))
    Jm = np.where(good[:, None, None], Jm, np.eye(n))
    with np.errstate(all="ignore"):
        det = np.linalg.det(Jm)
        good &= np.isfinite(det) & (det != 0.0)
        C = np.linalg.inv(np.where(good[:, None, None], Jm, np.eye(n)))
    good &= np.all(np.isfinite(C), axis=(-1, -2))
    C = np.where(good[:, None, None], C, 0.0)
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
