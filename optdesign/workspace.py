"""The workspace W: sampled points of the task space.

Regions: a ``box`` over the pose axes (an axis with lower == upper is fixed, so
a box with a fixed z is the plane at fixed height of the paper) and a
``cylinder`` (a disc of ``radius`` around ``center`` in the first two axes,
times a range or a value on the third).  Points on a grid (``step`` or
``points_per_axis``) or quasi-random (scipy.stats.qmc Sobol, Halton, Latin
hypercube; seeded) or pseudo-random (numpy, seeded).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["WorkspaceSpec", "Workspace", "sample", "point_count", "MAX_POINTS", "WorkspaceTooLarge"]

#: the most workspace points of a spec, and the most (point, design) pairs of
#: one evaluation call (the numpy path needs about 250-500 bytes per pair,
#: a compiled path about 12): one limit, however the points are given
MAX_POINTS = 10_000_000


class WorkspaceTooLarge(ValueError):
    """A workspace (or points x designs) beyond :data:`MAX_POINTS`."""


@dataclass(frozen=True)
class WorkspaceSpec:
    """The region W of the task space over which global indices are averaged.

    ``type`` is ``box`` (every axis a range or a fixed value: a fixed axis makes
    a plane or a line) or ``cylinder`` (radius around ``center`` in the first
    two axes, a range or a value on the third).  ``sampling`` is ``grid``
    (``step`` or ``points_per_axis``) or ``sobol``/``halton``/``lhs``/``random``
    (``points``, ``seed``).  All values SI (radians for angular axes unless
    ``unit: deg``).
    """

    type: str
    axes: dict[str, tuple[float, float]]  # name -> (lo, hi); lo == hi fixes the axis
    sampling: str = "grid"
    step: float | None = None
    points_per_axis: int | None = None
    points: int | None = None
    seed: int = 0
    radius: float | None = None
    center: tuple[float, float] = (0.0, 0.0)
    unit: str | None = None


@dataclass
class Workspace:
    """Sampled workspace points ``X`` (N, dof) and the spec they came from."""

    spec: WorkspaceSpec
    names: tuple[str, ...]
    X: np.ndarray
    grid_shape: tuple[int, ...] | None = None  # for grids: points per free axis

    @property
    def n(self) -> int:
        return self.X.shape[0]

    def free_axes(self) -> list[str]:
        if self.spec.type == "cylinder":
            fixed3 = self.spec.axes.get(self.names[2], (0, 0))
            return list(self.names[:2]) + ([self.names[2]] if fixed3[1] > fixed3[0] else [])
        return [a for a in self.names if self.spec.axes[a][1] > self.spec.axes[a][0]]

    def describe(self) -> str:
        s = self.spec
        parts = []
        if s.type == "cylinder":
            parts.append(f"cylinder r={s.radius:g} about ({s.center[0]:g}, {s.center[1]:g})")
        for a in self.names:
            if a in s.axes:
                lo, hi = s.axes[a]
                parts.append(f"{a}={lo:g}" if lo == hi else f"{a} in [{lo:g}, {hi:g}]")
        how = f"grid step {s.step:g}" if s.step else (f"grid {s.points_per_axis}/axis" if s.sampling == "grid" else f"{s.sampling} {s.points} pts seed {s.seed}")
        return f"{s.type}: " + ", ".join(parts) + f"; {how}; {self.n} points"


def _axis_count(lo: float, hi: float, step: float | None, count: int | None) -> int:
    """Points of :func:`_axis_grid` on one axis, computed without allocating."""
    if hi == lo:
        return 1
    if step is not None:
        ratio = (hi - lo) / step + 1e-9 if step > 0 else math.inf
        return int(math.floor(ratio)) + 1 if ratio < 1e18 else 10 ** 18
    return int(count)


def point_count(spec: WorkspaceSpec, names: tuple[str, ...]) -> int:
    """The number of points :func:`sample` allocates for ``spec`` (for a
    cylinder grid: the square grid before the disc is cut from it)."""
    if spec.sampling != "grid":
        return int(spec.points)
    if spec.type == "box":
        n = 1
        for a in names:
            lo, hi = spec.axes[a]
            n *= _axis_count(lo, hi, spec.step, spec.points_per_axis)
        return n
    side = _axis_count(-spec.radius, spec.radius, spec.step, spec.points_per_axis)
    lo3, hi3 = spec.axes[names[2]]
    return side * side * _axis_count(lo3, hi3, spec.step, spec.points_per_axis)


def _axis_grid(lo: float, hi: float, step: float | None, count: int | None) -> np.ndarray:
    if hi == lo:
        return np.array([lo])
    if step is not None:
        k = int(math.floor((hi - lo) / step + 1e-9))
        g = lo + step * np.arange(k + 1)
        # a grid that ends within round-off of the upper bound ends on it exactly
        if abs(g[-1] - hi) < 1e-9 * max(1.0, abs(hi)):
            g[-1] = hi
        return g
    return np.linspace(lo, hi, count) if count > 1 else np.array([0.5 * (lo + hi)])


def _unit_samples(kind: str, n: int, dim: int, seed: int) -> np.ndarray:
    if dim == 0:
        return np.zeros((n, 0))
    from scipy.stats import qmc  # imported here: a second of start-up that grids never need

    if kind == "sobol":
        eng = qmc.Sobol(d=dim, scramble=True, seed=seed)
        m = int(math.ceil(math.log2(max(n, 2))))
        return eng.random_base2(m)[:n]
    if kind == "halton":
        return qmc.Halton(d=dim, scramble=True, seed=seed).random(n)
    if kind == "lhs":
        return qmc.LatinHypercube(d=dim, seed=seed).random(n)
    return np.random.default_rng(seed).random((n, dim))


def sample(spec: WorkspaceSpec, names: tuple[str, ...]) -> Workspace:
    """Sample the region of ``spec`` over the pose axes ``names`` (SI units).
    Raises :class:`WorkspaceTooLarge` before allocating more than MAX_POINTS points."""
    n = point_count(spec, names)
    if n > MAX_POINTS:
        raise WorkspaceTooLarge(f"the workspace has {n:,} points; at most {MAX_POINTS:,} are allowed")
    if spec.type == "box":
        ranges = [spec.axes[a] for a in names]
        free = [i for i, (lo, hi) in enumerate(ranges) if hi > lo]
        if spec.sampling == "grid":
            axes = [_axis_grid(lo, hi, spec.step, spec.points_per_axis) for lo, hi in ranges]
            mesh = np.meshgrid(*axes, indexing="ij")
            X = np.stack([g.ravel() for g in mesh], axis=-1)
            shape = tuple(len(axes[i]) for i in free)
            return Workspace(spec, names, X, shape)
        U = _unit_samples(spec.sampling, spec.points, len(free), spec.seed)
        X = np.empty((spec.points, len(names)))
        for i, (lo, hi) in enumerate(ranges):
            X[:, i] = lo
        for j, i in enumerate(free):
            lo, hi = ranges[i]
            X[:, i] = lo + (hi - lo) * U[:, j]
        return Workspace(spec, names, X, None)

    # cylinder: a disc in the first two axes times the third axis
    r = spec.radius
    cx, cy = spec.center
    lo3, hi3 = spec.axes[names[2]]
    if spec.sampling == "grid":
        g = _axis_grid(-r, r, spec.step, spec.points_per_axis)
        g3 = _axis_grid(lo3, hi3, spec.step, spec.points_per_axis)
        a, b, c = np.meshgrid(g, g, g3, indexing="ij")
        inside = a * a + b * b <= r * r * (1 + 1e-12)
        X = np.stack([cx + a[inside], cy + b[inside], c[inside]], axis=-1)
        return Workspace(spec, names, X, None)
    free3 = hi3 > lo3
    U = _unit_samples(spec.sampling, spec.points, 3 if free3 else 2, spec.seed)
    rad = r * np.sqrt(U[:, 0])          # uniform over the disc area
    ang = 2 * np.pi * U[:, 1]
    z = lo3 + (hi3 - lo3) * U[:, 2] if free3 else np.full(spec.points, lo3)
    X = np.stack([cx + rad * np.cos(ang), cy + rad * np.sin(ang), z], axis=-1)
    return Workspace(spec, names, X, None)
