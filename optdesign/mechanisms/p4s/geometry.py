"""The 3-P(4S)'s fixed geometry: branch directions e_i, the vertical z, the
short-side directions t_i of the parallelograms, and array helpers."""
from __future__ import annotations

import numpy as np

__all__ = ["E", "Z", "T", "skew"]

_GAMMA = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
#: e_i, the unit vectors from the centre to the branches (3 branches x 3 components)
E = np.stack([np.cos(_GAMMA), np.sin(_GAMMA), np.zeros(3)], axis=-1)
E[np.abs(E) < 1e-15] = 0.0
Z = np.array([0.0, 0.0, 1.0])
#: t_i = z x e_i, the direction of the short sides of the parallelogram
T = np.cross(Z, E)

def _col(a: np.ndarray) -> np.ndarray:
    """Parameter (design shape, which already spans the pose axis) -> shape
    (..., 1, 1) to broadcast over the (branch, component) axes."""
    return np.asarray(a, dtype=float)[..., None, None]


def skew(n: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrices of vectors (..., 3) -> (..., 3, 3): skew(a) b = a x b."""
    z = np.zeros_like(n[..., 0])
    return np.stack([
        np.stack([z, -n[..., 2], n[..., 1]], -1),
        np.stack([n[..., 2], z, -n[..., 0]], -1),
        np.stack([-n[..., 1], n[..., 0], z], -1),
    ], -2)


def _p(a, k: int) -> np.ndarray:
    """A (broadcast) design parameter with k trailing axes added."""
    a = np.asarray(a, dtype=float)
    return a.reshape(a.shape + (1,) * k)
