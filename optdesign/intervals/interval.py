"""Vectorized interval arithmetic over numpy arrays, with outward rounding.

An :class:`Interval` holds two float arrays ``lo <= hi`` of one shape (a
batch of boxes, legs, matrix entries ...).  Every operation computes its
bounds in round-to-nearest IEEE arithmetic and then moves each bound one
floating-point number outward (``np.nextafter``, compiled for large arrays:
:mod:`._steps`): +, -, *, / and sqrt are
correctly rounded in IEEE 754 (error <= 1/2 ulp), so one step outward
encloses the exact result.  ``cos``/``sin`` of point values (the design's
constants) are widened by 4 ulps, relying on the platform's libm being
accurate to better than 1 ulp (glibc's documented bound for x86_64).
"""
from __future__ import annotations

import numpy as np

from ..fast import KernelModule, enabled

__all__ = ["Interval", "point", "hull"]

_INF = np.inf
_F = np.dtype(float)


#: the compiled rounding (:mod:`._steps`), used from this many elements on: below, numpy's
#: nextafter costs less than the call (about 2.5 us against 4.8 ns an element, 1.1 compiled)
COMPILED_FROM = 640
_STEPS = KernelModule("optdesign.intervals._steps")


def _compiled_step(a, toward: float, one: int):
    """``np.nextafter(a, toward)`` for an array of at least COMPILED_FROM
    elements: compiled where compiled paths may be used."""
    if enabled():
        mod = _STEPS.get()
        if mod is not None:
            a = np.asarray(a, dtype=float)
            return mod.steps(np.ascontiguousarray(a).reshape(-1), one).reshape(a.shape)
    return np.nextafter(a, toward)


def _down(a):
    """One double below ``a``: np.nextafter(a, -inf) bit for bit (interval
    arithmetic rounds every bound of every operation)."""
    if getattr(a, "size", 1) < COMPILED_FROM:
        return np.nextafter(a, -_INF)
    return _compiled_step(a, -_INF, -1)


def _up(a):
    """One double above ``a``: np.nextafter(a, inf) bit for bit."""
    if getattr(a, "size", 1) < COMPILED_FROM:
        return np.nextafter(a, _INF)
    return _compiled_step(a, _INF, 1)


