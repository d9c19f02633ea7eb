"""The safe expression language of mechanism descriptions.

An expression is a number or a string such as ``"R_b * cos(split_b / 2)"``.
Strings are parsed with Python's :mod:`ast` module into a small tree of
tuples and evaluated by :func:`evaluate`; user text is never given to
``eval``, ``exec`` or ``compile``.  The grammar:

* numbers (``0.25``, ``1e-3``), the constant ``pi`` and the names of the
  description's parameters;
* ``+ - * / **`` and unary ``-`` / ``+``, parentheses;
* calls of ``sin cos tan asin acos atan atan2 sqrt abs`` and ``deg`` (degrees
  to radians: ``deg(120)`` is ``120 * pi / 180``).

Anything else (attributes, subscripts, comparisons, keywords, strings,
lambdas ...) is a one-line error.  Expressions are bounded: at most
:data:`MAX_CHARS` characters, :data:`MAX_NODES` nodes and depth
:data:`MAX_DEPTH` (parentheses, calls, unary signs and operators of another
precedence nest; a chain such as ``a + b - c + d`` or ``a * b / c`` is one
level however long).

Trees are ``("num", v)``, ``("name", s)``, ``("neg", a)``,
``("bin", op, a, b)`` with op one of ``+ - * / **`` and
``("call", f, (args...))``.  :func:`evaluate` broadcasts with numpy (parameters
may be arrays, one entry per design) or, given ``lib=CASADI``, builds CasADi
expressions (the independent symbolic check).
"""
from __future__ import annotations

import ast
import math
import sys
from typing import Any, Mapping

import numpy as np

from ...checking import suggest

__all__ = ["ExprError", "parse", "evaluate", "names_of", "first_problem", "to_text", "FUNCTIONS",
           "MAX_CHARS", "MAX_NODES", "MAX_DEPTH"]

MAX_CHARS = 400
MAX_NODES = 200
MAX_DEPTH = 24

#: function name -> number of arguments
FUNCTIONS = {"sin": 1, "cos": 1, "tan": 1, "asin": 1, "acos": 1, "atan": 1, "atan2": 2, "sqrt": 1,
             "abs": 1, "deg": 1}
CONSTANTS = {"pi": math.pi}
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
#: precedence levels: a left-associative chain within one level counts as one level of nesting
_LEVEL = {ast.Add: "+", ast.Sub: "+", ast.Mult: "*", ast.Div: "*", ast.Pow: "**"}


class ExprError(ValueError):
    """A bad expression; the message is one line (the caller adds the key)."""


def _show(text: str) -> str:
    t = " ".join(str(text).split())
    return repr(t if len(t) <= 60 else t[:57] + "...")


def parse(value: Any, names) -> tuple:
    """The tree of an expression (a number or a string) whose names must be in
    ``names`` (an iterable of the allowed parameter names)."""
    if isinstance(value, bool) or value is None:
        raise ExprError(f"expected a number or an expression, got {'a boolean' if isinstance(value, bool) else 'nothing (null)'}")
    if isinstance(value, (int, float)):
        try:
            x = float(value)
        except OverflowError:
            raise ExprError("expected a number of sensible size") from None
        if not math.isfinite(x) or abs(x) > 1e12 or 0 < abs(x) < sys.float_info.min:
            raise ExprError(f"expected a finite number of sensible size, got {value!r}")
        return ("num", x)
    if not isinstance(value, str):
        kind = "a list" if isinstance(value, (list, tuple)) else "a mapping" if isinstance(value, Mapping) else type(value).__name__
        raise ExprError(f"expected a number or an expression, got {kind}")
    text = value.strip()
    if not text:
        raise ExprError("empty expression")
    if len(text) > MAX_CHARS:
        raise ExprError(f"expression longer than {MAX_CHARS} characters")
    if "\x00" in text:
        raise ExprError("expression contains a NUL character")
    try:
        node = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ExprError(f"not a valid expression: {_show(text)} ({exc.msg})") from None
    except (RecursionError, MemoryError, ValueError):
        raise ExprError(f"expression too deeply nested: {_show(text)}") from None
    allowed = set(names)
    count = [0]
    return _convert(node.body, text, allowed, count, 0)


