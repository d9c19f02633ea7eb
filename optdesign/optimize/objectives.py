"""Objectives beyond the performance indices (compactness), so that a real
trade-off appears where the indices themselves do not conflict."""
from __future__ import annotations

from typing import Callable, Mapping

import numpy as np


def _base_radius(design: Mapping[str, np.ndarray]) -> np.ndarray:
    """Base circumradius r_b (m): the footprint of the base."""
    return np.asarray(design["r_b"], dtype=float)


def _overall_radius(design: Mapping[str, np.ndarray]) -> np.ndarray:
    """Largest of the base and platform radii (m): the plan-view envelope."""
    return np.maximum(np.asarray(design["r_b"], float), np.asarray(design["r_a"], float))


#: name -> (function of the design parameters (D,), sense, description, parameters it needs)
EXTRA_OBJECTIVES: dict[str, tuple[Callable, str, str, tuple[str, ...]]] = {
    "base_radius": (_base_radius, "min", "base circumradius r_b (m)", ("r_b",)),
    "overall_radius": (_overall_radius, "min", "max(r_a, r_b) (m)", ("r_a", "r_b")),
}
