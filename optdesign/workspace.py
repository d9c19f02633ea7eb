"""The workspace W: sampled points of the task space, as quadratures of the
integral mean over W (eq. 29: int_W sigma dW / int_W dW).

Regions: a ``box`` over the pose axes (an axis with lower == upper is fixed, so
a box with a fixed z is the plane at fixed height of the paper) and a
``cylinder`` (a disc of ``radius`` around ``center`` in the first two axes,
times a range or a value on the third).  Points

* on a ``grid`` (``step`` or ``points_per_axis``; every point the same weight);
* ``gauss``: tensor Gauss-Legendre nodes and weights (``points_per_axis`` per
  free axis; for a cylinder Gauss-Legendre in the radius with the Jacobian r,
  ``2 points_per_axis`` equally spaced angles, Gauss-Legendre in the height);
* ``rqmc``: ``scramblings`` independently scrambled Sobol sets of ``points``
  each (seeded), every point the same weight;
* quasi-random (scipy.stats.qmc Sobol, Halton, Latin hypercube; seeded) or
  pseudo-random (numpy, seeded);
* ``adaptive``: no fixed points; each global index is integrated to a relative
  ``tolerance`` by adaptive cubature (:mod:`optdesign.cubature`, at most
  ``max_points`` nodes).  The sample holds the nodes of the cubature's starting
  partition (a fixed rule, for the paths that need points).

Each sample carries an :class:`ErrorRule`, how the error of its mean against
the integral is estimated (see :func:`sample`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .cubature import initial_rule

__all__ = ["WorkspaceSpec", "Workspace", "Rule", "ErrorRule", "sample", "gauss_legendre", "point_count",
           "MAX_POINTS", "WorkspaceTooLarge"]

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
    scramblings: int = 8
    tolerance: float | None = None      # adaptive: relative tolerance of each global index
    max_points: int = 200_000           # adaptive: the most nodes per evaluation


@dataclass(frozen=True)
class Rule:
    """A quadrature of the integral mean over W: points ``X`` (M, dof) and
    weights (M,) summing to 1 (``None``: every point 1/M, the plain mean)."""

    X: np.ndarray
    weights: np.ndarray | None = None


@dataclass(frozen=True)
class ErrorRule:
    """How the error of a sample's mean against the integral is estimated.

    ``method``:

    * ``subgrid`` (grids): ``factor * |Q - Q_c|`` with Q_c the plain mean over
      the sub-grid of every second point along each free axis (``rules[0]``);
      the plain mean of a grid is a first-order rule (its error is about
      c / n per axis, n points), and ``factor = n_c / (n - n_c)`` (the
      largest over the free axes) is the Richardson extrapolation of that
      error from the two grids;
    * ``coarse`` (gauss): ``|Q_n - Q_(n-1)|``, the difference to the rule of
      one node fewer per axis (``rules[0]``, its own points);
    * ``scramblings`` (rqmc): the standard error of the mean over the S
      scramblings, ``std(Q_s, ddof=1) / sqrt(S)`` (``rules``: the S sets,
      whose union is the sample);
    * ``sample`` (sobol, halton, lhs, random): ``std / sqrt(count)``, the
      Monte Carlo standard error (exact for random points; for one
      quasi-random set it overstates the error, which it cannot estimate);
    * ``adaptive``: the adaptive cubature's own estimate (the sum over its
      boxes of |Q_7 - Q_5|, propagated to the mean; :mod:`optdesign.cubature`).
    """

    method: str
    rules: tuple[Rule, ...] = ()
    factor: float = 1.0
    description: str = ""


@dataclass
class Workspace:
    """Sampled workspace points ``X`` (N, dof) and the spec they came from.

    ``weights`` (N,) sum to 1 (``None``: the plain mean, every point 1/N);
    ``error_rule`` says how the mean's error is estimated."""

    spec: WorkspaceSpec
    names: tuple[str, ...]
    X: np.ndarray
    grid_shape: tuple[int, ...] | None = None  # for grids: points per free axis
    weights: np.ndarray | None = None
    error_rule: ErrorRule | None = None

    @property
    def n(self) -> int:
        return self.X.shape[0]

    def fraction(self, mask: np.ndarray) -> np.ndarray:
        """The weighted share of the points in ``mask`` (..., N): the share of
        W they stand for (the plain share for unweighted samples)."""
        if self.weights is None:
            return mask.mean(axis=-1)
        return mask @ self.weights

    def free_axes(self) -> list[str]:
        if self.spec.type == "cylinder":
            fixed3 = self.spec.axes.get(self.names[2], (0, 0))
            return list(self.names[:2]) + ([self.names[2]] if fixed3[1] > fixed3[0] else [])
        return [a for a in self.names if self.spec.axes[a][1] > self.spec.axes[a][0]]

    def describe(self, units=None) -> str:
        """One line: the region and its sampling.  ``units`` (axis -> (unit,
        factor), value shown = SI value * factor) shows it in the config's
        units with each unit named; without, the values are SI."""
        s = self.spec

        def num(a, v):
            if not units or a not in units:
                return f"{v:g}"
            u, f = units[a]
            return f"{v * f:g}" + ("" if u in ("1", "–", "") else f" {u}")

        parts = []
        if s.type == "cylinder":
            xy = [a for a in self.names if a not in s.axes] or list(self.names[:1])
            parts.append(f"cylinder r={num(xy[0], s.radius)} about ({num(xy[0], s.center[0])}, "
                         f"{num(xy[0], s.center[1])})")
        for a in self.names:
            if a in s.axes:
                lo, hi = s.axes[a]
                parts.append(f"{a}={num(a, lo)}" if lo == hi else f"{a} in [{num(a, lo)}, {num(a, hi)}]")
        free = [a for a in self.names if a in s.axes and s.axes[a][0] != s.axes[a][1]] or list(self.names)
        shown = {units[a] for a in free if a in units} if units else set()
        step_axis = free[0] if len(shown) == 1 else None
        if s.sampling == "grid":
            how = f"grid step {num(step_axis, s.step)}" if s.step else f"grid {s.points_per_axis}/axis"
        elif s.sampling == "gauss":
            how = f"Gauss-Legendre {s.points_per_axis}/axis"
        elif s.sampling == "adaptive":
            how = f"adaptive cubature, tolerance {s.tolerance:g} (relative), at most {s.max_points} nodes"
        elif s.sampling == "rqmc":
            how = f"rqmc {s.points} pts x {s.scramblings} scramblings seed {s.seed}"
        else:
            how = f"{s.sampling} {s.points} pts seed {s.seed}"
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
    if spec.sampling == "gauss":
        free = sum(1 for a in names if a in spec.axes and spec.axes[a][1] > spec.axes[a][0])
        n = spec.points_per_axis
        return 2 * n ** (free + 2) if spec.type == "cylinder" else n ** free
    if spec.sampling == "rqmc":
        return int(spec.points) * int(spec.scramblings)
    if spec.sampling == "adaptive":     # the starting boxes' nodes (each refinement call stays below CALL_PAIRS)
        return int(initial_rule(spec, names)[1].shape[0])
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


