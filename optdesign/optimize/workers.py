"""Stop requests, signals and the worker processes that run stages.

* :class:`StopRequest` — SIGINT/SIGTERM during a run ask the GA to stop after
  the generation in progress (its checkpoint is then on disk); a second one
  stops at once.  Outside the stages (before the run starts) a signal stops at
  once; once the run is complete, signals are noted and ignored, so that the
  exit status is the one the manifest gives.  A stage worker also stops when
  the main process writes the stop file or is gone.
* :class:`StagePool` — ``jobs - 1`` spawned worker processes (compiled kernels
  on one thread each) that run stages handed to them; they ignore Ctrl-C while
  idle, stop at a generation boundary when asked, and end themselves when the
  main process disappears (even a SIGKILLed one).
"""
from __future__ import annotations

import os
import signal
import threading
import time
from pathlib import Path
from typing import Callable

__all__ = ["Interrupted", "StopRequest", "StagePool", "STOP_FILE", "default_jobs", "set_kernel_threads",
           "warm_kernels", "warm_plots", "worker_progress"]

#: written into the run folder by the main process to stop its stage workers
STOP_FILE = ".stop"


class Interrupted(KeyboardInterrupt):
    """Raised on SIGTERM (and Ctrl-C) so the run is marked incomplete and can be resumed."""

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signum)
        self.signum = signum


class StopRequest:
    """The signal state of a run (see the module docstring).  ``deferred``:
    a first signal waits for the generation boundary; ``completed``: signals
    are only noted (``late``)."""

    def __init__(self, stop_file: Path | None = None, parent: int | None = None, deferred: bool = True):
        self.signum: int | None = None
        self.previous: dict[int, object] = {}
        self.stop_file = stop_file
        self.parent = parent
        self.deferred = deferred
        self.completed = False
        self.late: int | None = None
        self.insisted = False   # a second signal: stop now, do not wait for stage workers
        self.folder = None      # the run folder, once there is one

    def handler(self, signum, frame):
        if self.completed:
            self.late = signum
            return
        if self.signum is not None or not self.deferred:
            self.insisted = self.signum is not None
            self.signum = self.signum or signum
            raise Interrupted(signum)
        self.signum = signum

    def install(self) -> "StopRequest":
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                self.previous[sig] = signal.signal(sig, self.handler)
            except ValueError:  # not in the main thread (e.g. a worker thread)
                break
        return self

    def restore(self) -> None:
        for sig, old in self.previous.items():
            try:
                signal.signal(sig, old)
            except (ValueError, TypeError):
                pass
        self.previous = {}

    def requested(self) -> bool:
        if self.signum is None and self.stop_file is not None:
            try:
                self.signum = int(self.stop_file.read_text() or signal.SIGTERM)
            except (FileNotFoundError, ValueError):
                pass
        if self.signum is None and self.parent is not None and os.getppid() != self.parent:
            self.signum = signal.SIGTERM
        return self.signum is not None

    def check(self) -> None:
        if self.requested():
            raise Interrupted(self.signum)


