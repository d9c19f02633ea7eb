"""The derivative of a local index from its matrix and the matrix's
derivative (simple singular values, cond_F through the inverse, the Gram
determinant), vectorized over poses and designs; matrices that are
non-finite or exactly singular give NaN, never a LinAlgError.  Plain numpy:
the bottom of the flow, used by :mod:`optdesign.gradients`."""
from __future__ import annotations

import numpy as np

__all__ = ["local_derivative", "solve"]


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
    c = np.sqrt(a * b)
    return c, (da * b[..., None] + a[..., None] * db) / (2.0 * c[..., None])


def local_derivative(kind: str, convention: str | None, options: dict, J, dJ, M=None, dM=None):
    """(value, derivative) of a local index from its matrix and the matrix's
    derivative: J (..., n_act, dof), dJ (..., n_act, dof, n_free), likewise M
    and dM for the dynamic index.  Closed forms (simple singular values):
    d sigma_k = u_k^T dA v_k; cond_F from the Frobenius norms of A and A^-1;
    d sqrt(det G) = sqrt(det G) <G^-1 J, dJ> for G = J J^T (and J H^-1 for
    H = J^T J)."""
    options = options or {}
    if kind == "dynamic":
        U, s, Vt = _svd_parts(M)
        return s[..., 0], _dsigma(U, Vt, dM, 0)
    if kind == "stiffness":
        U, s, Vt = _svd_parts(J)
        k = options.get("k", 1.0)
        ds = _dsigma(U, Vt, dJ, -1)
        sm = s[..., -1]
        if (convention or "lambda_min_K") == "lambda_min_K":
            return k * sm * sm, 2.0 * k * sm[..., None] * ds
        return np.sqrt(k) * sm, np.sqrt(k) * ds
    if kind == "isotropy" and convention == "two_norm":
        U, s, Vt = _svd_parts(J)
        d1, dn = _dsigma(U, Vt, dJ, 0), _dsigma(U, Vt, dJ, -1)
        s1, sn = s[..., :1], s[..., -1:]
        return s[..., 0] / s[..., -1], (d1 * sn - s1 * dn) / (sn * sn)
    if kind in ("isotropy", "dexterity"):
        c, dc = _dfro_cond(J, dJ)
        if kind == "isotropy":
            return c, dc
        n = J.shape[-1] if convention == "normalized" else 1.0
        return n / c, -n * dc / (c * c)[..., None]
    if kind in ("manipulability", "driving"):
        Jt = np.swapaxes(J, -1, -2)
        if kind == "manipulability":
            G = J @ Jt
            W = solve(G, J)                       # G^-1 J
        else:
            G = Jt @ J
            W = np.swapaxes(solve(G, Jt), -1, -2)  # J H^-1
        m = np.sqrt(np.maximum(np.linalg.det(G), 0.0))
        return m, m[..., None] * np.einsum("...ij,...ijp->...p", W, dJ)
    if kind == "axis_stiffness":
        k = options.get("k", 1.0)
        a = int(options.get("axis", 0))
        return k * np.sum(J[..., :, a] ** 2, axis=-1), 2.0 * k * np.einsum("...i,...ip->...p", J[..., :, a], dJ[..., :, a, :])
    raise ValueError(f"no derivative for index kind {kind!r}")

