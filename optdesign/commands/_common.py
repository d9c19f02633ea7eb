"""Helpers shared by the subcommands."""
from __future__ import annotations

import os
import stat
from typing import Sequence

from ..config import Config, load_config

PACKAGED_PAPER_CONFIG = "p4s_paper.yaml"


class UsageError(Exception):
    """A mistake in the command line (exit status 2, one line)."""


def check_name_option(value: str | None, option: str) -> None:
    """A name given on the command line that becomes part of a folder name."""
    from ..config.reader import shorten
    from ..names import name_problem

    if value is None:
        return
    problem = name_problem(value)
    if problem:
        raise UsageError(f"{option}: {problem}, got {shorten(value)}")


def check_out_root(path: str, option: str = "--out") -> None:
    """An output root that exists must be a folder, and so must every existing
    folder above it; nothing is created here (see :func:`make_out_root`)."""
    from pathlib import Path

    from ..config.reader import plain, shorten

    p = Path(path)
    if not path or "\x00" in path:
        raise UsageError(f"{option}: expected a folder, got {shorten(path)}")
    for q in (p, *p.parents):
        try:
            st = os.stat(q)          # follows links; a link loop or too long a name raises
        except (FileNotFoundError, NotADirectoryError):
            continue
        except OSError as exc:
            raise UsageError(f"{option}: cannot use {plain(path)} ({exc.strerror or type(exc).__name__})") from None
        if not stat.S_ISDIR(st.st_mode):
            what = "is not a folder" if q == p else f"lies under {plain(str(q))}, which is not a folder"
            raise UsageError(f"{option}: {plain(path)} {what}")


def check_out_file(path: str, option: str = "--out", suffixes=(".html", ".htm"), kind: str = "HTML") -> None:
    """An output file given on the command line: named ``*<suffix>``, in an
    existing folder, and, if it exists, a regular file (never a symbolic link,
    which is not followed) that already holds ``kind`` (an HTML page starts with
    ``<!DOCTYPE html`` or ``<html``), so that nothing else is ever overwritten."""
    from pathlib import Path

    from ..config.reader import plain, shorten

    if not path or "\x00" in path:
        raise UsageError(f"{option}: expected a file name ending in {suffixes[0]}, got {shorten(path)}")
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise UsageError(f"{option}: expected a file name ending in {suffixes[0]}, got {shorten(path)}")
    try:
        st = os.lstat(p)
    except (FileNotFoundError, NotADirectoryError):
        st = None
    except OSError as exc:
        raise UsageError(f"{option}: cannot use {plain(path)} ({exc.strerror or type(exc).__name__})") from None
    if st is not None:
        if stat.S_ISLNK(st.st_mode):
            raise UsageError(f"{option}: {plain(path)} is a symbolic link; refusing to write through or over it")
        if stat.S_ISDIR(st.st_mode):
            raise UsageError(f"{option}: {plain(path)} is a folder; expected an {kind} file")
        if not stat.S_ISREG(st.st_mode):
            raise UsageError(f"{option}: {plain(path)} exists and is not a regular file")
        if kind == "HTML" and st.st_size:
            fd = os.open(p, os.O_RDONLY | os.O_NOFOLLOW | getattr(os, "O_NONBLOCK", 0))
            try:
                head = os.read(fd, 512)
            finally:
                os.close(fd)
            start = head.lstrip(b"\xef\xbb\xbf \t\r\n").lower()
            if not (start.startswith(b"<!doctype html") or start.startswith(b"<html")):
                raise UsageError(f"{option}: {plain(path)} exists and is not an HTML page; refusing to overwrite it")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"{option}: {plain(str(parent))}: no such folder")


def make_out_root(path: str, option: str = "--out") -> None:
    """Create the output root (just before the first write)."""
    from pathlib import Path

    from ..config.reader import plain

    check_out_root(path, option)
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{option}: cannot make the folder {plain(path)} "
                         f"({exc.strerror or type(exc).__name__})") from None


def add_config_arg(p, optional: bool = False):
    if optional:
        p.add_argument("config", nargs="?", default=None,
                       help="YAML config (default: the embedded configs/p4s_paper.yaml)")
    else:
        p.add_argument("config", help="YAML config file")


def open_config(path: str | None) -> Config:
    """Load a config; ``None`` loads the embedded paper config."""
    if path is None:
        from importlib.resources import as_file, files

        with as_file(files("optdesign") / "data" / PACKAGED_PAPER_CONFIG) as p:
            cfg = load_config(p)
        cfg.source = f"configs/{PACKAGED_PAPER_CONFIG}"
        return cfg
    return load_config(path)


def design_names(cfg: Config, requested: Sequence[str] | None) -> list[str]:
    if not requested:
        return [n for n in cfg.designs if n != "initial" or len(cfg.designs) == 1]
    from ..config.reader import shorten, suggest

    for n in requested:
        if n not in cfg.designs:
            raise UsageError(f"{cfg.source}: designs: no design named {shorten(n)}{suggest(n, cfg.designs)}; "
                             f"the config has {', '.join(cfg.designs)}")
    return list(requested)


def json_text(obj) -> str:
    """Strict JSON (a number that is not finite becomes null) for ``--json``."""
    import json
    import math

    def clean(o):
        if isinstance(o, float) and not math.isfinite(o):
            return None
        if isinstance(o, dict):
            return {str(k): clean(v) for k, v in o.items()}
        if isinstance(o, (list, tuple)):
            return [clean(v) for v in o]
        if isinstance(o, (str, int, float, bool)) or o is None:
            return o
        return str(o)

    return json.dumps(clean(obj), indent=2, allow_nan=False)


# ---------------------------------------------------------------------- designs that reach nothing
def unreachable_message(config, name: str) -> str:
    """The one line for a named design that reaches no point of W, with a hint
    when a length of it was written without a unit and is implausibly large in m."""
    from ..evaluate import mechanism_class

    msg = f"no pose of W is reachable for design {name!r}"
    cls = mechanism_class(config)
    design = config.design(name)
    big = [k for k in cls.length_parameters if k in design and design[k] > 10.0
           and getattr(config.design_variables.get(k), "unit", None) is None]
    if big:
        k = big[0]
        return (f"{msg}; are the values in m? ({k} = {design[k]:g} m); write the unit of values in millimetres, "
                f"e.g. {k}: {{value: {design[k]:g}, unit: mm}}")
    return f"{msg}; check the design's dimensions (their units) against the workspace"


def unreachable_design(config, names=None, workspace=None) -> str | None:
    """The first named design (all when ``names`` is None) whose mechanism
    reaches no point of W, or None (the numpy model's ``reachable``, cheap:
    no index is computed)."""
    import numpy as np

    from ..evaluate import build, workspace_of

    ws = workspace_of(config) if workspace is None else workspace
    for n in (list(names) if names else list(config.designs)):
        if not np.any(build(config, n).reachable(ws.X)):
            return n
    return None
