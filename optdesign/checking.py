"""The one validation toolkit: typed checks of parsed YAML whose mistakes are
one line naming the key path, the constraints a key table declares, and the
one "did you mean".

Configs (:mod:`optdesign.config.reader`) and mechanism descriptions
(:mod:`optdesign.mechanisms.described.schema`) both check with a
:class:`Checker`, so they say the same thing the same way::

    optimizer.population: expected an integer >= 4, got 3
    optimizer.sed: unknown key (did you mean 'seed'?); expected one of ...
    mechanism.legs[0].kind: unknown leg kind 'strutt' (did you mean 'strut'?); expected one of ...

A :class:`Checker` reports through :meth:`Checker.fail`, which each user
overrides to raise its own error (a ConfigError naming the file, a
DescriptionError).  This module imports nothing else of the package (a
bottom module, see tests/test_architecture.py).
"""
from __future__ import annotations

import difflib
import math
import re
import reprlib
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["LARGEST", "SMALLEST", "CheckError", "Checker", "Interval", "Options", "closest", "join", "listing",
           "plain", "shorten", "show", "suggest", "tname"]

#: the smallest positive physical value (a length, mass, stiffness ...) of sensible
#: size, as LARGEST is the largest; a subnormal number (below 2.2e-308, such as
#: 1e-320) is refused wherever a number is read
SMALLEST = 1e-12
LARGEST = 1e12


# --------------------------------------------------------------------------- did you mean
def closest(word: Any, choices, cutoff: float = 0.6) -> str | None:
    """The one of ``choices`` closest to a mistyped ``word`` (difflib's ratio
    at least ``cutoff``, or the same word in another case), or None."""
    if not isinstance(word, str) or not word or len(word) > 200:
        return None
    options = [c for c in choices if isinstance(c, str)]
    close = difflib.get_close_matches(word, options, n=1, cutoff=cutoff)
    if not close:
        low = {c.lower(): c for c in options}
        close = [low[word.lower()]] if word.lower() in low else []
    return close[0] if close and close[0] != word else None


def suggest(word: Any, choices, cutoff: float = 0.6) -> str:
    """'' or " (did you mean 'x'?)": the package's one wording of the hint."""
    c = closest(word, choices, cutoff)
    return f" (did you mean {c!r}?)" if c else ""


# --------------------------------------------------------------------------- values in messages
def tname(v: Any) -> str:
    """What a value is, for a message: 'a string', 'a list of 3 items', ..."""
    if v is None:
        return "nothing (null)"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, (list, tuple)):
        return f"a list of {len(v)} item{'s' if len(v) != 1 else ''}"
    if isinstance(v, Mapping):
        return "a mapping"
    return {int: "an integer", float: "a number", str: "a string"}.get(type(v), type(v).__name__)


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxtuple, _REPR.maxdict = 2, 4, 4, 4
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = 48, 48, 24


