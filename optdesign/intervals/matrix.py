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

from .interval import Interval, _down, _up, norm_upper

__all__ = ["cond_fro_upper", "cond_2_upper", "cond_fro_upper_adjugate", "cond_2_upper_adjugate",
           "sigma_max_upper", "lambda_max_upper", "det_adjugate", "mid_matrix"]


def mid_matrix(J) -> np.ndarray:
    """(K, n, n) float midpoints of an interval matrix."""
    return np.stack([np.stack([e.mid for e in row], -1) for row in J], -2)


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


def _gram_bound(A, B=None) -> np.ndarray:
    """Gershgorin's bound of sigma_max(A) from the interval Gram matrix B = A^T A."""
    B = _gram(A) if B is None else B
    n_c = len(B)
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
    sigma_max bounded by :func:`sigma_max_upper`; never above the Frobenius
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
        e = np.minimum(sigma_max_upper(E), norm_upper([x.mag for row in E for x in row]))
        den = _down(1.0 - e)
        out = _up(_up(sigma_max_upper(J) * sigma_max_upper(Ci)) / den)
    ok = good & (e < 1.0) & np.isfinite(out) & (den > 0)
    out = np.where(ok, out, np.inf)
    return np.minimum(out, cond_fro_upper(J))


# --------------------------------------------------------------------------- adjugate forms
#: the largest order whose adjugate is expanded (cofactors by Laplace
#: expansion with memoized minors: 3 x 3 needs 9 minors of order 2).  Beyond
#: 4 the preconditioned bounds above are used alone: measured with
#: benchmarks/bench_certify.py --compare on the Gough-Stewart platform's
#: reference design (6 x 6), the adjugate's bound leaves the 8799 boxes of
#: its proof unchanged and takes 4.06 times as long (7.44 s against 1.83 s)
ADJUGATE_MAX_ORDER = 4


def _minors(M):
    """det(M) and the cofactor matrix of a square matrix (list of rows of any
    arithmetic: floats, Interval or Dual), by Laplace expansion along the
    first row with memoized minors."""
    n = len(M)
    memo: dict = {}

    def det(rows: tuple, cols: tuple):
        if len(rows) == 1:
            return M[rows[0]][cols[0]]
        key = (rows, cols)
        if key in memo:
            return memo[key]
        acc = None
        for j, c in enumerate(cols):
            t = M[rows[0]][c] * det(rows[1:], cols[:j] + cols[j + 1:])
            acc = t if acc is None else (acc + t if j % 2 == 0 else acc - t)
        memo[key] = acc
        return acc

    allr = tuple(range(n))
    if n == 1:
        return M[0][0], [[1.0]]
    cof = [[None] * n for _ in range(n)]
    for i in range(n):
        for j in range(n):
            m = det(allr[:i] + allr[i + 1:], allr[:j] + allr[j + 1:])
            cof[i][j] = m if (i + j) % 2 == 0 else -m
    d = None
    for j in range(n):
        t = M[0][j] * cof[0][j]
        d = t if d is None else d + t
    return d, cof


def _meet(a: Interval, b: Interval) -> Interval:
    """The intersection of two enclosures of one quantity (a where it would be empty or NaN)."""
    lo, hi = np.maximum(a.lo, b.lo), np.minimum(a.hi, b.hi)
    bad = ~(lo <= hi)
    return Interval(np.where(bad, a.lo, lo), np.where(bad, a.hi, hi))


def det_adjugate(J, J_dual=None, J_mid=None, lo=None, hi=None):
    """Enclosures of det J and of adj J = cof(J)^T over each box: the natural
    extension over the interval matrix J, intersected, when the duals of J's
    entries over the boxes (``J_dual``) and J at the boxes' midpoints
    (``J_mid``, intervals) are given with the boxes ``lo, hi`` (K, dof), with
    the mean-value forms of det and of each cofactor (interval derivatives of
    the polynomial over the box, centred at the midpoint).  Returns (det, adj)
    (Interval (K,) and rows of them)."""
    from .dual import Dual, mean_value, value

    n = len(J)
    d_nat, c_nat = _minors(J)
    if J_dual is not None and J_mid is not None:
        d_box, c_box = _minors(J_dual)
        d_mid, c_mid = _minors(J_mid)

        def mv(box, mid, nat):
            if not isinstance(box, Dual):
                return _meet(nat, value(box))
            return _meet(nat, mean_value(box, mid, lo, hi))

        d_nat = mv(d_box, d_mid, d_nat)
        c_nat = [[mv(c_box[i][j], c_mid[i][j], Interval._of(c_nat[i][j])) for j in range(n)] for i in range(n)]
    c_nat = [[Interval._of(x) for x in row] for row in c_nat]
    adj = [[c_nat[j][i] for j in range(n)] for i in range(n)]
    return d_nat, adj


