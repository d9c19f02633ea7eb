"""Atomic file writing: write to a temporary file in the same folder, then rename,
so an interrupted program never leaves a half-written file."""
from __future__ import annotations

import errno
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


class UnsafeSource(Exception):
    """A file to read is a symbolic link (or lies under one), or is not a
    regular file, or is too large: nothing is read (one line naming the file)."""


def read_no_links(path: str | os.PathLike, limit: int, root: str | os.PathLike | None = None) -> bytes:
    """The bytes of a regular file, never through a symbolic link: the file
    is opened with ``O_NOFOLLOW`` (and ``O_NONBLOCK``, so a FIFO never blocks)
    and checked with ``fstat`` on the open descriptor, so a link planted
    between a check and the read is refused too.  With ``root``, every folder
    between ``root`` and the file is opened the same way (``root`` itself may
    be reached through a link: the user named it).  FileNotFoundError if the
    file is absent; :class:`UnsafeSource` for a link, a non-regular file or
    one larger than ``limit`` bytes."""
    path = Path(path)
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    dflags = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    fds: list[int] = []
    try:
        if root is not None:
            try:
                parts = path.relative_to(root).parts
            except ValueError:
                raise UnsafeSource(f"{path}: not inside {root}") from None
            if not parts or ".." in parts:
                raise UnsafeSource(f"{path}: not a file inside {root}")
            fds.append(os.open(root, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_CLOEXEC", 0)))
            here = Path(root)
            for part in parts[:-1]:
                here = here / part
                try:
                    fds.append(os.open(part, dflags, dir_fd=fds[-1]))
                except OSError as exc:
                    if exc.errno in (errno.ELOOP, errno.ENOTDIR):
                        raise UnsafeSource(f"{here}: a symbolic link or not a folder; refusing to read through it") \
                            from None
                    raise
            name, dir_fd = parts[-1], fds[-1]
        else:
            name, dir_fd = str(path), None
        try:
            fd = os.open(name, flags, dir_fd=dir_fd)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise UnsafeSource(f"{path}: a symbolic link; refusing to read through it") from None
            if exc.errno in (errno.ENOENT,):
                raise
            if exc.errno == errno.ENOTDIR:
                raise UnsafeSource(f"{path}: a folder on its path is not a folder") from None
            raise UnsafeSource(f"{path}: cannot be read ({exc.strerror or type(exc).__name__})") from None
        fds.append(fd)
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise UnsafeSource(f"{path}: not a regular file")
        if st.st_size > limit:
            raise UnsafeSource(f"{path}: larger than {limit} bytes")
        chunks, total = [], 0
        while True:
            b = os.read(fd, 1 << 20)
            if not b:
                break
            total += len(b)
            if total > limit:
                raise UnsafeSource(f"{path}: larger than {limit} bytes")
            chunks.append(b)
        return b"".join(chunks)
    finally:
        for f in fds:
            os.close(f)


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


class LockHeld(Exception):
    """The lock is held by another process (the message names it, as its lock file says)."""


class FileLock:
    """An exclusive ``fcntl.flock`` on ``path`` (created if absent, never
    through a symbolic link), taken at once or :class:`LockHeld`; the file
    then holds ``pid <pid> on host <host>``.  Held until :meth:`release` (or
    the end of a ``with`` block); the kernel drops it when the process
    exits, however it ends."""

    def __init__(self, path: str | os.PathLike):
        import fcntl
        import socket

        self.path = Path(path)
        flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0) \
            | getattr(os, "O_NONBLOCK", 0)
        try:
            self.fd: int | None = os.open(self.path, flags, _file_mode())
        except OSError as exc:
            what = "a symbolic link" if exc.errno == errno.ELOOP else f"cannot be opened ({exc.strerror})"
            raise UnsafeSource(f"{self.path}: {what}") from None
        try:
            if not stat.S_ISREG(os.fstat(self.fd).st_mode):
                raise UnsafeSource(f"{self.path}: not a regular file")
            try:
                fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(self.fd, 200, 0).decode("utf-8", "replace").strip() or "another process"
                raise LockHeld("locked by " + "".join(c if c.isprintable() else "?" for c in holder)[:120]) from None
            os.ftruncate(self.fd, 0)
            os.pwrite(self.fd, f"pid {os.getpid()} on host {socket.gethostname()}\n".encode(), 0)
        except BaseException:
            os.close(self.fd)
            raise

    def release(self) -> None:
        if self.fd is not None:
            os.close(self.fd)       # closing its descriptor drops the flock
            self.fd = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()