def shorten(v: Any, limit: int = 60) -> str:
    """A user's value for a message: a bounded repr (strings, lists and
    mappings cut with '...', integers too long to print described), never
    more than about ``limit`` characters and never a raw control character."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10 ** 15:
        return f"an integer of about {int(abs(v).bit_length() * 0.30103) + 1} digits"
    if isinstance(v, str):
        r = repr(v[:limit])
        return r if len(v) <= limit else f"{r[:-1]}...{r[-1]} ({len(v):,} characters)"
    try:
        r = _REPR.repr(v)
    except Exception:  # noqa: BLE001 - a value whose repr fails
        return tname(v)
    return r if len(r) <= 2 * limit else f"{r[:2 * limit]}..."


#: the name the messages use (one helper that shortens)
show = shorten


def plain(v: Any, limit: int = 100) -> str:
    """A name or path for a message: as it is if it is a short printable
    string, otherwise escaped and shortened (see :func:`shorten`)."""
    if isinstance(v, str) and v.isprintable() and len(v) <= limit:
        return v
    if isinstance(v, str) and v.isprintable():
        return f"{v[:limit]}... ({len(v):,} characters)"
    if isinstance(v, str):
        r = repr(v[:limit])[1:-1]
        return r if len(v) <= limit else f"{r}... ({len(v):,} characters)"
    return shorten(v, limit)


def join(path: str, key) -> str:
    """``path.key`` (``path[i]`` for a list index); a key that is long or not
    printable appears shortened and escaped, so a key path is always one short line."""
    if isinstance(key, int) and not isinstance(key, bool):
        return f"{path}[{key}]"
    key = plain(key)
    return f"{path}.{key}" if path else key


def listing(choices) -> str:
    """'a, b, c': a set sorted, any other collection in its own order."""
    items = sorted(choices) if isinstance(choices, (set, frozenset)) else list(choices)
    return ", ".join(str(c) for c in items)


def _g(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


# --------------------------------------------------------------------------- constraints
@dataclass(frozen=True)
class Interval:
    """A range of numbers, as scikit-learn's ``Interval``: ``low`` .. ``high``
    (None: unbounded), ``closed`` one of "both", "left", "right", "neither";
    ``what`` names the quantity in the message ("a probability": "expected a
    probability in [0, 1], got 1.5"); ``also``: one value allowed outside the
    range, with its meaning (``(0, "no integrals")``)."""

    low: float | None = None
    high: float | None = None
    closed: str = "both"
    what: str | None = None
    also: tuple | None = None

    def contains(self, x: float) -> bool:
        if self.also is not None and x == self.also[0]:
            return True
        lo_ok = self.low is None or (x >= self.low if self.closed in ("both", "left") else x > self.low)
        hi_ok = self.high is None or (x <= self.high if self.closed in ("both", "right") else x < self.high)
        return lo_ok and hi_ok

    def text(self) -> str:
        """'[0, 0.5)', or '> 0', '>= 0'."""
        if self.high is None:
            return f"{'>=' if self.closed in ('both', 'left') else '>'} {_g(self.low)}"
        if self.low is None:
            return f"{'<=' if self.closed in ('both', 'right') else '<'} {_g(self.high)}"
        return (f"{'[' if self.closed in ('both', 'left') else '('}{_g(self.low)}, {_g(self.high)}"
                f"{']' if self.closed in ('both', 'right') else ')'}")

    def problem(self, x: float) -> str | None:
        """The message of a value outside (after the type check), or None."""
        if self.contains(x):
            return None
        also = f"{_g(self.also[0])} ({self.also[1]}) or " if self.also is not None else ""
        return f"expected {also}{self.what or 'a number'} in {self.text()}, got {shorten(x)}"

    def outside(self, integer: bool = False) -> tuple:
        """Values just outside the range (the invalid values a test tries)."""
        eps = 1 if integer else 1e-9
        out = []
        if self.low is not None:
            if self.closed not in ("both", "left"):
                out += [self.low, self.low - 1]
            elif not integer and self.low > 0:
                out.append(self.low / 2)
            else:
                out.append(self.low - eps)
            if self.also is not None:
                out.append(self.also[0] - (1 if integer else 1e-3))
        if self.high is not None:
            out.append(self.high + eps if self.closed in ("both", "right") else self.high)
        return tuple(out)


@dataclass(frozen=True)
class Options:
    """The allowed strings (scikit-learn's ``StrOptions``), in the order the docs list them."""

    values: tuple

    def __init__(self, values):
        object.__setattr__(self, "values", tuple(values))


# --------------------------------------------------------------------------- the checker
class CheckError(ValueError):
    """A mistake found by a plain :class:`Checker` (its users raise their own)."""

    def __init__(self, path: str, message: str):
        self.path, self.message = path, message
        super().__init__(f"{path}: {message}" if path else message)


class Checker:
    """Typed access to a nested mapping that reports the key path on error;
    override :meth:`fail` to raise the error of the caller."""

    def fail(self, path: str, message: str):
        raise CheckError(path, message)

    def mapping(self, value: Any, path: str) -> Mapping:
        if not isinstance(value, Mapping):
            self.fail(path, f"expected a mapping, got {tname(value)}")
        for k in value:
            if not isinstance(k, str):
                self.fail(path, f"expected string keys, got key {shorten(k)} ({tname(k)})")
        return value

    def only(self, value: Mapping, path: str, allowed, what: str = "key") -> None:
        for k in value:
            if k not in allowed:
                self.fail(join(path, k), f"unknown {what}{suggest(k, allowed)}; expected one of {listing(set(allowed))}")

    def require(self, value: Mapping, key: str, path: str, why: str = "", null_is_missing: bool = False) -> Any:
        """``value[key]``; when it is missing, a key that looks mistyped for it
        is named instead (``rodd: unknown key (did you mean 'rod'?); 'rod' is required here``)."""
        if key not in value or (null_is_missing and value[key] is None):
            if key not in value:
                for k in value:
                    if isinstance(k, str) and closest(k, [key], cutoff=0.7):
                        self.fail(join(path, k), f"unknown key{suggest(k, [key], 0.7)}; {key!r} is required here")
            self.fail(join(path, key), "missing required key" + (f" ({why})" if why else ""))
        return value[key]

    def number(self, value: Any, path: str, *, positive=False, nonneg=False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"expected a number, got {tname(value)}{_yaml11_hint(value)}")
        try:
            x = float(value)
        except OverflowError:  # an integer beyond the float range
            self.fail(path, f"expected a number of sensible size, got {show(value)}")
        if not math.isfinite(x):
            self.fail(path, f"expected a finite number, got {shorten(value)}")
        if abs(x) > LARGEST or 0 < abs(x) < sys.float_info.min:   # huge, or subnormal (1e-320)
            self.fail(path, f"expected a number of sensible size, got {show(value)}")
        if positive and x <= 0:
            self.fail(path, f"expected a positive number, got {shorten(value)}")
        if positive and x < SMALLEST:
            self.fail(path, f"expected a positive number of sensible size (at least {SMALLEST:g}), got {show(value)}")
        if nonneg and x < 0:
            self.fail(path, f"expected a non-negative number, got {shorten(value)}")
        return x

    def integer(self, value: Any, path: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(path, f"expected an integer, got {tname(value)}{_yaml11_hint(value)}")
        if minimum is not None and value < minimum:
            self.fail(path, f"expected an integer >= {minimum}, got {show(value)}")
        if maximum is not None and value > maximum:
            self.fail(path, f"expected an integer <= {maximum}, got {show(value)}")
        return int(value)

    def string(self, value: Any, path: str, choices=None) -> str:
        if not isinstance(value, str):
            self.fail(path, f"expected a string, got {tname(value)}")
        if choices is not None and value not in choices:
            self.fail(path, f"expected one of {listing(set(choices))}, got {shorten(value)}{suggest(value, choices)}")
        return value

    def choice(self, value: Any, path: str, choices, what: str) -> str:
        """One of ``choices`` named as a kind of thing: ``unknown leg kind 'x'
        (did you mean 'y'?); expected one of ...`` (``choices`` in their order)."""
        if not isinstance(value, str) or value not in choices:
            self.fail(path, f"unknown {what} {shorten(value)}{suggest(value, choices)}; expected one of {listing(choices)}")
        return value

    def boolean(self, value: Any, path: str) -> bool:
        if not isinstance(value, bool):
            self.fail(path, f"expected true or false, got {tname(value)}{_yaml11_hint(value)}")
        return value

    def pair(self, value: Any, path: str, *, scale=1.0, positive=False) -> tuple[float, float]:
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            self.fail(path, f"expected a list [lower, upper], got {tname(value)}")
        lo = self.number(value[0], join(path, 0), positive=positive) * scale
        hi = self.number(value[1], join(path, 1), positive=positive) * scale
        if lo > hi:
            self.fail(path, f"lower {value[0]} is above upper {value[1]}")
        return lo, hi

    def in_interval(self, value: Any, path: str, interval: Interval, integer: bool = False):
        """A number (an integer if ``integer``) inside ``interval``: an
        integer range reads as ``expected an integer >= 4``; a half-line from
        0 as a positive or non-negative number; any other range in one message
        (``expected a probability in [0, 1], got 1.5``)."""
        iv = interval
        if integer:
            if iv.what is None and iv.also is None and iv.closed == "both":
                return self.integer(value, path, minimum=iv.low, maximum=iv.high)
            x = self.integer(value, path)
        elif iv.what is None and iv.also is None and iv.high is None and iv.low == 0:
            return self.number(value, path, positive=iv.closed in ("neither", "right"),
                               nonneg=iv.closed in ("both", "left"))
        else:
            x = self.number(value, path)
        problem = iv.problem(x)
        if problem:
            self.fail(path, problem)
        return x


_SEXAGESIMAL = re.compile(r"^[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?$")
_YAML11_BOOL = {"yes", "no", "on", "off", "y", "n"}


def _yaml11_hint(value: Any) -> str:
    """The string itself after its type ("got a string 'abc'"), and why a
    string a YAML 1.1 reader would have turned into a number or a boolean is
    not one here (see optdesign.config.yamlsafe)."""
    if not isinstance(value, str):
        return ""
    v = value.strip()
    if _SEXAGESIMAL.match(v):
        return f" {shorten(value)} (sexagesimal numbers such as 1:30 are not read as numbers; write the value)"
    if v.lower() in _YAML11_BOOL:
        return f" {shorten(value)} (yes/no/on/off are strings here, not booleans; write true or false, or a number)"
    if re.match(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?$", v) and "_" in v:
        return f" {shorten(value)} (digits grouped with '_' are not read as a number; write them without)"
    return f" {shorten(value)}"
