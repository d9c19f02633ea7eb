"""The local values from (J, M), defined once: :data:`VALUES`, one table.

Each row is one local value: its id (the column of the compiled kernels'
value arrays), its name, the matrix it needs, its sense (``min``: the value
is ``inf`` where it cannot be computed, a point that then scores worst;
``max``: ``0``), the numpy formula from the intermediate quantities of
:class:`Operands` (the singular values of J and M, the finite J) and its
derivative from (A, dA) (simple singular values, cond_F through the inverse,
the Gram determinant), side by side.

=======  ==============  =====  =====  ============================================
id       name            needs  sense  formula
=======  ==============  =====  =====  ============================================
DYN      dynamic         M      min    sigma_max(M) = s_1(M) (eq. 28)
SMIN2    sigma_min_sq    J      max    c s_n(J)^2 = lambda_min(K), K = J^T c J
SMIN     sigma_min       J      max    c s_n(J) (c = sqrt(k): the literal eq. 33)
FRO      cond_fro        J      min    sqrt(sum s_i^2 sum 1/s_i^2) = ||J||_F ||J^-1||_F
TWO      cond_2          J      min    s_1 / s_n
DET      det_JJt         J      max    sqrt(det(J J^T)) (= |det J| for square J)
DET      det_JtJ         J      max    sqrt(det(J^T J)) (= |det J| for square J)
IFRO     inv_cond_fro    J      max    c / cond_F(J) (c = 1, or n: ``normalized``)
COL0+a   col_sq          J      max    c sum_i J_ia^2 = c (J^T J)_aa
=======  ==============  =====  =====  ============================================

c is the factor of :func:`select` (an option ``k``, ``n`` of normalized
dexterity, else 1).  The engine (:mod:`optdesign.engine.kernels`) computes
each value with c = 1 in inline arithmetic of its own (QR, closed-form
eigenvalues: no dispatch in the point loop) into the column of its id; its
callers scale the reductions by c > 0 (:func:`kernel_value`).  The
global index is the mean of the local value over the reachable points
(:mod:`optdesign.indices`).  The numpy paths (:mod:`optdesign.indices`, the
points the kernels leave to LAPACK) call ``VALUES[...].value``; the gradients
(:mod:`optdesign.local_derivatives`) ``.derivative``.

Two routes to one number, kept as they were: a derivative entry returns its
own value (the SVD with its vectors; cond_F through the inverse), equal to
``.value`` to a few ulps (cond_F and its inverse: to about eps cond_F); the
Gram determinants lose about eps cond(J)^2 relative where the described
kernel's |det J| (from its QR) loses eps cond(J) (its points of cond_F >=
1000 get the numpy formula).

Imports numpy only: the bottom of the package.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "COL0",
    "DET",
    "DYN",
    "FRO",
    "IFRO",
    "NCOL",
    "NVAL",
    "SMIN",
    "SMIN2",
    "TWO",
    "VALUES",
    "LocalValue",
    "Operands",
    "cond_2_of",
    "cond_fro_of",
    "finite_stack",
    "full_rank",
    "kernel_value",
    "select",
    "sigma_max_of",
    "sigma_min_of",
    "singular_values",
    "solve",
]

#: ids: the columns of the kernels' value arrays
DYN, SMIN2, SMIN, FRO, TWO, DET, IFRO = 0, 1, 2, 3, 4, 5, 6
COL0 = 7            # COL0 + a: column a of J (axis stiffness)
NCOL = 6            # columns the value arrays hold (pose coordinates <= 6)
NVAL = COL0 + NCOL


# ---------------------------------------------------------------------- intermediate quantities
def finite_stack(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Replace non-finite matrices by the identity; return (clean, good mask)."""
    good = np.all(np.isfinite(A), axis=(-1, -2))
    eye = np.eye(A.shape[-1], A.shape[-2]) if A.shape[-1] == A.shape[-2] else np.zeros(A.shape[-2:])
    return np.where(good[..., None, None], A, eye), good


