"""Local performance indices (plain functions of matrices) and their global aggregates.

All functions take stacks of matrices ``(..., n, n)`` and return ``(...)``.  A
local value that cannot be computed (a singular or unreachable pose) is ``inf``
for indices to be minimized and ``0`` for indices to be maximized, never a
silent NaN: a design whose workspace meets a singularity then scores worst.

Index kinds (the names a config uses); each local value is a row of the
table :data:`optdesign.formulas.VALUES` (its numpy formula, shared with the
compiled paths' LAPACK hand-off and the gradients):

==============  =======  ==============================================================
kind            sense    local value
==============  =======  ==============================================================
dynamic         min      sigma_max(M) = sqrt(lambda_max(M^T M)) (eq. 28), M of eq. 23
stiffness       max      ``lambda_min_K`` (default): lambda_min(K), K = J^T k J, which
                         equals sqrt(lambda_min(K^T K)); ``sqrt_lambda_min_K``: the
                         literal eq. 33, sqrt(lambda_min(K))
isotropy        min      ``frobenius`` (default): ||J||_F ||J^-1||_F / 1 (MATLAB's
                         cond(J, 'fro')); ``two_norm``: sigma_max(J)/sigma_min(J), the
                         literal eq. 36
dexterity       max      1 / (||J||_F ||J^-1||_F) (normalized by the dimension n:
                         ``normalized`` convention multiplies by n)
manipulability  max      sqrt(det(J J^T))
driving         max      sqrt(det(J^T J))
axis_stiffness  max      k (J^T J)_aa: diagonal entry ``axis`` (option, 0-based) of
                         K = k J^T J, the stiffness along one task axis (3-SPS-S eq. 12)
constraint      max      the constraint-singularity value of a chain mechanism (``C``:
                         sigma_(6 - n) of its unit constraint wrenches, dimensionless,
                         0 at a constraint singularity; docs/lower-mobility.md)
==============  =======  ==============================================================

``constraint`` is not a function of J or M: the mechanism gives the value
itself as the ``C`` of its index matrices (chain mechanisms only).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .formulas import Operands, select
from .linalg import (cond_2, cond_2_of, cond_fro, cond_fro_of, finite_stack, sigma_max, sigma_max_of,  # noqa: F401
                     sigma_min, sigma_min_of, singular_values)

__all__ = [
    "IndexKind", "INDEX_KINDS", "local_index", "global_summary", "weighted_summary",
    "sigma_max", "sigma_min", "cond_fro", "cond_2",
]


@dataclass(frozen=True)
class IndexKind:
    """A local index: what it needs (``J`` and/or ``M``), its sense, its conventions."""

    kind: str
    needs: str                       # "J", "M" or "C" (a value the mechanism gives)
    sense: str                       # "min" or "max"
    conventions: tuple[str, ...]
    default_convention: str | None
    func: Callable[..., np.ndarray]
    description: str
    #: the keys a config's ``options`` may give this index
    options: tuple[str, ...] = ()


def _local(kind):
    """func(M, J, convention, options) of an index kind: its row of the table
    optdesign.formulas.VALUES, with the factor and column its options give."""
    def func(M, J, convention, options, C=None):
        row, c, a = select(kind, convention, options, None if J is None else J.shape[-1])
        return row.value(Operands(J=J, M=M), c, a)
    return func


_dynamic, _stiffness, _isotropy, _dexterity, _manip, _driving, _axis_stiffness = (
    _local(k) for k in ("dynamic", "stiffness", "isotropy", "dexterity", "manipulability", "driving", "axis_stiffness"))


def _constraint(M, J, convention, options, C=None):
    """The mechanism's constraint-singularity value C (...), 0 where it is not finite."""
    c = np.asarray(C, dtype=float)
    return np.where(np.isfinite(c), c, 0.0)