def default_jobs() -> int:
    """Processes for a run's stages: the CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def set_kernel_threads(n: int | None) -> int | None:
    """Set the compiled kernels' thread count (None: numba's default); returns the old one."""
    try:
        import numba
    except Exception:  # noqa: BLE001 - no numba: the numpy path, nothing to set
        return None
    old = numba.get_num_threads()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS if n is None else max(1, min(n, numba.config.NUMBA_NUM_THREADS)))
    return old


def warm_kernels(evaluate_once: Callable[[], object]) -> None:
    """One evaluation: loads (on a fresh installation: compiles and caches) the
    compiled kernels before the workers start, so that they load them from the
    cache.  Only a warm-up: a failure is left for the stages to report."""
    import numpy as np

    try:
        with np.errstate(all="ignore"):
            evaluate_once()
    except Exception:  # noqa: BLE001
        pass


def warm_plots() -> bool:
    """Load the plotting library (while this process waits for its workers)."""
    try:
        import matplotlib.backends.backend_agg  # noqa: F401  (what the report's PNGs draw with)
        import matplotlib.figure  # noqa: F401
    except Exception:  # noqa: BLE001 - the report says why plots are missing
        pass
    return True


# ---------------------------------------------------------------------- worker side
_busy = False
_events = None   # the queue the worker's stages report their progress to (None: no report)


def worker_progress():
    """The progress of a stage in this worker process (sent to the main
    process), or None when the main process shows none."""
    if _events is None:
        return None
    from .progress import RemoteProgress

    return RemoteProgress(_events)


def _worker_init(parent: int, events=None) -> None:
    global _events
    _events = events
    if events is not None:
        events.cancel_join_thread()   # progress only: a worker's exit never waits for it
    # a Ctrl-C on the terminal reaches every process of the group: an idle
    # worker ignores it, a busy one stops at its generation boundary (its
    # task installs a StopRequest)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    set_kernel_threads(1)
    from ..process import tune_collector

    tune_collector()        # before the stage's imports (the evaluator's unpickling)
    # the parent's pid comes from the parent: it may have died while this
    # worker was starting, and os.getppid() would then already name another process
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _watch_parent(parent: int, poll: float = 0.2, grace: float = 10.0) -> None:
    """End this worker when the main process is gone (e.g. SIGKILLed): at once
    when idle; a busy one stops at its next generation boundary by itself
    (its StopRequest sees the new parent) and is ended after ``grace`` s if not."""
    while os.getppid() == parent:
        time.sleep(poll)
    t = time.monotonic()
    while _busy and time.monotonic() - t < grace:
        time.sleep(poll)
    os._exit(1)


def _worker_ready() -> bool:
    return True


def _in_worker(fn: Callable, stop_file: str, parent: int, args: tuple):
    """Run ``fn(*args, stop=...)`` in a worker with its own stop request."""
    global _busy
    stop = StopRequest(Path(stop_file), parent).install()
    _busy = True
    try:
        return fn(*args, stop=stop)
    finally:
        _busy = False
        stop.restore()


# ---------------------------------------------------------------------- main side
class StagePool:
    """Worker processes for stages (none if ``workers`` is 0)."""

    def __init__(self, workers: int, folder: Path, warm: Callable[[], None] | None = None, events: bool = False):
        self.workers = max(0, int(workers))
        self.stop_file = Path(folder) / STOP_FILE
        self.running: dict = {}
        self.pool = None
        self.threads = None
        self.events = None   # the workers' progress reports (``events``: wanted)
        if self.workers:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            ctx = mp.get_context("spawn")
            self.events = ctx.Queue() if events else None
            self.threads = set_kernel_threads(1)
            self.pool = ProcessPoolExecutor(self.workers, mp_context=ctx,
                                            initializer=_worker_init, initargs=(os.getpid(), self.events))
            for _ in range(self.workers):  # start the workers (their imports) now
                self.pool.submit(_worker_ready)
            if warm is not None:
                warm_kernels(warm)

    def free(self) -> bool:
        return self.pool is not None and len(self.running) < self.workers

    def submit(self, key, name: str, fn: Callable, *args) -> None:
        """Run ``fn(*args, stop=...)`` in a worker; ``key`` comes back with its result."""
        self.running[self.pool.submit(_in_worker, fn, str(self.stop_file), os.getpid(), args)] = (key, name)

    def wait_any(self, stop: StopRequest, progress) -> None:
        """Wait until a worker's stage ends or a stop is requested (checked every 50 ms)."""
        from concurrent.futures import FIRST_COMPLETED, wait

        t0 = time.perf_counter()
        names = [name for _, name in self.running.values()]
        shown = False
        while not stop.requested():
            done, _ = wait(list(self.running), timeout=0.05, return_when=FIRST_COMPLETED)
            if done:
                break
            progress.waiting(names, t0)
            shown = True
        if shown:
            progress.finish()

    def poll_progress(self) -> list:
        """The progress reports the workers sent since the last call."""
        out = []
        if self.events is None:
            return out
        import queue

        try:
            while len(out) < 10_000:
                out.append(self.events.get_nowait())
        except (queue.Empty, OSError, ValueError, EOFError):
            pass
        return out

    def finished(self) -> list:
        """``(key, result)`` of the stages the workers finished (a worker's error is raised)."""
        out = []
        for fut in [f for f in self.running if f.done()]:
            out.append((self.running.pop(fut)[0], fut.result()))
        return out

    def stop(self, signum: int, wait: bool) -> None:
        """Ask the workers to stop at their next generation boundary (after their
        checkpoint) and, unless the user insisted (a second signal), wait for them."""
        if self.pool is None:
            return
        from ..io import atomic_write_text

        atomic_write_text(self.stop_file, str(int(signum)))
        if wait:
            try:
                self.pool.shutdown(wait=True, cancel_futures=True)
            except KeyboardInterrupt:
                pass

    def release(self) -> None:
        """Let the idle workers exit (while the results and the report are written)."""
        if self.pool is not None:
            self.pool.shutdown(wait=False)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=False, cancel_futures=True)
        if self.events is not None:
            self.events.close()
            self.events.cancel_join_thread()
            self.events = None
        if self.threads is not None:
            set_kernel_threads(self.threads)
        try:
            self.stop_file.unlink()
        except FileNotFoundError:
            pass
