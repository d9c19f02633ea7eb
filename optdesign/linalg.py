"""Plain functions of stacks of matrices ``(..., n, m)``: the extreme
singular values and condition numbers of a matrix.

The bottom of the package (numpy and :mod:`optdesign.formulas` only): the
formulas from the singular values are :mod:`optdesign.formulas`' (imported
here under their old names), so that the numpy path of the indices
(:mod:`optdesign.indices`) and the mechanisms' compiled paths (which hand
ill-conditioned points to LAPACK) share one implementation.
"""
from __future__ import annotations

import numpy as np

from .formulas import (
    cond_2_of,
    cond_fro_of,
    finite_stack,
    full_rank,
    sigma_max_of,
    sigma_min_of,
    singular_values,
)

__all__ = ["finite_stack", "singular_values", "sigma_max", "sigma_min", "cond_2", "cond_fro",
           "sigma_max_of", "sigma_min_of", "cond_2_of", "cond_fro_of", "full_rank"]


def sigma_max(A: np.ndarray) -> np.ndarray:
    """Largest singular value, sqrt(lambda_max(A^T A)); inf where A is not finite."""
    return sigma_max_of(*singular_values(A))


def sigma_min(A: np.ndarray) -> np.ndarray:
    """Smallest singular value; 0 where A is not finite."""
    return sigma_min_of(*singular_values(A))


def cond_2(A: np.ndarray) -> np.ndarray:
    """sigma_max / sigma_min (the literal eq. 36); inf where singular."""
    return cond_2_of(*singular_values(A), A.shape)


def cond_fro(A: np.ndarray) -> np.ndarray:
    """Frobenius condition number ||A||_F ||A^-1||_F (square A); inf where singular.

    Uses the singular values: ||A||_F^2 = sum s^2, ||A^-1||_F^2 = sum 1/s^2.
    """
    return cond_fro_of(*singular_values(A), A.shape)