INDEX_KINDS: dict[str, IndexKind] = {
    "dynamic": IndexKind("dynamic", "M", "min", (), None, _dynamic,
                         "dynamic index sigma_max(M) = sqrt(lambda_max(M^T M)) (eq. 28)"),
    "stiffness": IndexKind("stiffness", "J", "max", ("lambda_min_K", "sqrt_lambda_min_K"), "lambda_min_K", _stiffness,
                           "stiffness index from K = J^T k J (eq. 30-33)", ("k",)),
    "isotropy": IndexKind("isotropy", "J", "min", ("frobenius", "two_norm"), "frobenius", _isotropy,
                          "velocity isotropy, condition number of J (eq. 36)"),
    "dexterity": IndexKind("dexterity", "J", "max", ("plain", "normalized"), "plain", _dexterity,
                           "dexterity 1/(||J||_F ||J^-1||_F)"),
    "manipulability": IndexKind("manipulability", "J", "max", (), None, _manip, "manipulability sqrt(det(J J^T))"),
    "driving": IndexKind("driving", "J", "max", (), None, _driving, "driving index sqrt(det(J^T J))"),
    "axis_stiffness": IndexKind("axis_stiffness", "J", "max", (), None, _axis_stiffness,
                                "stiffness along one task axis, k (J^T J)_aa (options: axis, k)", ("axis", "k")),
    "constraint": IndexKind("constraint", "C", "max", (), None, _constraint,
                            "constraint-singularity value of a chain mechanism (0 at a constraint singularity)"),
}


def local_index(kind: str, *, J: np.ndarray | None = None, M: np.ndarray | None = None,
                convention: str | None = None, options: dict | None = None, C: np.ndarray | None = None) -> np.ndarray:
    """Evaluate one local index on stacks of matrices (``C``: the constraint
    kind's value, which the mechanism computes)."""
    spec = INDEX_KINDS[kind]
    conv = convention if convention is not None else spec.default_convention
    return spec.func(M, J, conv, options or {}, C)


def global_summary(values: np.ndarray, mask: np.ndarray | None = None, axis: int = -1) -> dict[str, np.ndarray]:
    """The global index over W (eq. 29, 34, 37: the mean over the sampled points)
    and min, max and standard deviation, over the points in ``mask`` along ``axis``.

    With a uniform sample of W the mean is the discrete form of
    int_W sigma dW / int_W dW.  Points outside ``mask`` are left out; a design
    with no point in the mask gets NaN.
    """
    v = np.asarray(values, dtype=float)
    if mask is None:
        mask = np.isfinite(v)
    mask = np.broadcast_to(mask, v.shape)
    cnt = np.sum(mask, axis=axis)
    vz = np.where(mask, v, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.sum(vz, axis=axis) / cnt
        var = np.sum(np.where(mask, (v - np.expand_dims(mean, axis)) ** 2, 0.0), axis=axis) / cnt
    vmin = np.min(np.where(mask, v, np.inf), axis=axis)
    vmax = np.max(np.where(mask, v, -np.inf), axis=axis)
    empty = cnt == 0
    return {
        "mean": np.where(empty, np.nan, mean),
        "min": np.where(empty, np.nan, vmin),
        "max": np.where(empty, np.nan, vmax),
        "std": np.where(empty, np.nan, np.sqrt(var)),
        "count": cnt,
    }


def weighted_summary(values: np.ndarray, mask: np.ndarray, weights: np.ndarray) -> dict[str, np.ndarray]:
    """The global index as a quadrature of eq. 29 over the reachable part of W:
    ``mean = sum_reach w sigma / sum_reach w`` with the rule's weights (N,)
    along the last axis, the weighted standard deviation, min and max over the
    reachable points, their ``count``.  Where every point is reachable the
    mean is the rule's integral mean over W; otherwise it is the mean over the
    reachable part (a region with a jump in the integrand, where a quadrature
    converges slowly).  A design with no reachable point gets NaN."""
    v = np.asarray(values, dtype=float)
    mask = np.broadcast_to(mask, v.shape)
    wm = np.where(mask, np.asarray(weights, dtype=float), 0.0)
    total = np.sum(wm, axis=-1)
    cnt = np.sum(mask, axis=-1)
    vz = np.where(mask, v, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.sum(wm * vz, axis=-1) / total
        var = np.sum(wm * np.where(mask, (v - mean[..., None]) ** 2, 0.0), axis=-1) / total
    empty = cnt == 0
    return {
        "mean": np.where(empty, np.nan, mean),
        "min": np.where(empty, np.nan, np.min(np.where(mask, v, np.inf), axis=-1)),
        "max": np.where(empty, np.nan, np.max(np.where(mask, v, -np.inf), axis=-1)),
        "std": np.where(empty, np.nan, np.sqrt(np.maximum(var, 0.0))),
        "count": cnt,
    }
