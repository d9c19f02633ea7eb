"""Smooth platform paths X(t), V(t), A(t) for the dynamics checks: the paper's
(section 2.4, figures 9 and 10) and a larger one."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Trajectory", "paper_trajectory", "large_trajectory"]


@dataclass(frozen=True)
class Trajectory:
    """A platform path X(t), V(t), A(t) (arrays of times -> (N, 3))."""

    name: str
    amplitude: tuple[float, float, float]
    frequency: tuple[float, float, float]   # Hz
    phase: tuple[float, float, float]
    center: tuple[float, float, float]

    def __call__(self, t):
        t = np.atleast_1d(np.asarray(t, float))[:, None]
        a = np.array(self.amplitude)
        w = 2 * np.pi * np.array(self.frequency)
        ph = np.array(self.phase)
        s = np.sin(w * t + ph)
        c = np.cos(w * t + ph)
        X = np.array(self.center) + a * s
        V = a * w * c
        A = -a * w * w * s
        return X, V, A

    def describe(self) -> str:
        parts = []
        for k, (a, f, ph, c) in enumerate(zip(self.amplitude, self.frequency, self.phase, self.center)):
            ax = "xyz"[k]
            if a == 0:
                parts.append(f"{ax} = {c:g}")
            else:
                cs = f"{c:g} + " if c else ""
                phs = f" + {ph:.3g}" if ph else ""
                parts.append(f"{ax} = {cs}{a:g} sin(2 pi {f:g} t{phs})")
        return ", ".join(parts)


def paper_trajectory(z: float = 0.57) -> Trajectory:
    """x = y = 0.001 sin(40 pi t), z = 0.57 (section 2.4, figures 9 and 10)."""
    return Trajectory("paper", (1e-3, 1e-3, 0.0), (20.0, 20.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, z))


def large_trajectory(z: float = 0.57) -> Trajectory:
    """A larger smooth path: 3 cm at 2 Hz in x, 2 cm at 3 Hz in y, 1.5 cm at 2.5 Hz in z."""
    return Trajectory("large", (0.03, 0.02, 0.015), (2.0, 3.0, 2.5), (0.0, 0.5, 0.0), (0.0, 0.0, z))
