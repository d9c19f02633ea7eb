"""Typed, path-reporting access to the parsed YAML of a config: every mistake
becomes a :class:`ConfigError` whose message is one line naming the file, the
key path and what was expected."""
from __future__ import annotations

import math
import re
import reprlib
import sys
from typing import Any, Mapping

from ..mechanisms.params import UNIT_SCALES

__all__ = ["ConfigError", "Reader", "UNITS", "tname", "show", "shorten", "plain", "join", "suggest"]

#: every unit a config may write, and its factor to SI (None: SI as written)
UNITS = {**UNIT_SCALES, None: 1.0}


class ConfigError(ValueError):
    """A mistake in a configuration file (reported without a traceback)."""

    def __init__(self, source: str, path: str, message: str):
        self.source = source
        self.path = path
        self.message = message
        shown = path if len(path) <= 200 else f"{path[:120]}...{path[-60:]}"
        where = f"{source}: {shown}: " if path else f"{source}: "
        super().__init__(where + message)




# --------------------------------------------------------------------------- helpers
class Reader:
    """Typed access to a nested mapping that reports the key path on error."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, message: str):
        raise ConfigError(self.source, path, message)

    def mapping(self, value: Any, path: str) -> Mapping:
        if not isinstance(value, Mapping):
            self.fail(path, f"expected a mapping, got {tname(value)}")
        for k in value:
            if not isinstance(k, str):
                self.fail(path, f"expected string keys, got key {shorten(k)} ({tname(k)})")
        return value

    def only(self, value: Mapping, path: str, allowed) -> None:
        for k in value:
            if k not in allowed:
                self.fail(join(path, k), f"unknown key{suggest(k, allowed)}; expected one of {', '.join(sorted(allowed))}")

    def require(self, value: Mapping, key: str, path: str) -> Any:
        if key not in value:
            self.fail(join(path, key), "missing required key")
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
        if abs(x) > 1e12 or 0 < abs(x) < sys.float_info.min:   # huge, or subnormal (1e-320)
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
            self.fail(path, f"expected one of {', '.join(sorted(choices))}, got {shorten(value)}{suggest(value, choices)}")
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

    def unit(self, value: Any, path: str, allowed=("m", "mm", "rad", "deg")) -> str | None:
        if value is None:
            return None
        return self.string(value, path, choices=set(allowed))


#: the smallest positive physical value (a length, mass, stiffness ...) of sensible
#: size, as 1e12 is the largest; a subnormal number (below 2.2e-308, such as
#: 1e-320) is refused wherever a number is read
SMALLEST = 1e-12


def tname(v: Any) -> str:
    if v is None:
        return "nothing (null)"
    if isinstance(v, list):
        return f"a list of {len(v)} item{'s' if len(v) != 1 else ''}"
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "a list", dict: "a mapping"}.get(type(v), type(v).__name__)


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


def suggest(word: Any, choices) -> str:
    """'' or " (did you mean 'x'?)": the closest of ``choices`` to a mistyped word."""
    import difflib

    if not isinstance(word, str) or not word or len(word) > 200:
        return ""
    options = [c for c in choices if isinstance(c, str)]
    close = difflib.get_close_matches(word, options, n=1, cutoff=0.6)
    if not close:
        low = {c.lower(): c for c in options}
        close = [low[word.lower()]] if word.lower() in low else []
    return f" (did you mean {close[0]!r}?)" if close and close[0] != word else ""


_SEXAGESIMAL = re.compile(r"^[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?$")
_YAML11_BOOL = {"yes", "no", "on", "off", "y", "n"}


def _yaml11_hint(value: Any) -> str:
    """Why a string a YAML 1.1 reader would have turned into a number or a
    boolean is not one here (see optdesign.config.yamlsafe)."""
    if not isinstance(value, str):
        return ""
    v = value.strip()
    if _SEXAGESIMAL.match(v):
        return f" {shorten(value)} (sexagesimal numbers such as 1:30 are not read as numbers; write the value)"
    if v.lower() in _YAML11_BOOL:
        return f" {shorten(value)} (yes/no/on/off are strings here, not booleans; write true or false, or a number)"
    if re.match(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?$", v) and "_" in v:
        return f" {shorten(value)} (digits grouped with '_' are not read as a number; write them without)"
    return f" {shorten(value)}" if len(v) < 40 and re.match(r"^[-+0-9.eE]+$", v) else ""
