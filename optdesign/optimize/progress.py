"""Progress of a run on a terminal: one line per running stage (in this
process or a worker process), a line for the whole run (stages done, ETA),
a line of its own for each finished stage.

Drawn with rich (a live display that redraws in place); every line is cut to
the terminal's width, so a redraw never leaves a line behind.  Silent when
the stream is not a terminal.  A worker process reports its stage through a
queue (:class:`RemoteProgress`); the main process shows it.

The ETA of the run: the work still to do (generations x population of the
stages not done, the pre-scan's designs) at the rate this process has seen so
far, from the pre-scan's first batch on; the percentage counts the stages a
resumed run finished before.  After the stages, the final phases (results,
report) are lines of their own, and the run line names the phase instead of
an ETA.  Lines are cut at field boundaries, never inside a number or word.

:meth:`Progress.watch` also keeps the same state in the run folder's
progress.json (:mod:`.watch`), terminal or not: ``optdesign status RUN``.
"""
from __future__ import annotations

import sys
import threading
import time

from .lines import _clock, _cut_words, _isatty, fit_line, stage_line, wrap_line  # noqa: F401

__all__ = ["Progress", "RemoteProgress", "CountProgress", "stage_line", "fit_line", "wrap_line", "COMPILE_NOTICE"]

#: said before kernels compile (the first run on a machine)
COMPILE_NOTICE = ("compiling the engine's kernels (once per machine, about 20-40 s; every mechanism shares them, "
                  "later runs load them from the cache)")


class _Stage:
    def __init__(self, label: str, total: int, done: int, where: str):
        self.label, self.total, self.gen, self.where = label, total, done, where
        self.best = ""
        self.t0 = time.perf_counter()
        self.first = done