def _det_mig(d: Interval) -> np.ndarray:
    """min |det| over the enclosure (0 where it holds 0)."""
    return np.where(d.lo > 0, d.lo, np.where(d.hi < 0, -d.hi, 0.0))


def cond_fro_upper_adjugate(J, J_dual=None, J_mid=None, lo=None, hi=None) -> np.ndarray:
    """(K,) upper bounds of max cond_F over each box by the adjugate:
    cond_F(J) = ||J||_F ||adj J||_F / |det J| (J^-1 = adj J / det J), det and
    adj enclosed by :func:`det_adjugate`; inf where det's enclosure holds 0 or
    the order exceeds ``ADJUGATE_MAX_ORDER``."""
    n = len(J)
    K = np.shape(J[0][0].lo)
    if n > ADJUGATE_MAX_ORDER:
        return np.full(K, np.inf)
    d, adj = det_adjugate(J, J_dual, J_mid, lo, hi)
    nj = norm_upper([e.mag for row in J for e in row])
    na = norm_upper([e.mag for row in adj for e in row])
    mig = _det_mig(d)
    with np.errstate(all="ignore"):
        out = _up(_up(nj * na) / mig)
    return np.where((mig > 0) & np.isfinite(out), out, np.inf)


def cond_2_upper_adjugate(J, J_dual=None, J_mid=None, lo=None, hi=None) -> np.ndarray:
    """(K,) upper bounds of max cond_2 over each box by the adjugate:
    cond_2(J) = sigma_max(J) sigma_max(adj J) / |det J| (sigma_max(J^-1) =
    sigma_max(adj J) / |det J|), each sigma_max bounded by
    :func:`sigma_max_upper`."""
    n = len(J)
    K = np.shape(J[0][0].lo)
    if n > ADJUGATE_MAX_ORDER:
        return np.full(K, np.inf)
    d, adj = det_adjugate(J, J_dual, J_mid, lo, hi)
    mig = _det_mig(d)
    with np.errstate(all="ignore"):
        out = _up(_up(sigma_max_upper(J) * sigma_max_upper(adj)) / mig)
    return np.where((mig > 0) & np.isfinite(out), out, np.inf)


# --------------------------------------------------------------------------- Weyl
def _gram(A):
    """The interval Gram matrix A^T A (rows of Interval (K,))."""
    n_r, n_c = len(A), len(A[0])
    B = [[None] * n_c for _ in range(n_c)]
    for i in range(n_c):
        for j in range(i, n_c):
            acc = None
            for k in range(n_r):
                t = A[k][i].sqr() if i == j else A[k][i] * A[k][j]
                acc = t if acc is None else acc + t
            B[i][j] = B[j][i] = acc
    return B


#: unit roundoff of IEEE double, and twice the smallest subnormal (the
#: absolute error of a product that underflows is at most half of it)
_U = 2.0 ** -53
_ETA2 = 2.0 ** -1073


def _residual_upper(P: np.ndarray, B: np.ndarray, m: int) -> np.ndarray:
    """Entrywise upper bounds of |exact| for a float result P of sums of m
    products (computed in any order, with or without FMA), B the float sums
    of the products' magnitudes: |fl - exact| <= gamma_m sum |x y| with
    gamma_m = m u / (1 - m u) (Higham, Accuracy and Stability, 3.1), plus m
    half-subnormals for underflow.  The margin: 2 gamma_m B covers B's own
    rounding (B underestimates sum |x y| by at most a factor 1 + gamma_m) and
    the rounding of this bound's few operations."""
    gamma = m * _U / (1.0 - m * _U)
    return _up(_up(np.abs(P) + _up(2.0 * gamma * B)) + m * _ETA2)


