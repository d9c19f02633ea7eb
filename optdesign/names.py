"""Names that become parts of paths, and the check that a path stays inside
its output root.

Every name a user gives that ends up in a file or folder name (a config's
``name``, ``--name``, design names of atlas folders, index names of stage
folders and plot files, batch names) is checked by :func:`name_problem`:
one path component of at most :data:`MAX_NAME` characters from
``[A-Za-z0-9._-]``, not starting with ``.`` or ``-``, without ``..``.  Every
writer then resolves its target and checks with :func:`check_inside` that it
lies inside the output root it was given (``runs/``, ``indices/``, ``--out``),
so neither a name nor a symbolic link inside the root can take a write
elsewhere.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

__all__ = ["MAX_NAME", "name_problem", "safe_default_name", "OutsideRoot", "check_inside"]

#: the longest name allowed (a run folder adds about 40 characters to it)
MAX_NAME = 100
_ALLOWED = re.compile(r"[A-Za-z0-9._-]")
_NOT_ALLOWED = re.compile(r"[^A-Za-z0-9._-]")


def name_problem(value, max_len: int = MAX_NAME) -> str | None:
    """Why ``value`` cannot be a file or folder name, or None if it can
    (``max_len``: a longer limit for names made of a name and a suffix)."""
    if not isinstance(value, str):
        return f"expected a name (a string), got {type(value).__name__}"
    if not value:
        return "expected a non-empty name"
    if len(value) > max_len:
        return f"a name of {len(value):,} characters; expected at most {max_len}"
    bad = _NOT_ALLOWED.search(value)
    if bad:
        c = bad.group()
        shown = repr(c) if c.isprintable() and c != " " else ("a space" if c == " " else f"U+{ord(c):04X}")
        return (f"character {shown} is not allowed in a name (it becomes a folder or file name); "
                "use letters, digits, '.', '_' and '-'")
    if value[0] in ".-":
        return f"a name may not start with {value[0]!r}"
    if ".." in value:
        return "a name may not contain '..'"
    return None


def safe_default_name(text: str, fallback: str) -> str:
    """A valid name made from ``text`` (a file's stem): characters outside the
    safe set become '_', leading dots and dashes go, at most MAX_NAME characters."""
    name = _NOT_ALLOWED.sub("_", text).lstrip(".-")
    while ".." in name:
        name = name.replace("..", ".")
    name = name[:MAX_NAME]
    return name if name and name_problem(name) is None else fallback


class OutsideRoot(ValueError):
    """A write whose target would leave the chosen output root."""


def check_inside(root: str | os.PathLike, target: str | os.PathLike) -> Path:
    """``target`` resolved (symbolic links followed), if it lies inside
    ``root`` resolved; raises :class:`OutsideRoot` otherwise."""
    r = Path(root).resolve()
    t = Path(target)
    t = (t if t.is_absolute() else Path.cwd() / t).resolve()
    if t != r and r not in t.parents:
        raise OutsideRoot(f"{target} would be written outside {root}")
    return t