class Interval:
    """A batch of closed intervals [lo, hi] (numpy arrays of one shape)."""

    __slots__ = ("lo", "hi")
    __array_priority__ = 1000

    def __init__(self, lo, hi=None):
        if type(lo) is np.ndarray and type(hi) is np.ndarray and lo.dtype == _F and hi.dtype == _F \
                and lo.shape == hi.shape:
            # the common case (every operation's result): what np.broadcast_arrays returns for
            # two float arrays of one shape, without its cost (4 of the 5 us of a construction)
            self.lo, self.hi = lo, hi
            return
        lo = np.asarray(lo, dtype=float)
        hi = lo if hi is None else np.asarray(hi, dtype=float)
        self.lo, self.hi = np.broadcast_arrays(lo, hi)

    # ------------------------------------------------------------------ helpers
    @property
    def shape(self):
        return self.lo.shape

    @property
    def mid(self):
        return 0.5 * self.lo + 0.5 * self.hi

    @property
    def rad(self):
        """An upper bound of the radius (hi - lo) / 2."""
        return _up(0.5 * _up(self.hi - self.lo))

    @property
    def mag(self):
        """max |x| over the interval."""
        return np.maximum(np.abs(self.lo), np.abs(self.hi))

    def __getitem__(self, k):
        return Interval(self.lo[k], self.hi[k])

    def contains(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        return (self.lo <= x) & (x <= self.hi)

    def __repr__(self):
        return f"Interval({self.lo!r}, {self.hi!r})"

    @staticmethod
    def _of(x) -> "Interval":
        return x if isinstance(x, Interval) else Interval(x)

    # ------------------------------------------------------------------ arithmetic
    def __neg__(self):
        return Interval(-self.hi, -self.lo)

    def __add__(self, o):
        if getattr(o, "_is_dual", False):
            return NotImplemented
        o = Interval._of(o)
        return Interval(_down(self.lo + o.lo), _up(self.hi + o.hi))

    __radd__ = __add__

    def __sub__(self, o):
        if getattr(o, "_is_dual", False):
            return NotImplemented
        o = Interval._of(o)
        return Interval(_down(self.lo - o.hi), _up(self.hi - o.lo))

    def __rsub__(self, o):
        return Interval._of(o) - self

    def __mul__(self, o):
        if getattr(o, "_is_dual", False):
            return NotImplemented
        o = Interval._of(o)
        p = (self.lo * o.lo, self.lo * o.hi, self.hi * o.lo, self.hi * o.hi)
        lo = np.minimum(np.minimum(p[0], p[1]), np.minimum(p[2], p[3]))
        hi = np.maximum(np.maximum(p[0], p[1]), np.maximum(p[2], p[3]))
        return Interval(_down(lo), _up(hi))

    __rmul__ = __mul__

    def reciprocal(self):
        """1 / x; [-inf, inf] where the interval contains 0."""
        bad = (self.lo <= 0.0) & (self.hi >= 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            lo = np.where(bad, -_INF, _down(1.0 / self.hi))
            hi = np.where(bad, _INF, _up(1.0 / self.lo))
        return Interval(lo, hi)

    def __truediv__(self, o):
        if getattr(o, "_is_dual", False):
            return NotImplemented
        o = Interval._of(o)
        bad = (o.lo <= 0.0) & (o.hi >= 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            p = (self.lo / o.lo, self.lo / o.hi, self.hi / o.lo, self.hi / o.hi)
            lo = np.minimum(np.minimum(p[0], p[1]), np.minimum(p[2], p[3]))
            hi = np.maximum(np.maximum(p[0], p[1]), np.maximum(p[2], p[3]))
        return Interval(np.where(bad, -_INF, _down(lo)), np.where(bad, _INF, _up(hi)))

    def __rtruediv__(self, o):
        return Interval._of(o) / self

    def sqr(self):
        """x^2 (tighter than x * x: one variable)."""
        a, b = self.lo * self.lo, self.hi * self.hi
        hi = np.maximum(a, b)
        lo = np.where((self.lo <= 0.0) & (self.hi >= 0.0), 0.0, np.minimum(a, b))
        return Interval(np.maximum(_down(lo), 0.0), _up(hi))

    def sqrt(self):
        """sqrt(x) over the part x >= 0 (NaN bounds where hi < 0)."""
        with np.errstate(invalid="ignore"):
            lo = np.where(self.lo > 0.0, np.maximum(_down(np.sqrt(np.maximum(self.lo, 0.0))), 0.0), 0.0)
            hi = _up(np.sqrt(self.hi))
        return Interval(lo, hi)

    def __pow__(self, n):
        if n == 2:
            return self.sqr()
        if isinstance(n, int) and n >= 1:
            out = self
            for _ in range(n - 1):
                out = out * self
            return out
        raise ValueError("only positive integer powers of intervals")


def point(x) -> Interval:
    """The degenerate interval [x, x] of a float array."""
    return Interval(x, x)


def hull(*xs) -> Interval:
    """The smallest interval containing the given float arrays (widened 1 ulp)."""
    a = np.asarray(xs, dtype=float)
    return Interval(_down(a.min(axis=0)), _up(a.max(axis=0)))


def cos_point(x) -> Interval:
    """cos of float values, enclosed (libm accurate to < 1 ulp, widened by 4)."""
    c = np.cos(np.asarray(x, float))
    return _widen(c, 4)


def sin_point(x) -> Interval:
    s = np.sin(np.asarray(x, float))
    return _widen(s, 4)


def _widen(v, k: int) -> Interval:
    lo, hi = v, v
    for _ in range(k):
        lo, hi = _down(lo), _up(hi)
    return Interval(lo, hi)


def dot(a: list, b: list) -> Interval:
    """sum_k a_k b_k for lists of intervals (or floats)."""
    out = Interval._of(a[0]) * b[0]
    for x, y in zip(a[1:], b[1:]):
        out = out + Interval._of(x) * y
    return out


def norm_upper(mags) -> np.ndarray:
    """An upper bound of sqrt(sum m^2) for nonnegative float arrays (summed along axis 0 of the list)."""
    s = np.zeros_like(np.asarray(mags[0], float))
    for m in mags:
        s = _up(s + _up(m * m))
    return _up(np.sqrt(s))


_TWO_PI = 2.0 * np.pi
#: slack (rad) when asking whether an interval holds an extremum of cos or sin:
#: far above the rounding of k * 2 pi for the angles of a workspace (|x| < 1e3)
_EXT_TOL = 1e-9


def _has_point(lo, hi, offset):
    """Whether [lo, hi] (widened by _EXT_TOL) holds offset + 2 k pi for some integer k."""
    k = np.ceil((lo - _EXT_TOL - offset) / _TWO_PI)
    return offset + k * _TWO_PI <= hi + _EXT_TOL


def _trig(x: Interval, f, at_max: float, at_min: float) -> Interval:
    lo, hi = x.lo, x.hi
    a, b = f(lo), f(hi)
    mn, mx = _widen(np.minimum(a, b), 4).lo, _widen(np.maximum(a, b), 4).hi
    mx = np.where(_has_point(lo, hi, at_max), 1.0, mx)
    mn = np.where(_has_point(lo, hi, at_min), -1.0, mn)
    whole = ~(hi - lo < _TWO_PI) | ~np.isfinite(lo) | ~np.isfinite(hi)
    mn = np.where(whole, -1.0, np.maximum(mn, -1.0))
    mx = np.where(whole, 1.0, np.minimum(mx, 1.0))
    return Interval(mn, mx)


def cos(x: Interval) -> Interval:
    """cos over intervals: the end values widened by 4 ulps, and +-1 where the
    interval holds a multiple of pi (its extrema)."""
    return _trig(x, np.cos, 0.0, np.pi)


def sin(x: Interval) -> Interval:
    return _trig(x, np.sin, 0.5 * np.pi, -0.5 * np.pi)