def _convert(node, text: str, allowed: set, count: list, depth: int) -> tuple:
    count[0] += 1
    if count[0] > MAX_NODES:
        raise ExprError(f"expression has more than {MAX_NODES} terms: {_show(text)}")
    if depth > MAX_DEPTH:
        raise ExprError(f"expression nested deeper than {MAX_DEPTH} levels: {_show(text)}")
    if isinstance(node, ast.Constant):
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ExprError(f"unexpected {type(v).__name__} {v!r} in {_show(text)}; expected numbers and names")
        try:
            x = float(v)
        except OverflowError:
            raise ExprError(f"number too large in {_show(text)}") from None
        if not math.isfinite(x) or abs(x) > 1e12:
            raise ExprError(f"number too large in {_show(text)}")
        if 0 < abs(x) < sys.float_info.min:
            raise ExprError(f"subnormal number (below 2.2e-308) in {_show(text)}")
        return ("num", x)
    if isinstance(node, ast.Name):
        if node.id in CONSTANTS:
            return ("num", CONSTANTS[node.id])
        if node.id in allowed:
            return ("name", node.id)
        if node.id in FUNCTIONS:
            raise ExprError(f"function {node.id!r} used without arguments in {_show(text)}")
        hint = suggest(node.id, sorted(allowed | set(CONSTANTS))) or (
            f"; expected one of {', '.join(sorted(allowed))}" if allowed and len(allowed) <= 12 else "")
        raise ExprError(f"unknown name {node.id!r} in {_show(text)}{hint}")
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        a = _convert(node.operand, text, allowed, count, depth + 1)
        if isinstance(node.op, ast.UAdd):
            return a
        return ("num", -a[1]) if a[0] == "num" else ("neg", a)
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        # a chain of one precedence level (a + b - c + ..., a * b / c ...) is flat:
        # Python parses it left-associatively, so its left operand does not nest deeper
        flat = isinstance(node.left, ast.BinOp) and _LEVEL.get(type(node.left.op)) == _LEVEL.get(type(node.op)) != "**"
        a = _convert(node.left, text, allowed, count, depth + (0 if flat else 1))
        b = _convert(node.right, text, allowed, count, depth + 1)
        return ("bin", _BINOPS[type(node.op)], a, b)
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            fname = node.func.id if isinstance(node.func, ast.Name) else None
            hint = suggest(fname, sorted(FUNCTIONS)) or f"; expected one of {', '.join(sorted(FUNCTIONS))}"
            what = f"unknown function {fname!r}" if fname else "only plain function calls are allowed"
            raise ExprError(f"{what} in {_show(text)}{hint}")
        if node.keywords:
            raise ExprError(f"keyword arguments are not allowed in {_show(text)}")
        n = FUNCTIONS[node.func.id]
        if len(node.args) != n or any(isinstance(a, ast.Starred) for a in node.args):
            raise ExprError(f"{node.func.id} takes {n} argument{'s' if n > 1 else ''}, got {len(node.args)} in {_show(text)}")
        args = tuple(_convert(a, text, allowed, count, depth + 1) for a in node.args)
        return ("call", node.func.id, args)
    what = {ast.Attribute: "attribute access", ast.Subscript: "indexing", ast.Compare: "a comparison",
            ast.BoolOp: "a boolean operator", ast.Lambda: "a lambda", ast.IfExp: "a conditional",
            ast.Tuple: "a tuple", ast.List: "a list"}.get(type(node), type(node).__name__)
    if isinstance(node, ast.BinOp):
        what = f"the operator {type(node.op).__name__}"
    if isinstance(node, ast.UnaryOp):
        what = f"the operator {type(node.op).__name__}"
    raise ExprError(f"{what} is not allowed in {_show(text)}; expected arithmetic (+ - * / **), numbers, names and {', '.join(sorted(FUNCTIONS))}")


def names_of(tree: tuple) -> set:
    """The parameter names an expression uses."""
    kind = tree[0]
    if kind == "name":
        return {tree[1]}
    if kind == "num":
        return set()
    if kind == "neg":
        return names_of(tree[1])
    if kind == "bin":
        return names_of(tree[2]) | names_of(tree[3])
    out = set()
    for a in tree[2]:
        out |= names_of(a)
    return out


class _Numpy:
    sin, cos, tan = np.sin, np.cos, np.tan
    asin, acos, atan, atan2 = np.arcsin, np.arccos, np.arctan, np.arctan2
    sqrt, abs = np.sqrt, np.abs

    @staticmethod
    def deg(x):
        return x * (np.pi / 180.0)

    @staticmethod
    def asarray(x):
        return np.asarray(x, dtype=float)

    number = np.float64   # numpy's arithmetic (inf, not OverflowError)


