"""Typed, path-reporting access to the parsed YAML of a config: every mistake
becomes a :class:`ConfigError` whose message is one line naming the file, the
key path and what was expected.  The checks and the message helpers are the
package's one toolkit, :mod:`optdesign.checking` (re-exported here)."""
from __future__ import annotations

from typing import Any

from ..checking import SMALLEST, Checker, join, plain, shorten, show, suggest, tname
from ..mechanisms.params import UNIT_SCALES

__all__ = ["ConfigError", "Reader", "UNITS", "SMALLEST", "tname", "show", "shorten", "plain", "join", "suggest"]

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
class Reader(Checker):
    """Typed access to a nested mapping that reports the file and the key
    path on error (the checks are :class:`optdesign.checking.Checker`'s)."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, message: str):
        raise ConfigError(self.source, path, message)

    def unit(self, value: Any, path: str, allowed=("m", "mm", "rad", "deg")) -> str | None:
        if value is None:
            return None
        return self.string(value, path, choices=set(allowed))
