"""Interval forward-mode derivatives, for mean-value forms.

A :class:`Dual` carries an enclosure ``v`` of a function over a box and
enclosures ``d[k]`` of its partial derivatives with respect to the box's
coordinates over the same box (``None``: the derivative is 0).  Running an
interval computation on duals seeded with the box's coordinates gives both;
the mean-value theorem then encloses the function over the box by

    f(box) ⊆ f(m) + sum_k d_k(box) (box_k - m_k),

whose excess over the true range shrinks quadratically with the box's
width (the natural interval extension's only linearly): :func:`mean_value`
intersects the two.
"""
from __future__ import annotations

import numpy as np

from . import interval as iv
from .interval import Interval

__all__ = ["Dual", "seed", "value", "mean_value", "cos", "sin"]


def _mul(a, b):
    if a is None or b is None:
        return None
    return a * b


def _add(a, b):
    if a is None:
        return b
    if b is None:
        return a
    return a + b


def _neg(a):
    return None if a is None else -a


class Dual:
    """An interval value ``v`` and its interval partials ``d`` (list, None = 0)."""

    __slots__ = ("v", "d")
    __array_priority__ = 1001
    _is_dual = True

    def __init__(self, v: Interval, d: list):
        self.v, self.d = v, d

    # the value's bounds (reach margins, branch signs, containment)
    @property
    def lo(self):
        return self.v.lo

    @property
    def hi(self):
        return self.v.hi

    def contains(self, x):
        return self.v.contains(x)

    def _lift(self, o) -> "Dual":
        if isinstance(o, Dual):
            return o
        return Dual(Interval._of(o), [None] * len(self.d))

    def __neg__(self):
        return Dual(-self.v, [_neg(a) for a in self.d])

    def __add__(self, o):
        o = self._lift(o)
        return Dual(self.v + o.v, [_add(a, b) for a, b in zip(self.d, o.d)])

    __radd__ = __add__

    def __sub__(self, o):
        o = self._lift(o)
        return Dual(self.v - o.v, [_add(a, _neg(b)) for a, b in zip(self.d, o.d)])

    def __rsub__(self, o):
        return self._lift(o) - self

    def __mul__(self, o):
        if not isinstance(o, Dual):       # a float or interval constant
            c = Interval._of(o)
            return Dual(self.v * c, [None if a is None else a * c for a in self.d])
        return Dual(self.v * o.v, [_add(_mul(a, o.v), _mul(self.v, b)) for a, b in zip(self.d, o.d)])

    __rmul__ = __mul__

    def __truediv__(self, o):
        o = self._lift(o)
        q = self.v / o.v
        inv = o.v.reciprocal()
        return Dual(q, [None if (a is None and b is None) else _mul(_add(a, _neg(_mul(q, b))), inv)
                        for a, b in zip(self.d, o.d)])

    def __rtruediv__(self, o):
        return self._lift(o) / self

    def sqr(self):
        two_v = self.v * 2.0
        return Dual(self.v.sqr(), [None if a is None else a * two_v for a in self.d])

    def sqrt(self):
        r = self.v.sqrt()
        half_inv = (r * 2.0).reciprocal()
        return Dual(r, [None if a is None else a * half_inv for a in self.d])


def seed(lo: np.ndarray, hi: np.ndarray, k: int, n: int) -> Dual:
    """The coordinate k of boxes (K,) as a dual over n coordinates."""
    d = [None] * n
    d[k] = Interval(np.ones_like(lo))
    return Dual(Interval(lo, hi), d)


def cos(x):
    if isinstance(x, Dual):
        s = iv.sin(x.v)
        return Dual(iv.cos(x.v), [None if a is None else -(a * s) for a in x.d])
    return iv.cos(x)


def sin(x):
    if isinstance(x, Dual):
        c = iv.cos(x.v)
        return Dual(iv.sin(x.v), [None if a is None else a * c for a in x.d])
    return iv.sin(x)


def value(x) -> Interval:
    return x.v if isinstance(x, Dual) else Interval._of(x)


def mean_value(at_box, at_mid, lo: np.ndarray, hi: np.ndarray) -> Interval:
    """The mean-value enclosure over boxes, intersected with the natural one.
    ``at_box``: the dual over the boxes; ``at_mid``: the interval (or dual)
    value at the midpoints (point boxes); lo, hi (K, n)."""
    nat = value(at_box)
    if not isinstance(at_box, Dual):
        return nat
    mid = 0.5 * lo + 0.5 * hi
    acc = value(at_mid)
    for k, a in enumerate(at_box.d):
        if a is None:
            continue
        acc = acc + a * (Interval(lo[:, k], hi[:, k]) - Interval(mid[:, k]))
    lo_ = np.maximum(nat.lo, acc.lo)
    hi_ = np.minimum(nat.hi, acc.hi)
    bad = ~(lo_ <= hi_)          # NaN bounds or an empty intersection (cannot happen in exact terms)
    return Interval(np.where(bad, nat.lo, lo_), np.where(bad, nat.hi, hi_))
