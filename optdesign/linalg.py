"""Plain functions of stacks of matrices ``(..., n, m)``: singular values and
the condition numbers and extreme singular values built from them.

The bottom of the package: imports numpy only, so that the numpy path of the
indices (:mod:`optdesign.indices`) and the mechanisms' compiled paths (which
hand ill-conditioned points to LAPACK) share one implementation.
"""
from __future__ import annotations

import numpy as np

__all__ = ["finite_stack", "singular_values", "sigma_max", "sigma_min", "cond_2", "cond_fro",
           "sigma_max_of", "sigma_min_of", "cond_2_of", "cond_fro_of", "full_rank"]


def finite_stack(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Replace non-finite matrices by the identity; return (clean, good mask)."""
    good = np.all(np.isfinite(A), axis=(-1, -2))
    eye = np.eye(A.shape[-1], A.shape[-2]) if A.shape[-1] == A.shape[-2] else np.zeros(A.shape[-2:])
    return np.where(good[..., None, None], A, eye), good


def singular_values(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values (..., k) in descending order and the mask of finite inputs."""
    Ac, good = finite_stack(A)
    return np.linalg.svd(Ac, compute_uv=False), good


def sigma_max(A: np.ndarray) -> np.ndarray:
    """Largest singular value, sqrt(lambda_max(A^T A)); inf where A is not finite."""
    return sigma_max_of(*singular_values(A))


def sigma_min(A: np.ndarray) -> np.ndarray:
    """Smallest singular value; 0 where A is not finite."""
    return sigma_min_of(*singular_values(A))


def full_rank(s: np.ndarray, shape: tuple) -> np.ndarray:
    """Numerically full rank (numpy.linalg.matrix_rank's tolerance): a matrix
    whose smallest singular value is round-off of the largest counts as singular."""
    tol = s[..., 0] * max(shape[-2:]) * np.finfo(float).eps
    return s[..., -1] > tol


def cond_2(A: np.ndarray) -> np.ndarray:
    """sigma_max / sigma_min (the literal eq. 36); inf where singular."""
    return cond_2_of(*singular_values(A), A.shape)


def cond_fro(A: np.ndarray) -> np.ndarray:
    """Frobenius condition number ||A||_F ||A^-1||_F (square A); inf where singular.

    Uses the singular values: ||A||_F^2 = sum s^2, ||A^-1||_F^2 = sum 1/s^2.
    """
    return cond_fro_of(*singular_values(A), A.shape)


# the same values from singular values already computed (s, good) = singular_values(A)
# (so that several indices of one matrix need one SVD)
def sigma_max_of(s: np.ndarray, good: np.ndarray) -> np.ndarray:
    return np.where(good, s[..., 0], np.inf)


def sigma_min_of(s: np.ndarray, good: np.ndarray) -> np.ndarray:
    return np.where(good, s[..., -1], 0.0)


def cond_2_of(s: np.ndarray, good: np.ndarray, shape: tuple) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        c = s[..., 0] / s[..., -1]
    return np.where(good & full_rank(s, shape), c, np.inf)


def cond_fro_of(s: np.ndarray, good: np.ndarray, shape: tuple) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.sqrt(np.sum(s * s, axis=-1) * np.sum(1.0 / (s * s), axis=-1))
    return np.where(good & full_rank(s, shape) & np.isfinite(c), c, np.inf)