NUMPY = _Numpy()


def _casadi_lib():
    import casadi as ca

    class _Casadi:
        sin, cos, tan = ca.sin, ca.cos, ca.tan
        asin, acos, atan, atan2 = ca.asin, ca.acos, ca.atan, ca.atan2
        sqrt, abs = ca.sqrt, ca.fabs

        @staticmethod
        def deg(x):
            return x * (np.pi / 180.0)

        @staticmethod
        def asarray(x):
            return x

        @staticmethod
        def number(x):
            return x

    return _Casadi()


def casadi_lib():
    """The function table that turns trees into CasADi expressions."""
    return _casadi_lib()


def evaluate(tree: tuple, env: Mapping[str, Any], lib=NUMPY):
    """The value of a tree with the names bound in ``env`` (numpy: arrays that
    broadcast; the result has their broadcast shape, a float for none)."""
    kind = tree[0]
    if kind == "num":
        return lib.number(tree[1])
    if kind == "name":
        return lib.asarray(env[tree[1]])
    if kind == "neg":
        return -evaluate(tree[1], env, lib)
    if kind == "bin":
        a = evaluate(tree[2], env, lib)
        b = evaluate(tree[3], env, lib)
        op = tree[1]
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            return a / b
        return a ** b
    f = getattr(lib, tree[1])
    return f(*(evaluate(a, env, lib) for a in tree[2]))


def first_problem(tree: tuple, env: Mapping[str, float]) -> str | None:
    """For scalar parameters: why the expression is not finite (the innermost
    failing operation, e.g. ``division by zero in 'R / (a - b)'``), or None."""
    with np.errstate(all="ignore"):
        return _problem(tree, env)[1]


def _problem(tree, env):
    kind = tree[0]
    if kind == "num":
        return tree[1], None
    if kind == "name":
        v = float(np.asarray(env[tree[1]], dtype=float))
        return v, (None if math.isfinite(v) else f"parameter {tree[1]!r} is not finite")
    if kind == "neg":
        v, p = _problem(tree[1], env)
        return -v, p
    if kind == "bin":
        a, pa = _problem(tree[2], env)
        if pa:
            return a, pa
        b, pb = _problem(tree[3], env)
        if pb:
            return b, pb
        op = tree[1]
        txt = _show(to_text(tree))
        if op == "/" and b == 0.0:
            return math.nan, f"division by zero in {txt}"
        if op == "**":
            if a == 0.0 and b < 0:
                return math.nan, f"zero to a negative power in {txt}"
            if a < 0 and b != math.floor(b):
                return math.nan, f"negative number to a fractional power in {txt}"
        v = float(evaluate(("bin", op, ("num", a), ("num", b)), {}))
        return v, (None if math.isfinite(v) else f"overflow in {txt}")
    args = []
    for t in tree[2]:
        v, p = _problem(t, env)
        if p:
            return v, p
        args.append(v)
    f = tree[1]
    txt = _show(to_text(tree))
    if f == "sqrt" and args[0] < 0:
        return math.nan, f"square root of a negative number ({args[0]:.6g}) in {txt}"
    if f in ("asin", "acos") and abs(args[0]) > 1:
        return math.nan, f"{f} of {args[0]:.6g} (outside [-1, 1]) in {txt}"
    v = float(getattr(NUMPY, f)(*args))
    return v, (None if math.isfinite(v) else f"{f} is not finite in {txt}")


_PREC = {"+": 1, "-": 1, "*": 2, "/": 2, "**": 4}


def to_text(tree: tuple, parent: int = 0) -> str:
    """The expression as text (for messages)."""
    kind = tree[0]
    if kind == "num":
        v = tree[1]
        s = "pi" if v == math.pi else "-pi" if v == -math.pi else repr(v)
        return f"({s})" if v < 0 and parent else s
    if kind == "name":
        return tree[1]
    if kind == "neg":
        s = "-" + to_text(tree[1], 3)
        return f"({s})" if parent >= 3 else s
    if kind == "bin":
        p = _PREC[tree[1]]
        s = f"{to_text(tree[2], p)} {tree[1]} {to_text(tree[3], p + (0 if tree[1] == '**' else 1))}"
        return f"({s})" if p < parent or (p == parent and tree[1] == "**") else s
    return f"{tree[1]}({', '.join(to_text(a) for a in tree[2])})"