#: above this many nodes per axis the Gauss rule is scipy's (O(n)) rather than numpy's (O(n^3))
LEGGAUSS_MAX = 150


def gauss_legendre(n: int, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes (n,) on [lo, hi] and weights (n,) summing to 1
    (the rule of the mean over the interval; exact for polynomials of degree
    2n - 1).  A fixed axis (lo == hi) is one node of weight 1."""
    if hi == lo:
        return np.array([lo]), np.array([1.0])
    if n <= LEGGAUSS_MAX:
        t, w = np.polynomial.legendre.leggauss(n)
    else:
        # numpy's rule solves a dense n x n eigenproblem (0.4 s at n = 1024, seconds under load);
        # scipy's asymptotic rule is O(n), its integrals as exact (both within 1e-13 of
        # int cos(a x), a up to n/2, at n = 200..1024)
        from scipy.special import roots_legendre

        t, w = roots_legendre(n)
    return lo + 0.5 * (hi - lo) * (t + 1.0), 0.5 * w


def _tensor(nodes: list[np.ndarray], weights: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Tensor-product rule: points (prod n_i, k) in 'ij' order, weights their products."""
    mesh = np.meshgrid(*nodes, indexing="ij")
    wmesh = np.meshgrid(*weights, indexing="ij")
    X = np.stack([g.ravel() for g in mesh], axis=-1)
    w = np.prod(np.stack([g.ravel() for g in wmesh], axis=0), axis=0)
    return X, w


def _gauss_box(ranges, n: int) -> tuple[np.ndarray, np.ndarray]:
    nodes, weights = zip(*(gauss_legendre(n, lo, hi) for lo, hi in ranges))
    return _tensor(list(nodes), list(weights))


def _gauss_cylinder(r: float, center, range3, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The mean over the disc of radius r (times the third axis): Gauss-Legendre
    in the radius with the Jacobian r (weights w_i r_i / R), 2n equally spaced
    angles (the trapezoid rule, exact for trigonometric polynomials of degree
    < 2n), Gauss-Legendre in the height.  Exact for polynomials of the pose of
    degree <= 2n - 2 in (x, y) and 2n - 1 in the height."""
    rho, wr = gauss_legendre(n, 0.0, r)
    wr = wr * rho / (0.5 * r)                  # the Jacobian, normalized: sum(wr) = 1
    m = 2 * n
    ang = 2.0 * np.pi * (np.arange(m) + 0.5) / m
    z, wz = gauss_legendre(n, *range3)
    R, A, Z = np.meshgrid(rho, ang, z, indexing="ij")
    WR, WA, WZ = np.meshgrid(wr, np.full(m, 1.0 / m), wz, indexing="ij")
    X = np.stack([center[0] + (R * np.cos(A)).ravel(), center[1] + (R * np.sin(A)).ravel(), Z.ravel()], axis=-1)
    return X, (WR * WA * WZ).ravel()


def _sobol_sets(dim: int, m: int, scramblings: int, seed: int) -> np.ndarray:
    """``scramblings`` independently scrambled Sobol sets of 2^m points in
    [0, 1)^dim, (S, 2^m, dim), from child seeds of ``seed``."""
    if dim == 0:
        return np.zeros((scramblings, 2 ** m, 0))
    from scipy.stats import qmc

    kids = np.random.SeedSequence(seed).spawn(scramblings)
    return np.stack([qmc.Sobol(d=dim, scramble=True, seed=np.random.default_rng(k)).random_base2(m) for k in kids])


def _richardson(counts) -> float:
    """Factor n_c / (n - n_c) of a first-order rule from n points and the n_c
    points of every second one, the largest over the axes (1 without a free axis)."""
    f = [math.ceil(n / 2) / (n - math.ceil(n / 2)) for n in counts if n > 1]
    return max(f) if f else 1.0


def _grid_error(X: np.ndarray, rows: np.ndarray, counts) -> ErrorRule:
    factor = _richardson(counts)
    return ErrorRule("subgrid", (Rule(X[rows]),), factor,
                     f"grid against its sub-grid of every second point, Richardson factor {factor:.3g} "
                     "(first-order rule)")


def _coarse_error(X: np.ndarray, w: np.ndarray, n: int) -> ErrorRule:
    return ErrorRule("coarse", (Rule(X, w),), 1.0, f"|Q_{n} - Q_{n - 1}| (Gauss-Legendre, one node fewer per axis)")


def _rqmc(spec: WorkspaceSpec, names: tuple[str, ...], dim: int, to_points) -> Workspace:
    P, S = spec.points, spec.scramblings
    U = _sobol_sets(dim, int(round(math.log2(P))), S, spec.seed)
    X = np.concatenate([to_points(U[s]) for s in range(S)])
    rules = tuple(Rule(X[s * P:(s + 1) * P]) for s in range(S))
    err = ErrorRule("scramblings", rules, 1.0, f"standard error over {S} scramblings of {P} Sobol points")
    return Workspace(spec, names, X, None, None, err)


_ADAPTIVE = ("adaptive cubature (Genz-Malik 7/5, Gauss-Kronrod 15/7 on one axis): 3 x the sum of |Q_hi - Q_lo| "
             "over its boxes, to a relative tolerance {:g}")
_SAMPLE_ERROR = ErrorRule("sample", (), 1.0, "std / sqrt(points), the Monte Carlo standard error")


def sample(spec: WorkspaceSpec, names: tuple[str, ...]) -> Workspace:
    """Sample the region of ``spec`` over the pose axes ``names`` (SI units).
    Raises :class:`WorkspaceTooLarge` before allocating more than MAX_POINTS points."""
    n = point_count(spec, names)
    if n > MAX_POINTS:
        raise WorkspaceTooLarge(f"the workspace has {n:,} points; at most {MAX_POINTS:,} are allowed")
    if spec.sampling == "adaptive":
        X, w = initial_rule(spec, names)
        return Workspace(spec, names, X, None, w, ErrorRule("adaptive", (), 1.0, _ADAPTIVE.format(spec.tolerance)))
    if spec.type == "box":
        ranges = [spec.axes[a] for a in names]
        free = [i for i, (lo, hi) in enumerate(ranges) if hi > lo]
        if spec.sampling == "grid":
            axes = [_axis_grid(lo, hi, spec.step, spec.points_per_axis) for lo, hi in ranges]
            mesh = np.meshgrid(*axes, indexing="ij")
            X = np.stack([g.ravel() for g in mesh], axis=-1)
            shape = tuple(len(axes[i]) for i in free)
            rows = np.ravel_multi_index(np.ix_(*(np.arange(0, len(g), 2) for g in axes)),
                                        tuple(len(g) for g in axes)).ravel()
            return Workspace(spec, names, X, shape, None, _grid_error(X, rows, shape))
        if spec.sampling == "gauss":
            n = spec.points_per_axis
            X, w = _gauss_box(ranges, n)
            Xc, wc = _gauss_box(ranges, n - 1)
            return Workspace(spec, names, X, (n,) * len(free), w, _coarse_error(Xc, wc, n))

        def unit_to_box(U):
            X = np.empty((U.shape[0], len(names)))
            for i, (lo, hi) in enumerate(ranges):
                X[:, i] = lo
            for j, i in enumerate(free):
                lo, hi = ranges[i]
                X[:, i] = lo + (hi - lo) * U[:, j]
            return X

        if spec.sampling == "rqmc":
            return _rqmc(spec, names, len(free), unit_to_box)
        U = _unit_samples(spec.sampling, spec.points, len(free), spec.seed)
        return Workspace(spec, names, unit_to_box(U), None, None, _SAMPLE_ERROR)

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
        i, j, k = np.meshgrid(*(np.arange(len(v)) % 2 == 0 for v in (g, g, g3)), indexing="ij")
        rows = (np.cumsum(inside.ravel()) - 1)[(inside & i & j & k).ravel()]
        counts = (len(g), len(g), len(g3))
        return Workspace(spec, names, X, None, None, _grid_error(X, rows, counts))
    free3 = hi3 > lo3
    if spec.sampling == "gauss":
        n = spec.points_per_axis
        X, w = _gauss_cylinder(r, (cx, cy), (lo3, hi3), n)
        Xc, wc = _gauss_cylinder(r, (cx, cy), (lo3, hi3), n - 1)
        return Workspace(spec, names, X, None, w, _coarse_error(Xc, wc, n))

    def unit_to_cylinder(U):
        rad = r * np.sqrt(U[:, 0])          # uniform over the disc area
        ang = 2 * np.pi * U[:, 1]
        z = lo3 + (hi3 - lo3) * U[:, 2] if free3 else np.full(U.shape[0], lo3)
        return np.stack([cx + rad * np.cos(ang), cy + rad * np.sin(ang), z], axis=-1)

    if spec.sampling == "rqmc":
        return _rqmc(spec, names, 3 if free3 else 2, unit_to_cylinder)
    U = _unit_samples(spec.sampling, spec.points, 3 if free3 else 2, spec.seed)
    return Workspace(spec, names, unit_to_cylinder(U), None, None, _SAMPLE_ERROR)