class Progress:
    """A run's progress on a terminal; silent otherwise (see the module docstring)."""

    def __init__(self, enabled: bool | None = None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = _isatty(self.stream) if enabled is None else bool(enabled)
        self.poll = None            # callable -> remote events, set by the worker pool
        self._lock = threading.RLock()
        self._live = None
        self._console = None
        self._stages: dict[str, _Stage] = {}
        self._local: str | None = None
        self._plan: dict[str, tuple[int, int]] = {}   # stage -> (position, work)
        self._done: set[str] = set()
        self._work_done = 0.0
        self._t0 = time.perf_counter()
        self._describe = None
        self._pre_done: set[str] = set()
        self._phase = ""            # the run's final phase (results, report), shown instead of the ETA
        self._status = None         # progress.json (:meth:`watch`)
        self._finished: list[dict] = []

    @property
    def tracking(self) -> bool:
        """Whether the stages' progress is wanted (a terminal, or progress.json)."""
        return self.enabled or self._status is not None

    def watch(self, folder) -> None:
        """Keep the run's progress in ``folder``/progress.json (at most once a second)."""
        from .watch import StatusFile

        self._finished = []
        self._status = StatusFile(folder, self.snapshot)

    def _poke(self) -> None:
        # never called with self._lock held (the status file's lock comes first)
        if self._status is not None:
            self._status.poke()

    def end(self, status: str) -> None:
        """The run ended (complete, interrupted, failed): progress.json says so."""
        if self._status is not None:
            self._status.end(status)

    # ------------------------------------------------------------------ display
    def _width(self) -> int:
        return max(20, self._console.width - 1) if self._console is not None else 79

    def _ensure(self) -> bool:
        if not self.enabled:
            return False
        if self._live is None:
            from rich.console import Console
            from rich.live import Live

            self._console = Console(file=self.stream, highlight=False, markup=False, emoji=False, soft_wrap=False)
            self._live = Live(get_renderable=self._render, console=self._console, auto_refresh=True,
                              refresh_per_second=4, transient=True, redirect_stdout=False, redirect_stderr=False)
            self._live.start()
        return True

    def _render(self):
        from rich.text import Text

        with self._lock:
            self._drain()
            w = self._width()
            lines = [self._run_line(w)] if self._plan else []
            for name, s in self._stages.items():
                label = self._label(name) + (" (worker)" if s.where == "worker" else "")
                lines.append(stage_line(label, s.gen, s.total, s.best, time.perf_counter() - s.t0, w))
        return Text("\n".join(lines), no_wrap=True, overflow="ellipsis")

    def _label(self, name: str) -> str:
        if name in self._plan:
            return f"[{self._plan[name][0]}/{len(self._plan)}] {name}"
        return name

    def _progress_work(self) -> float:
        done = self._work_done
        for name, s in self._stages.items():
            pos_work = self._plan.get(name)
            if pos_work:
                done += pos_work[1] * (s.gen - s.first) / max(s.total, 1)
        return done

    def _totals(self) -> dict:
        """The whole run: stages done, percentage of the work, elapsed, ETA (seconds or None)."""
        el = time.perf_counter() - self._t0
        work = {n: wk for n, (_, wk) in self._plan.items()}
        total = sum(work.values())
        before = sum(work[n] for n in self._pre_done if n in work)      # done before (a resumed run)
        finished = sum(work[n] for n in self._done - self._pre_done if n in work)
        running = sum(work[n] * min(s.gen, s.total) / max(s.total, 1) for n, s in self._stages.items() if n in work)
        done_all = before + finished + running
        here = self._progress_work()        # the work this process has seen done: its rate
        eta = el * max(total - done_all, 0.0) / here if here > 0 and el > 1.0 else None
        return {"stages_done": len((self._done | self._pre_done) & set(work)), "stages_total": len(self._plan),
                "percent": round(100 * min(done_all / total, 1.0), 1) if total > 0 else None,
                "elapsed_s": round(el, 1), "eta_s": None if eta is None else round(eta, 1),
                "left": total > done_all}

    def _run_line(self, w: int) -> str:
        t = self._totals()
        eta = ""
        if self._phase:
            eta = self._phase
        elif t["eta_s"] is not None:
            eta = f"ETA {_clock(t['eta_s'])}"
        elif t["left"]:
            eta = "ETA …"
        pct = f"{t['percent']:.0f}%" if t["percent"] is not None else ""
        return fit_line([f"run: {t['stages_done']}/{t['stages_total']} stages done", pct,
                         f"{_clock(t['elapsed_s'])} elapsed", eta], w, shrink=None, drop=[2, 1])

    def snapshot(self) -> dict:
        """The run's progress as progress.json holds it (see :mod:`.watch`)."""
        with self._lock:
            self._drain()
            t = self._totals()
            t.pop("left")
            running = [{"stage": n, "label": self._label(n), "position": self._plan.get(n, (None,))[0],
                        "generation": s.gen, "generations": s.total, "best": s.best, "where": s.where}
                       for n, s in self._stages.items()]
            first = running[0] if running else {}
            return {"status": "running", "phase": self._phase or ("stages" if self._plan else "starting"),
                    **t, "eta": None if t["eta_s"] is None else _clock(t["eta_s"]),
                    "stage": first.get("stage"), "generation": first.get("generation"),
                    "generations": first.get("generations"), "best": first.get("best"),
                    "running": running, "finished": list(self._finished)}

    def _print(self, text: str) -> None:
        if self._ensure():
            # folded at spaces, never cut inside a word or a number
            self._console.print("\n".join(wrap_line(text, self._width())), no_wrap=True, overflow="ellipsis",
                                crop=True)

    def _drain(self) -> None:
        if self.poll is None:
            return
        for ev in self.poll():
            kind, name = ev[0], ev[1]
            if kind == "start":
                self._stages[name] = _Stage(name, ev[2], ev[3], "worker")
            elif kind == "update" and name in self._stages:
                self._stages[name].gen = ev[2]
                self._stages[name].best = ev[3]

    # ------------------------------------------------------------------ the run
    def plan(self, stages, done=()) -> None:
        """The run's stages in order, ``(name, generations, population)``;
        ``done``: those finished before (a resumed run)."""
        with self._lock:
            self._plan = {n: (i + 1, float(g) * float(p)) for i, (n, g, p) in enumerate(stages)}
            self._pre_done = set(done)
            self._t0 = time.perf_counter()
        self._ensure()
        self._poke()

    def compiling(self, what: str = ""):
        """The notice before kernels compile (the first run on a machine); the
        line when they are compiled (the callable returned)."""
        self._print(COMPILE_NOTICE)
        return lambda seconds: self._print(f"kernels compiled in {_clock(seconds)}")

    def phase(self, text: str, short: str | None = None) -> None:
        """The run's final work after its stages (final results, report
        writing): a line of its own, and the run line names it (``short``)
        instead of an ETA."""
        with self._lock:
            self._phase = short or text
        self._print(text)
        self._poke()

    def note(self, text: str) -> None:
        """A line of its own (e.g. a stage a worker process finished)."""
        self._print(text)

    def stage_done(self, name: str, summary: str = "") -> None:
        """A stage finished (here or in a worker): its line of its own."""
        with self._lock:
            self._drain()
            s = self._stages.pop(name, None)
            if name in self._plan and name not in self._done:
                self._done.add(name)
                self._work_done += self._plan[name][1] * ((s.total - s.first) / max(s.total, 1) if s else 1.0)
            el = f" in {_clock(time.perf_counter() - s.t0)}" if s else ""
            best = summary or (s.best if s else "")
            self._finished.append({"stage": name, "label": self._label(name), "result": best})
        where = " (worker)" if s is not None and s.where == "worker" else ""
        self._print(f"done {self._label(name)}{where}" + (f": {best}" if best else "") + el)
        self._poke()

    # ------------------------------------------------------------------ a stage in this process
    def start(self, label: str, total: int, done: int = 0, describe=None):
        """A stage starts (``done`` generations already finished: a resumed
        stage); ``describe(best)`` gives the text of its best value."""
        with self._lock:
            self._local = label
            self._describe = describe
            self._stages[label] = _Stage(label, total, done, "here")
        self._ensure()
        self._poke()

    def update(self, gen: int, best=None):
        if not self.tracking or self._local is None:
            return
        with self._lock:
            s = self._stages.get(self._local)
            if s is not None:
                s.gen = gen
                s.best = _best_text(best, self._describe)
        self._poke()

    def waiting(self, names, since: float):
        """This process waits for stages in worker processes (the display redraws itself)."""
        self._ensure()
        self._poke()

    def finish(self):
        """The stage of this process ended (finished or interrupted)."""
        with self._lock:
            name, self._local = self._local, None
        if name is not None and name in self._stages:
            s = self._stages[name]
            if s.gen >= s.total:
                self.stage_done(name)
            else:
                with self._lock:
                    self._stages.pop(name, None)

    def close(self) -> None:
        """Stop the display (the terminal gets its cursor back)."""
        if self._live is not None:
            try:
                self._live.stop()
            finally:
                self._live = None


def _best_text(best, describe) -> str:
    if best is None:
        return ""
    if describe is not None:
        return describe(best)
    return f"best {best:.6g}" if isinstance(best, (int, float)) else str(best)


class RemoteProgress:
    """The progress of a stage in a worker process, sent to the main process
    through a queue (at most every ``interval`` seconds, and at its start)."""

    enabled = True

    def __init__(self, queue, interval: float = 0.25):
        self.queue, self.interval = queue, interval
        self.name = None
        self.total = 0
        self._describe = None
        self._last = 0.0

    def _put(self, ev) -> None:
        try:
            self.queue.put_nowait(ev)
        except Exception:  # noqa: BLE001 - progress only: never stops a stage
            pass

    def start(self, label: str, total: int, done: int = 0, describe=None):
        self.name, self._describe, self.total = label, describe, total
        self._put(("start", label, total, done))

    def update(self, gen: int, best=None):
        now = time.perf_counter()
        if now - self._last >= self.interval or gen >= self.total:
            self._last = now
            self._put(("update", self.name, gen, _best_text(best, self._describe)))

    def finish(self):
        pass

    def waiting(self, names, since):
        pass

    def note(self, text):
        pass

    def close(self):
        pass


class CountProgress:
    """``label: done/total runs, elapsed, ETA`` on a terminal (silent
    otherwise), with a line of its own per finished item above it.  The ETA
    counts only the items this process has waited for (``counted``)."""

    def __init__(self, total: int, label: str = "batch", enabled: bool | None = None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = _isatty(self.stream) if enabled is None else bool(enabled)
        self.total, self.label = int(total), label
        self.done_n = 0
        self.counted = 0
        self.skipped = 0
        self._t0 = time.perf_counter()
        self._live = self._console = None
        if self.enabled:
            from rich.console import Console
            from rich.live import Live

            self._console = Console(file=self.stream, highlight=False, markup=False, emoji=False, soft_wrap=False)
            self._live = Live(get_renderable=self._render, console=self._console, auto_refresh=True,
                              refresh_per_second=2, transient=True, redirect_stdout=False, redirect_stderr=False)
            self._live.start()

    def _render(self):
        from rich.text import Text

        w = max(20, self._console.width - 1)
        el = time.perf_counter() - self._t0
        left = self.total - self.done_n
        eta = f"ETA {_clock(el * left / self.counted)}" if self.counted and left else ""
        k = int(12 * self.done_n / max(self.total, 1))
        line = fit_line([f"{self.label}:", f"[{'#' * k}{'.' * (12 - k)}]", f"{self.done_n}/{self.total} runs done",
                         f"{_clock(el)} elapsed", eta], w, shrink=0, drop=[1, 3, 4, 2])
        return Text(line, no_wrap=True, overflow="ellipsis")

    def say(self, text: str, file=None) -> None:
        """A line of its own: above the counter on the terminal, else to ``file`` (stdout)."""
        out = file or sys.stdout
        if self.enabled and _isatty(out):
            w = max(20, self._console.width - 1)
            self._console.print("\n".join(wrap_line(text, w)), no_wrap=True, crop=True)   # folded at spaces
        else:
            print(text, file=out, flush=True)

    def done(self, counted: bool = True) -> None:
        """An item finished (``counted``: it ran in this process's wait, not skipped)."""
        self.done_n += 1
        if counted:
            self.counted += 1

    def close(self) -> None:
        if self._live is not None:
            try:
                self._live.stop()
            finally:
                self._live = None
