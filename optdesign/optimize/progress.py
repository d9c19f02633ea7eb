"""A one-line progress bar per GA stage on a terminal, fed by the stage's callback."""
from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    """A one-line progress bar per GA run on a terminal; silent otherwise."""

    def __init__(self, enabled: bool | None = None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self._t0 = 0.0

    def start(self, label: str, total: int, done: int = 0):
        self.label, self.total = label, total
        self._t0 = time.perf_counter()
        if done:
            self.update(done, None)

    def update(self, gen: int, best: float | None):
        if not self.enabled:
            return
        width = 24
        k = int(width * gen / max(self.total, 1))
        best_txt = "" if best is None else f" best {best:.6g}"
        el = time.perf_counter() - self._t0
        self.stream.write(f"\r{self.label:<24} [{'#' * k}{'.' * (width - k)}] {gen}/{self.total}{best_txt} {el:5.1f}s ")
        self.stream.flush()

    def waiting(self, names, since: float):
        """A status line while this process waits for stages running in worker processes."""
        if self.enabled:
            self.stream.write(f"\r{', '.join(names)} (worker process) {time.perf_counter() - since:5.1f}s ")
            self.stream.flush()

    def note(self, text: str):
        """A line of its own (e.g. a stage a worker process finished)."""
        if self.enabled:
            self.stream.write(f"{text}\n")
            self.stream.flush()

    def finish(self):
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()
