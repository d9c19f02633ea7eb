"""Atomic file writing: write to a temporary file in the same folder, then rename,
so an interrupted program never leaves a half-written file."""
from __future__ import annotations

import functools
import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any


@functools.lru_cache(maxsize=1)
def _file_mode() -> int:
    """The mode a plain open() would give a new file (0o666 less the umask);
    mkstemp makes its files 0o600, unreadable to anyone else."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


class UnsafeDestination(Exception):
    """A file to write is a symbolic link, or exists and is not a regular file:
    nothing is written (the message is one line naming the file)."""


def check_destination(path: str | os.PathLike) -> None:
    """Raise :class:`UnsafeDestination` unless ``path`` is absent or a regular
    file (``lstat``: a symbolic link is never followed, even to a regular file)."""
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return
    except OSError as exc:
        raise UnsafeDestination(f"{os.fsdecode(path)!s}: cannot write ({exc.strerror or type(exc).__name__})") from None
    if stat.S_ISLNK(st.st_mode):
        raise UnsafeDestination(f"{os.fsdecode(path)!s}: is a symbolic link; refusing to write through or over it")
    if not stat.S_ISREG(st.st_mode):
        raise UnsafeDestination(f"{os.fsdecode(path)!s}: exists and is not a regular file; refusing to replace it")


def atomic_write_bytes(path: str | os.PathLike, data: bytes, durable: bool = True) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename.

    The rename makes the write atomic for every reader and against a killed
    process.  ``durable`` also flushes the file to the disk before the rename
    (fsync), which matters only if the operating system itself goes down;
    per-generation checkpoints skip it for speed: after an operating-system
    crash such a checkpoint may be older than the last generation or, on some
    file systems, empty, and resuming then says so instead of loading it.

    A destination that is a symbolic link or not a regular file is refused
    (:class:`UnsafeDestination`) before anything is written; the rename itself
    replaces a name, never writes through a link planted after that check."""
    path = Path(path)
    check_destination(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            if hasattr(os, "fchmod"):
                os.fchmod(fh.fileno(), _file_mode())
            fh.write(data)
            fh.flush()
            if durable:
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike, obj: Any) -> None:
    atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=False, default=_json_default) + "\n")


def _json_default(o):
    import numpy as np

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serializable: {type(o).__name__}")
