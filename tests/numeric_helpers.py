"""Numerical references shared by the tests."""
from __future__ import annotations

import numpy as np


def central_jacobian(f, X: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of a batched map ``f: (N, n) -> (N, m)``:
    the (N, m, n) Jacobian, column j from ``(f(X + h e_j) - f(X - h e_j)) / 2h``."""
    X = np.asarray(X, dtype=float)
    cols = []
    for j in range(X.shape[-1]):
        e = np.zeros(X.shape[-1])
        e[j] = h
        cols.append((f(X + e) - f(X - e)) / (2 * h))
    return np.stack(cols, axis=-1)