def singular_values(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values (..., k) in descending order and the mask of finite inputs."""
    Ac, good = finite_stack(A)
    return np.linalg.svd(Ac, compute_uv=False), good


def full_rank(s: np.ndarray, shape: tuple) -> np.ndarray:
    """Numerically full rank (numpy.linalg.matrix_rank's tolerance): a matrix
    whose smallest singular value is round-off of the largest counts as singular."""
    tol = s[..., 0] * max(shape[-2:]) * np.finfo(float).eps
    return s[..., -1] > tol


class Operands:
    """J and M of a stack of points and their intermediate quantities, each
    computed once when a formula first asks for it: ``svJ``, ``svM``
    (:func:`singular_values`: (s, good)), ``finite_J`` (:func:`finite_stack`).
    Singular values computed already may be given (``svJ``, ``svM``)."""

    def __init__(self, J=None, M=None, svJ=None, svM=None):
        self.J, self.M = J, M
        self._svJ, self._svM, self._finite_J = svJ, svM, None

    @property
    def svJ(self):
        if self._svJ is None:
            self._svJ = singular_values(self.J)
        return self._svJ

    @property
    def svM(self):
        if self._svM is None:
            self._svM = singular_values(self.M)
        return self._svM

    @property
    def finite_J(self):
        if self._finite_J is None:
            self._finite_J = finite_stack(self.J)
        return self._finite_J


# ---------------------------------------------------------------------- formulas from singular values
def sigma_max_of(s: np.ndarray, good: np.ndarray) -> np.ndarray:
    return np.where(good, s[..., 0], np.inf)


def sigma_min_of(s: np.ndarray, good: np.ndarray) -> np.ndarray:
    """The smallest singular value, 0 where the input is not finite or the
    value is round-off of the largest (numerically singular, the tolerance
    of :func:`full_rank` with the number of singular values): LAPACK returns
    anything from 0 to about 1e-64 for an exactly singular matrix, by platform."""
    tol = s[..., 0] * s.shape[-1] * np.finfo(float).eps
    return np.where(good & (s[..., -1] > tol), s[..., -1], 0.0)


def cond_2_of(s: np.ndarray, good: np.ndarray, shape: tuple) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        c = s[..., 0] / s[..., -1]
    return np.where(good & full_rank(s, shape), c, np.inf)


def cond_fro_of(s: np.ndarray, good: np.ndarray, shape: tuple) -> np.ndarray:
    """||A||_F ||A^-1||_F = sqrt(sum s^2 sum 1/s^2) (square A); inf where singular."""
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.sqrt(np.sum(s * s, axis=-1) * np.sum(1.0 / (s * s), axis=-1))
    return np.where(good & full_rank(s, shape) & np.isfinite(c), c, np.inf)


# ---------------------------------------------------------------------- the values (numpy, vectorized)
def _v_dyn(o, c, a):
    return sigma_max_of(*o.svM)


def _v_smin2(o, c, a):
    s = sigma_min_of(*o.svJ)
    return c * s * s


def _v_smin(o, c, a):
    return c * sigma_min_of(*o.svJ)


def _v_fro(o, c, a):
    return cond_fro_of(*o.svJ, o.J.shape)


def _v_two(o, c, a):
    return cond_2_of(*o.svJ, o.J.shape)


def _v_ifro(o, c, a):
    f = cond_fro_of(*o.svJ, o.J.shape)
    with np.errstate(divide="ignore"):
        return np.where(np.isfinite(f), c / f, 0.0)


def _v_det(rows):
    def value(o, c, a):
        Jc, good = o.finite_J
        G = Jc @ np.swapaxes(Jc, -1, -2) if rows else np.swapaxes(Jc, -1, -2) @ Jc
        return np.where(good, np.sqrt(np.maximum(np.linalg.det(G), 0.0)), 0.0)
    return value


def _v_col(o, c, a):
    Jc, good = o.finite_J
    return np.where(good, c * np.sum(Jc[..., :, a] ** 2, axis=-1), 0.0)


# ---------------------------------------------------------------------- their derivatives
def _clean(A):
    """(A with every non-finite matrix replaced by a copy of the identity's
    shape, mask (...,) of those matrices): LAPACK never sees NaN or inf (its
    SVD does not converge on them); their results are set to NaN after."""
    bad = ~np.all(np.isfinite(A), axis=(-1, -2))
    if not bad.any():
        return A, bad
    eye = np.eye(A.shape[-2], A.shape[-1])
    return np.where(bad[..., None, None], eye, A), bad


def _svd_parts(A):
    A, bad = _clean(np.asarray(A, float))
    U, s, Vt = np.linalg.svd(A)
    if bad.any():
        U, s, Vt = (np.where(bad[..., None, None], np.nan, U), np.where(bad[..., None], np.nan, s),
                    np.where(bad[..., None, None], np.nan, Vt))
    return U, s, Vt


def solve(A, B):
    """solve(A, B) per matrix; NaN where A is non-finite or exactly singular (no LinAlgError)."""
    A, bad = _clean(np.asarray(A, float))
    with np.errstate(all="ignore"):
        bad = bad | (np.linalg.det(A) == 0)
    X = np.linalg.solve(np.where(bad[..., None, None], np.eye(A.shape[-1]), A), B)
    return np.where(bad[..., None, None], np.nan, X)


def _inv(A):
    """inv(A) per matrix; NaN for a non-finite or exactly singular one (no LinAlgError)."""
    A, bad = _clean(np.asarray(A, float))
    with np.errstate(all="ignore"):
        bad = bad | (np.linalg.det(A) == 0)
    Ai = np.linalg.inv(np.where(bad[..., None, None], np.eye(A.shape[-1]), A))
    return np.where(bad[..., None, None], np.nan, Ai)


def _dsigma(U, Vt, dA, k):
    """d sigma_k = u_k^T dA v_k (a simple singular value), (..., n_free)."""
    return np.einsum("...i,...ijp,...j->...p", U[..., :, k], dA, Vt[..., k, :])


def _dfro_cond(A, dA):
    """(cond_F, d cond_F) of square A: ||A||_F ||A^-1||_F, d||A||^2 = 2 <A, dA>,
    d||A^-1||^2 = -2 <A^-1, A^-1 dA A^-1>."""
    Ai = _inv(A)
    a = np.sum(A * A, axis=(-1, -2))
    b = np.sum(Ai * Ai, axis=(-1, -2))
    da = 2.0 * np.einsum("...ij,...ijp->...p", A, dA)
    B = np.einsum("...ij,...jkp,...kl->...ilp", Ai, dA, Ai)
    db = -2.0 * np.einsum("...il,...ilp->...p", Ai, B)
    f = np.sqrt(a * b)
    return f, (da * b[..., None] + a[..., None] * db) / (2.0 * f[..., None])


def _d_dyn(A, dA, c, a):
    U, s, Vt = _svd_parts(A)
    return s[..., 0], _dsigma(U, Vt, dA, 0)


def _d_smin2(A, dA, c, a):
    U, s, Vt = _svd_parts(A)
    sm = s[..., -1]
    return c * sm * sm, 2.0 * c * sm[..., None] * _dsigma(U, Vt, dA, -1)


def _d_smin(A, dA, c, a):
    U, s, Vt = _svd_parts(A)
    return c * s[..., -1], c * _dsigma(U, Vt, dA, -1)


def _d_fro(A, dA, c, a):
    return _dfro_cond(A, dA)


def _d_two(A, dA, c, a):
    U, s, Vt = _svd_parts(A)
    d1, dn = _dsigma(U, Vt, dA, 0), _dsigma(U, Vt, dA, -1)
    s1, sn = s[..., :1], s[..., -1:]
    return s[..., 0] / s[..., -1], (d1 * sn - s1 * dn) / (sn * sn)


def _d_ifro(A, dA, c, a):
    f, df = _dfro_cond(A, dA)
    return c / f, -c * df / (f * f)[..., None]


def _d_det(rows):
    def derivative(J, dJ, c, a):
        """d sqrt(det G) = sqrt(det G) <G^-1 J, dJ> for G = J J^T (and J H^-1 for H = J^T J)."""
        Jt = np.swapaxes(J, -1, -2)
        if rows:
            G = J @ Jt
            W = solve(G, J)                       # G^-1 J
        else:
            G = Jt @ J
            W = np.swapaxes(solve(G, Jt), -1, -2)  # J H^-1
        m = np.sqrt(np.maximum(np.linalg.det(G), 0.0))
        return m, m[..., None] * np.einsum("...ij,...ijp->...p", W, dJ)
    return derivative


def _d_col(J, dJ, c, a):
    return c * np.sum(J[..., :, a] ** 2, axis=-1), 2.0 * c * np.einsum("...i,...ip->...p", J[..., :, a], dJ[..., :, a, :])


# ---------------------------------------------------------------------- the table
@dataclass(frozen=True)
class LocalValue:
    """One local value: ``value(Operands, c, a)`` (...) and ``derivative(A, dA, c, a)``
    -> (value, d value (..., n_free)) with A the matrix it ``needs``; c the
    factor and a the column (``col_sq``) of :func:`select`."""

    id: int
    name: str
    needs: str
    sense: str
    formula: str
    value: Callable[..., np.ndarray]
    derivative: Callable[..., tuple]


VALUES: dict[str, LocalValue] = {v.name: v for v in (
    LocalValue(DYN, "dynamic", "M", "min", "sigma_max(M)", _v_dyn, _d_dyn),
    LocalValue(SMIN2, "sigma_min_sq", "J", "max", "c sigma_min(J)^2", _v_smin2, _d_smin2),
    LocalValue(SMIN, "sigma_min", "J", "max", "c sigma_min(J)", _v_smin, _d_smin),
    LocalValue(FRO, "cond_fro", "J", "min", "||J||_F ||J^-1||_F", _v_fro, _d_fro),
    LocalValue(TWO, "cond_2", "J", "min", "sigma_max(J) / sigma_min(J)", _v_two, _d_two),
    LocalValue(DET, "det_JJt", "J", "max", "sqrt(det(J J^T))", _v_det(True), _d_det(True)),
    LocalValue(DET, "det_JtJ", "J", "max", "sqrt(det(J^T J))", _v_det(False), _d_det(False)),
    LocalValue(IFRO, "inv_cond_fro", "J", "max", "c / (||J||_F ||J^-1||_F)", _v_ifro, _d_ifro),
    LocalValue(COL0, "col_sq", "J", "max", "c (J^T J)_aa", _v_col, _d_col),
)}

#: (index kind, convention) -> value name (a convention of None: the kind's default)
_KINDS = {
    ("dynamic", None): "dynamic",
    ("stiffness", None): "sigma_min_sq", ("stiffness", "lambda_min_K"): "sigma_min_sq",
    ("stiffness", "sqrt_lambda_min_K"): "sigma_min",
    ("isotropy", None): "cond_fro", ("isotropy", "frobenius"): "cond_fro", ("isotropy", "two_norm"): "cond_2",
    ("dexterity", None): "inv_cond_fro", ("dexterity", "plain"): "inv_cond_fro",
    ("dexterity", "normalized"): "inv_cond_fro",
    ("manipulability", None): "det_JJt", ("driving", None): "det_JtJ",
    ("axis_stiffness", None): "col_sq",
}


def select(kind: str, convention: str | None, options: dict, n) -> tuple[LocalValue, object, int]:
    """(row, c, a) of an index kind with its convention and options for
    matrices of n columns: ``row.value(Operands(J, M), c, a)`` is its local
    value.  c: ``k`` (stiffness: ``sqrt(k)`` for ``sqrt_lambda_min_K``; axis
    stiffness), n (normalized dexterity) or 1; a: the ``axis`` option.
    ValueError for a kind or convention the table does not have."""
    if (kind, convention) not in _KINDS:
        raise ValueError(f"no local value for index kind {kind!r} with convention {convention!r}")
    row = VALUES[_KINDS[(kind, convention)]]
    k = options.get("k", 1.0)
    c = 1.0
    if row.id == SMIN2 or row.id == COL0:
        c = k
    elif row.id == SMIN:
        c = np.sqrt(k)
    elif row.id == IFRO and convention == "normalized":
        c = n
    return row, c, int(options.get("axis", 0)) if row.id == COL0 else 0


def kernel_value(kind: str, convention: str | None, options, dof: int) -> tuple[int, float] | None:
    """(id, c) of the kernels' column that gives this index's local value as
    c times the column (c > 0), or None where a kernel does not compute it: an
    unknown kind or convention, an option other than a positive finite ``k``
    (and an integer ``axis`` in [0, dof) for axis stiffness)."""
    opts = dict(options or ())
    k = opts.pop("k", 1.0)
    try:
        k = float(k)
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(k) and k > 0) or (kind, convention) not in _KINDS:
        return None
    row = VALUES[_KINDS[(kind, convention)]]
    if row.id == COL0:
        a = opts.pop("axis", 0)
        try:
            ok = float(a).is_integer() and 0 <= int(a) < min(dof, NCOL)
        except (TypeError, ValueError):
            ok = False
        return None if opts or not ok else (COL0 + int(a), k)
    if opts:
        return None
    if row.id == SMIN:
        return SMIN, math.sqrt(k)
    if row.id == IFRO:
        return IFRO, float(dof) if convention == "normalized" else 1.0
    return row.id, k if row.id == SMIN2 else 1.0
