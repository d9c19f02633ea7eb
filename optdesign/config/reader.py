"""Typed, path-reporting access to the parsed YAML of a config: every mistake
becomes a :class:`ConfigError` whose message is one line naming the file, the
key path and what was expected."""
from __future__ import annotations

import math
from typing import Any, Mapping

from ..mechanisms.params import UNIT_SCALES

__all__ = ["ConfigError", "Reader", "UNITS", "tname", "show", "join"]

#: every unit a config may write, and its factor to SI (None: SI as written)
UNITS = {**UNIT_SCALES, None: 1.0}


class ConfigError(ValueError):
    """A mistake in a configuration file (reported without a traceback)."""

    def __init__(self, source: str, path: str, message: str):
        self.source = source
        self.path = path
        self.message = message
        where = f"{source}: {path}: " if path else f"{source}: "
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
                self.fail(path, f"expected string keys, got key {k!r} ({tname(k)})")
        return value

    def only(self, value: Mapping, path: str, allowed) -> None:
        for k in value:
            if k not in allowed:
                self.fail(join(path, k), f"unknown key; expected one of {', '.join(sorted(allowed))}")

    def require(self, value: Mapping, key: str, path: str) -> Any:
        if key not in value:
            self.fail(join(path, key), "missing required key")
        return value[key]

    def number(self, value: Any, path: str, *, positive=False, nonneg=False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"expected a number, got {tname(value)}")
        try:
            x = float(value)
        except OverflowError:  # an integer beyond the float range
            self.fail(path, f"expected a number of sensible size, got {show(value)}")
        if not math.isfinite(x):
            self.fail(path, f"expected a finite number, got {value!r}")
        if abs(x) > 1e12:
            self.fail(path, f"expected a number of sensible size, got {show(value)}")
        if positive and x <= 0:
            self.fail(path, f"expected a positive number, got {value!r}")
        if nonneg and x < 0:
            self.fail(path, f"expected a non-negative number, got {value!r}")
        return x

    def integer(self, value: Any, path: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(path, f"expected an integer, got {tname(value)}")
        if minimum is not None and value < minimum:
            self.fail(path, f"expected an integer >= {minimum}, got {show(value)}")
        if maximum is not None and value > maximum:
            self.fail(path, f"expected an integer <= {maximum}, got {show(value)}")
        return int(value)

    def string(self, value: Any, path: str, choices=None) -> str:
        if not isinstance(value, str):
            self.fail(path, f"expected a string, got {tname(value)}")
        if choices is not None and value not in choices:
            self.fail(path, f"expected one of {', '.join(sorted(choices))}, got {value!r}")
        return value

    def boolean(self, value: Any, path: str) -> bool:
        if not isinstance(value, bool):
            self.fail(path, f"expected true or false, got {tname(value)}")
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


def tname(v: Any) -> str:
    if v is None:
        return "nothing (null)"
    if isinstance(v, list):
        return f"a list of {len(v)} item{'s' if len(v) != 1 else ''}"
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "a list", dict: "a mapping"}.get(type(v), type(v).__name__)


def show(v: Any) -> str:
    """repr of a value for a message; integers too long to print are described."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10 ** 15:
        return f"an integer of about {int(abs(v).bit_length() * 0.30103) + 1} digits"
    return repr(v)


def join(path: str, key) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)