def lambda_max_upper(S: np.ndarray) -> np.ndarray:
    """(K,) rigorous upper bounds of the largest eigenvalue of float symmetric
    matrices S (K, n, n).  eigh gives V, Lambda in floats; with the residual
    R = S V - V Lambda and F = V^T V - I (their float values with a priori
    bounds of their rounding, :func:`_residual_upper`), V^-1 S V = Lambda +
    V^-1 R, and Bauer-Fike on the diagonal Lambda puts every eigenvalue of S
    within ||V^-1 R||_2 <= ||R||_F / sqrt(1 - ||F||_F) of some float
    eigenvalue (sigma_min(V)^2 >= 1 - ||F||_2).  inf where ||F||_F >= 1 or S
    is not finite."""
    n = S.shape[-1]
    good = np.all(np.isfinite(S), axis=(-1, -2))
    Sg = np.where(good[:, None, None], S, 0.0)
    with np.errstate(all="ignore"):
        w, V = np.linalg.eigh(Sg)
        Vt = np.swapaxes(V, -1, -2)
        R = Sg @ V - V * w[:, None, :]
        Rb = np.abs(Sg) @ np.abs(V) + np.abs(V) * np.abs(w)[:, None, :]
        F = Vt @ V - np.eye(n)
        Fb = np.abs(Vt) @ np.abs(V) + np.eye(n)
        r = norm_upper(list(_residual_upper(R, Rb, n + 1).reshape(len(S), -1).T))
        f = norm_upper(list(_residual_upper(F, Fb, n + 1).reshape(len(S), -1).T))
        den = _down(np.sqrt(_down(1.0 - f)))
        out = _up(w[:, -1] + _up(r / den))
    ok = good & (f < 1.0) & (den > 0) & np.isfinite(out)
    return np.where(ok, out, np.inf)


def _weyl_bound(A, G=None) -> np.ndarray:
    """(K,) upper bounds of sigma_max over an interval matrix A by Weyl's
    inequality on its Gram matrix G = A^T A: for every G' in G,
    lambda_max(G') <= lambda_max(M) + ||G' - M||_2 <= lambda_max(M) + ||R||_2,
    M the float midpoint matrix and R (entrywise, upper) the largest distance
    of G's bounds from M (|G' - M| <= R, and the 2-norm is monotone on
    nonnegative matrices); ||R||_2 <= min(||R||_F, ||R||_inf)."""
    G = _gram(A) if G is None else G
    n = len(G)
    M = np.stack([np.stack([e.mid for e in row], -1) for row in G], -2)
    M = 0.5 * (M + np.swapaxes(M, -1, -2))
    rad = [[np.maximum(_up(G[i][j].hi - M[:, i, j]), _up(M[:, i, j] - G[i][j].lo)) for j in range(n)]
           for i in range(n)]
    with np.errstate(all="ignore"):
        rf = norm_upper([x for row in rad for x in row])
        ri = None
        for row in rad:
            s = row[0]
            for x in row[1:]:
                s = _up(s + x)
            ri = s if ri is None else np.maximum(ri, s)
        lam = _up(lambda_max_upper(M) + np.minimum(rf, ri))
        out = _up(np.sqrt(np.maximum(lam, 0.0)))
    return np.where(np.isfinite(out), out, np.inf)


def sigma_max_upper(A) -> np.ndarray:
    """(K,) upper bounds of the largest singular value over an interval matrix
    A: the smallest of Gershgorin's bounds on A^T A and A A^T
    (:func:`_sigma_max_upper`) and Weyl's on A^T A (:func:`_weyl_bound`; A A^T
    has the same nonzero eigenvalues)."""
    At = [[A[i][j] for i in range(len(A))] for j in range(len(A[0]))]
    G = _gram(A)
    return np.minimum(np.minimum(_gram_bound(A, G), _gram_bound(At)), _weyl_bound(A, G))
