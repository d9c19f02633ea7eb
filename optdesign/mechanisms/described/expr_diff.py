"""Derivatives of expression trees (:mod:`.expr`): ``diff(tree, name)`` is the
tree of d tree / d name, by the rules of calculus (no numbers involved), so
a declared coordinate map of a pose (docs/lower-mobility.md) has exact first
and second derivatives.  ``abs`` has the derivative ``x / abs(x)`` (not
defined at 0); ``x ** y`` with y free of the name is ``y x ** (y - 1)``,
otherwise ``x ** y (y' log-free form)`` is refused (the language has no log).
"""
from __future__ import annotations

from .expr import names_of

__all__ = ["diff", "DiffError"]

_ZERO, _ONE = ("num", 0.0), ("num", 1.0)


class DiffError(ValueError):
    """An expression whose derivative the language cannot write."""


def _num(t):
    return t[0] == "num"


def _add(a, b):
    if _num(a) and a[1] == 0.0:
        return b
    if _num(b) and b[1] == 0.0:
        return a
    return ("bin", "+", a, b)


def _sub(a, b):
    if _num(b) and b[1] == 0.0:
        return a
    if _num(a) and a[1] == 0.0:
        return ("neg", b)
    return ("bin", "-", a, b)


def _mul(a, b):
    if (_num(a) and a[1] == 0.0) or (_num(b) and b[1] == 0.0):
        return _ZERO
    if _num(a) and a[1] == 1.0:
        return b
    if _num(b) and b[1] == 1.0:
        return a
    return ("bin", "*", a, b)


def _div(a, b):
    if _num(a) and a[1] == 0.0:
        return _ZERO
    return ("bin", "/", a, b)


def _call(f, *args):
    return ("call", f, tuple(args))


def diff(tree: tuple, name: str) -> tuple:
    """The tree of the derivative of ``tree`` with respect to ``name``."""
    if name not in names_of(tree):
        return _ZERO
    kind = tree[0]
    if kind == "name":
        return _ONE
    if kind == "neg":
        d = diff(tree[1], name)
        return _ZERO if _num(d) and d[1] == 0.0 else ("neg", d)
    if kind == "bin":
        op, a, b = tree[1], tree[2], tree[3]
        da, db = diff(a, name), diff(b, name)
        if op == "+":
            return _add(da, db)
        if op == "-":
            return _sub(da, db)
        if op == "*":
            return _add(_mul(da, b), _mul(a, db))
        if op == "/":
            return _div(_sub(_mul(da, b), _mul(a, db)), ("bin", "**", b, ("num", 2.0)))
        if name in names_of(b):
            raise DiffError("the derivative of x ** y with y depending on a coordinate needs a logarithm")
        return _mul(_mul(b, ("bin", "**", a, _sub(b, _ONE))), da)
    f, args = tree[1], tree[2]
    if f == "atan2":
        y, x = args
        dy, dx = diff(y, name), diff(x, name)
        den = _add(("bin", "**", x, ("num", 2.0)), ("bin", "**", y, ("num", 2.0)))
        return _div(_sub(_mul(x, dy), _mul(y, dx)), den)
    x = args[0]
    dx = diff(x, name)
    one_minus = _sub(_ONE, ("bin", "**", x, ("num", 2.0)))
    inner = {
        "sin": _call("cos", x),
        "cos": ("neg", _call("sin", x)),
        "tan": _add(_ONE, ("bin", "**", _call("tan", x), ("num", 2.0))),
        "asin": _div(_ONE, _call("sqrt", one_minus)),
        "acos": ("neg", _div(_ONE, _call("sqrt", one_minus))),
        "atan": _div(_ONE, _add(_ONE, ("bin", "**", x, ("num", 2.0)))),
        "sqrt": _div(("num", 0.5), _call("sqrt", x)),
        "abs": _div(x, _call("abs", x)),
        "deg": ("num", 3.141592653589793 / 180.0),
    }[f]
    return _mul(inner, dx)
