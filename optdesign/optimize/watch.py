"""progress.json: a run's progress in its folder, for ``optdesign status RUN``
(also from another terminal while the run goes on).

:class:`StatusFile` writes what :class:`~optdesign.optimize.progress.Progress`
knows (the stage running, its generation, its best value in the config's
units with the unit named, the run's stages done, the ETA, the phase after
the stages) as JSON, atomically (a temporary file and a rename: a reader
never sees half a file), at most once a second while the run goes on; a
change within the second is written when the second is over (a timer), and
the run's end (complete, interrupted, failed) is written at once.  A write
that fails never stops the run.  The file is only written, never read by a
run: it takes no part in resuming.
"""
from __future__ import annotations

import json
import os
import threading
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

__all__ = ["PROGRESS_FILE", "FORMAT", "StatusFile", "read_status", "status_lines"]

#: the file in the run folder
PROGRESS_FILE = "progress.json"
#: the layout of the file (a key ``format`` says which)
FORMAT = 1
#: the largest progress.json ``status`` reads
MAX_BYTES = 1 << 20


def _now_iso() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="seconds").replace("+00:00", "Z")


class StatusFile:
    """progress.json in ``folder``: ``snapshot()`` gives its content (a dict).

    Lock order: ``poke``/``end`` take this object's lock and then call
    ``snapshot`` (which takes the caller's lock): the caller never calls them
    while holding its own lock."""

    def __init__(self, folder, snapshot: Callable[[], dict], interval: float = 1.0):
        self.path = Path(folder) / PROGRESS_FILE
        self.snapshot = snapshot
        self.interval = float(interval)
        self.writes = 0
        self.failed: str | None = None
        self._last = float("-inf")
        self._timer: threading.Timer | None = None
        self._lock = threading.Lock()
        self._ended = False

    def poke(self) -> None:
        """Something changed: written now if the last write is a second old,
        else when the second is over."""
        with self._lock:
            if self._ended:
                return
            wait = self._last + self.interval - time.monotonic()
            if wait <= 0:
                self._write({})
            elif self._timer is None:
                self._timer = threading.Timer(wait, self._flush)
                self._timer.daemon = True
                self._timer.start()

    def _flush(self) -> None:
        with self._lock:
            self._timer = None
            if not self._ended:
                self._write({})

    def end(self, status: str) -> None:
        """The run ended (``complete``, ``interrupted``, ``failed``): written at once, the last write."""
        with self._lock:
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
            if not self._ended:
                self._ended = True
                self._write({"status": status, "phase": status, "running": [], "stage": None})

    def _write(self, extra: dict) -> None:
        from ..io import UnsafeDestination, atomic_write_bytes

        try:
            data = {"format": FORMAT, **self.snapshot(), **extra, "updated_at": _now_iso(), "pid": os.getpid()}
            atomic_write_bytes(self.path, (json.dumps(data, indent=2) + "\n").encode("utf-8"), durable=False)
            self.writes += 1
        except (OSError, UnsafeDestination, TypeError, ValueError) as exc:   # progress only: never stops a run
            self.failed = f"{type(exc).__name__}: {exc}"
        self._last = time.monotonic()


def read_status(folder) -> dict:
    """The progress.json of run folder ``folder`` (:class:`~optdesign.runs.RunFolderError`
    with one line where there is none, or it is not a run's)."""
    import stat

    from ..runs import RunFolder, RunFolderError

    folder = Path(folder)
    RunFolder(folder).read_manifest(strict=False)          # a run folder at all
    path = folder / PROGRESS_FILE
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        raise RunFolderError(f"{folder}: no {PROGRESS_FILE} (the run has not started its stages, "
                             "or an earlier optdesign made it)") from None
    except OSError as exc:
        raise RunFolderError(f"{path}: cannot be read ({exc.strerror})") from None
    if not stat.S_ISREG(st.st_mode):
        raise RunFolderError(f"{path}: not a regular file (a link or a special file); not read")
    if st.st_size > MAX_BYTES:
        raise RunFolderError(f"{path}: larger than {MAX_BYTES // 2 ** 20} MiB; not a progress file")
    try:
        with open(path, "rb") as fh:
            data = json.loads(fh.read(MAX_BYTES + 1).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise RunFolderError(f"{path}: corrupted (not valid JSON)") from None
    except OSError as exc:
        raise RunFolderError(f"{path}: cannot be read ({exc.strerror})") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise RunFolderError(f"{path}: not a progress file of this optdesign (format {FORMAT})")
    return data


def _alive(pid) -> bool | None:
    if not isinstance(pid, int) or isinstance(pid, bool) or pid <= 0:
        return None
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError, OverflowError):
        return None
    return True


def _text(v, limit: int = 200) -> str:
    """A value of the file as one short line (the file is not trusted)."""
    s = "" if v is None else str(v)
    s = "".join(c if c.isprintable() else " " for c in s)
    return s if len(s) <= limit else s[: limit - 1] + "…"


def _age(updated: str) -> str:
    try:
        t = datetime.fromisoformat(str(updated).replace("Z", "+00:00"))
        s = max(0, int((datetime.now(timezone.utc) - t).total_seconds()))
    except (ValueError, TypeError, OverflowError):
        return ""
    return f", updated {s} s ago"


def _num(v, fmt: str) -> str | None:
    if isinstance(v, (int, float)) and not isinstance(v, bool) and v == v and abs(v) < 1e12:
        return format(v, fmt)
    return None


def status_lines(folder, data: dict) -> list[str]:
    """What ``optdesign status`` prints of a progress.json."""
    from .lines import _clock

    status = _text(data.get("status"), 40) or "?"
    lines = [f"run: {folder} ({status}{_age(data.get('updated_at'))})"]
    parts = []
    done, total = data.get("stages_done"), data.get("stages_total")
    if _num(done, "d") is not None and _num(total, "d") is not None:
        parts.append(f"{done}/{total} stages done")
    if _num(data.get("percent"), ".0f") is not None:
        parts.append(f"{_num(data['percent'], '.0f')} %")
    if _num(data.get("elapsed_s"), ".1f") is not None:
        parts.append(f"{_clock(data['elapsed_s'])} elapsed")
    if status == "running":
        if data.get("phase"):
            parts.append(_text(data["phase"], 60))
        elif _num(data.get("eta_s"), ".0f") is not None:
            parts.append(f"ETA {_clock(data['eta_s'])}")
        else:
            parts.append("ETA …")
    lines.append("progress: " + ", ".join(parts))
    running = data.get("running") if isinstance(data.get("running"), list) else []
    for s in running[:50]:
        if not isinstance(s, dict):
            continue
        gen, gens = _num(s.get("generation"), "d"), _num(s.get("generations"), "d")
        where = " (worker)" if s.get("where") == "worker" else ""
        line = f"running {_text(s.get('label') or s.get('stage'), 80)}{where}"
        if gen is not None and gens is not None:
            line += f": generation {gen}/{gens}"
        if s.get("best"):
            line += f", {_text(s['best'], 100)}"
        lines.append(line)
    finished = data.get("finished") if isinstance(data.get("finished"), list) else []
    for s in finished[-50:]:
        if isinstance(s, dict):
            res = f": {_text(s['result'], 100)}" if s.get("result") else ""
            lines.append(f"done {_text(s.get('label') or s.get('stage'), 80)}{res}")
    if status == "running" and _alive(data.get("pid")) is False:
        lines.append(f"its process ({data.get('pid')}) is gone (killed?); finish it with: optdesign run --resume {folder}")
    elif status == "interrupted":
        lines.append(f"finish it with: optdesign run --resume {folder}")
    return lines
