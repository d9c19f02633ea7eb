"""Execution of a batch: one task in a worker, many through joblib.

Each run lives in ``<out>/<name>-s<seed>-<key>/``: a task whose folder holds
a complete run is skipped, one whose folder holds an unfinished run is
resumed from its last finished generation.  A run's result depends only on
its config and seed, never on the number of workers, on the backend, or on
which worker ran it.

Backends (both through joblib):

* ``local`` — joblib's process pool (loky) on this machine's cores;
* ``dask`` — joblib's Dask backend over a ``dask.distributed`` cluster.  The
  run folders are written by the workers, so ``out`` must be a path every
  worker sees (a shared file system, or one machine).  A worker that dies
  loses at most the generation in progress: the scheduler gives its run to
  another worker, which resumes it from the run folder's checkpoint.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys
from pathlib import Path
from typing import Sequence

from ..config import ConfigError, parse_config
from ..names import OutsideRoot, check_inside
from ..runs import RunFolder, RunFolderError
from ..report.folders import config_key, sweep_label
from ..report.summary import row_from_folder
from .tasks import Task

__all__ = ["BackendError", "BatchInterrupted", "stop_on_signals", "run_task", "run_batch", "connect_dask",
           "check_shared_folder"]


class BackendError(RuntimeError):
    """The parallel backend cannot be used (extra not installed, scheduler unreachable, no workers)."""


class BatchInterrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM reached the batch (``signum`` says which)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def stop_on_signals():
    """SIGINT and SIGTERM raise :class:`BatchInterrupted` in the main thread
    (once: a second signal while the workers are being stopped is ignored, so
    the stopping is never cut short); outside the main thread it does nothing.  :func:`run_batch` then stops its
    workers before the exception leaves it."""
    fired = []

    def handler(signum, frame):
        if fired:
            return
        fired.append(signum)
        raise BatchInterrupted(signum)

    import threading

    if threading.current_thread() is not threading.main_thread():   # signals reach the main thread only
        yield
        return
    old = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)


@contextlib.contextmanager
def _signals_blocked():
    """SIGINT and SIGTERM held back (delivered when the block ends) in the main thread."""
    sigs = {signal.SIGINT, signal.SIGTERM}
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, sigs)
    except (AttributeError, ValueError, OSError):   # pragma: no cover - no pthread_sigmask
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


#: a warnings filter for joblib's resource tracker: a process that watches the
#: pool's semaphores and, when the batch ends after its workers were killed (a
#: signal), reports each one it unlinks as "leaked" -- noise after the batch's
#: own message, and the tracker is spawned with this process's environment
TRACKER_QUIET = "ignore:resource_tracker:UserWarning"


def _quiet_resource_tracker() -> None:
    """Add :data:`TRACKER_QUIET` to ``PYTHONWARNINGS`` (kept: the user's own filters)."""
    have = os.environ.get("PYTHONWARNINGS", "")
    if TRACKER_QUIET not in have.split(","):
        os.environ["PYTHONWARNINGS"] = f"{have},{TRACKER_QUIET}" if have else TRACKER_QUIET


def _kill_local_workers() -> None:
    """Kill joblib's loky worker processes and their children (joblib's own
    abort kills the workers of the call, and may start fresh ones for the
    next call; these are killed too, so no process outlives the batch)."""
    try:
        from joblib.externals.loky import reusable_executor
    except ImportError:  # pragma: no cover - joblib without loky
        return
    ex = getattr(reusable_executor, "_executor", None)
    if ex is not None:
        ex.shutdown(wait=True, kill_workers=True)


def run_task(task: Task, out: str, quiet: bool = True, reference_note=None) -> dict:
    """Run (or skip, or resume) one task; returns its summary row.

    A run that fails (for example no feasible design) or a folder that cannot
    be used gives a row with status ``failed`` and the error, so the rest of
    the batch goes on.  ``reference_note``: see :func:`optdesign.runner.run_outputs`.
    """
    from ..optimize.progress import Progress
    from ..runner import run_in_folder

    folder = RunFolder(Path(out) / task.folder_name)
    state = "new"
    try:
        try:      # a symbolic link in the batch folder never takes a run elsewhere
            check_inside(out, folder.path)
        except OutsideRoot as exc:
            raise RunFolderError(str(exc)) from None
        cfg = parse_config(task.config_text, source=task.source, run_folder=True)   # checked when planned
        if folder.path.exists():
            m = folder.read_manifest()
            if m.get("status") == "complete" and (folder.path / "results.json").exists():
                return _with_state(row_from_folder(folder.path), "done")
            state = "resumed"
        else:
            try:
                folder = RunFolder.create(out, task.folder_name, task.config_text, task.seed, task.key, exact=True)
                folder.update_manifest(pareto=task.pareto, config_source=task.source, name=task.name,
                                       sweep=task.sweep)
            except FileExistsError:  # another worker created it meanwhile: resume it
                state = "resumed"
        with folder.lock():     # another worker running this folder: this task fails, naming it
            run_in_folder(cfg, folder, task.seed, Progress(False if quiet else None), pareto=task.pareto,
                          reference_note=reference_note)
    except (RunFolderError, ConfigError, RuntimeError, ValueError, ArithmeticError, OSError) as exc:
        try:
            row = row_from_folder(folder.path)
        except RunFolderError:
            row = {}
        row = {**_empty_row(task, folder.path), **{k: v for k, v in row.items() if v is not None}}
        row.update(status="failed", error=f"{type(exc).__name__}: {exc}")
        return _with_state(row, state)
    return _with_state(row_from_folder(folder.path), state)


def _with_state(row: dict, state: str) -> dict:
    row["this_batch"] = state
    return row


def _empty_row(task: Task, path: Path) -> dict:
    return {"config": task.name, "sweep": sweep_label(task.sweep), "config_key": config_key(task.config_text),
            "run_key": task.key, "seed": task.seed, "status": "failed", "objective": None,
            "wall_time_s": None, "folder": str(path)}


def _probe_scheduler(scheduler: str, timeout: float, security) -> None:
    """Connect to ``scheduler`` on a private event loop and ask who it is,
    all within ``timeout`` seconds: a listener that says nothing, answers
    garbage or is not a Dask scheduler gives BackendError (one line), and no
    ``distributed.Client`` is made until the answer is right."""
    import asyncio

    from distributed.comm import connect

    async def ask():
        comm = await connect(scheduler, timeout=timeout, **security.get_connection_args("client"))
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    try:
        answer = asyncio.run(asyncio.wait_for(ask(), timeout))
    except (TimeoutError, asyncio.TimeoutError, OSError):
        raise BackendError(f"cannot reach the Dask scheduler at {scheduler}: no scheduler answered "
                           f"within {timeout:g} s") from None
    except Exception as exc:  # noqa: BLE001 - garbage on the port: MemoryError (a huge frame length), ValueError, ...
        raise BackendError(f"{scheduler} does not answer as a Dask scheduler (reading its answer gave "
                           f"{type(exc).__name__})") from None
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        raise BackendError(f"{scheduler} does not answer as a Dask scheduler (it answered {type(answer).__name__})")


def _silence_client_del() -> None:
    """A ``distributed.Client`` that failed to start complains from its
    ``__del__`` when collected ('Exception ignored in Client.__del__' and a
    traceback); our one-line error has said it all."""
    previous = sys.unraisablehook

    def hook(unraisable):
        if "Client.__del__" in repr(getattr(unraisable, "object", "")):
            return
        previous(unraisable)

    sys.unraisablehook = hook


def connect_dask(scheduler: str, timeout: float = 10.0, check_version: bool = True):
    """A ``distributed.Client`` on ``scheduler`` with at least one worker.

    Raises BackendError (one line) if the ``dask`` extra is missing, a
    ``tls://`` address has no certificates configured, nothing answers as a
    Dask scheduler within ``timeout`` seconds (nothing listening, a listener
    that says nothing or answers garbage), no worker joins within ``timeout``
    seconds, or a worker cannot import this optdesign.
    """
    try:
        from distributed import Client
        from distributed.security import Security
    except ImportError:
        raise BackendError("--backend dask needs the dask extra: pip install 'optdesign[dask]'") from None
    import logging

    security = Security()
    if scheduler.startswith("tls://") and security.get_connection_args("client").get("ssl_context") is None:
        raise BackendError(f"{scheduler}: tls:// needs certificates in the Dask configuration "
                           "(distributed.comm.tls.ca-file, distributed.comm.tls.client.cert and .key)")
    logging.getLogger("distributed").setLevel(logging.CRITICAL)   # our one-line error says it all
    _probe_scheduler(scheduler, timeout, security)
    try:
        client = Client(scheduler, timeout=timeout, set_as_default=False, security=security)
    except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError, ValueError for a bad address
        _silence_client_del()
        raise BackendError(f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s "
                           f"({type(exc).__name__}: {str(exc).splitlines()[0][:200] if str(exc) else 'no answer'})") from None
    logging.getLogger("distributed").setLevel(logging.WARNING)
    try:
        client.wait_for_workers(1, timeout=timeout)
    except Exception:  # noqa: BLE001 - TimeoutError
        client.close()
        raise BackendError(f"the Dask scheduler at {scheduler} has no workers (none joined within {timeout:g} s)") from None
    if check_version:
        from importlib.metadata import version

        try:
            versions = client.run(version, "optdesign")
        except Exception as exc:  # noqa: BLE001 - PackageNotFoundError on a worker
            client.close()
            raise BackendError(f"a Dask worker cannot import optdesign ({type(exc).__name__}); install it on every worker") from None
        mine = version("optdesign")
        wrong = {w: v for w, v in versions.items() if v != mine}
        if wrong:
            client.close()
            w, v = next(iter(wrong.items()))
            raise BackendError(f"Dask worker {w} has optdesign {v}, this client {mine}; install the same version everywhere")
    return client


def check_shared_folder(client, out_abs: str) -> None:
    """Every Dask worker must see the run folders' parent (a shared file system)."""
    marker = Path(out_abs) / f".optdesign-batch-{os.getpid()}-{os.urandom(4).hex()}"
    marker.write_text("")
    try:
        seen = client.run(os.path.exists, str(marker))
    finally:
        marker.unlink()
    blind = [w for w, ok in seen.items() if not ok]
    if blind:
        raise BackendError(f"Dask worker {blind[0]} does not see {out_abs}; with --backend dask, --out must be "
                           "a folder on a file system shared by this machine and every worker")


_check_shared_folder = check_shared_folder   # the name the tests have used


def run_batch(tasks: Sequence[Task], out: str = "runs", jobs: int | None = 2, backend: str = "local",
              scheduler: str | None = None, on_result=None, retries: int = 2, timeout: float = 10.0,
              client=None, reference_note=None) -> list[dict]:
    """Run tasks through joblib and return their rows (sorted by config and seed).

    ``local``: joblib's process pool (loky) with ``jobs`` workers.  If a
    worker process dies, the tasks without a result are submitted again (up
    to ``retries`` times); finished runs are then skipped and interrupted ones
    resumed.  ``dask``: joblib's Dask backend on the cluster at ``scheduler``
    (or the given ``client``); every worker thread takes runs (``jobs`` is
    not used: the cluster's size decides), each run is one Dask task, and a task lost with its worker is
    rescheduled by Dask on another worker (``retries`` more times if the task
    itself raises).  ``reference_note``: see :func:`optdesign.runner.run_outputs`.
    """
    from joblib import Parallel, delayed, parallel_config

    out_abs = str(Path(out).resolve())    # workers may have another working directory
    rows: dict[str, dict] = {}

    def collect(gen):
        for row in gen:
            rows[Path(row["folder"]).name] = row
            if on_result is not None:
                on_result(row)

    if backend == "local":
        from joblib.externals.loky.process_executor import TerminatedWorkerError

        Path(out_abs).mkdir(parents=True, exist_ok=True)
        _quiet_resource_tracker()
        attempt = 0
        while True:
            todo = [t for t in tasks if t.folder_name not in rows]
            if not todo:
                break
            try:
                with parallel_config(backend="loky", n_jobs=jobs or 2):
                    collect(Parallel(return_as="generator_unordered", batch_size=1)(
                        delayed(run_task)(t, out_abs, reference_note=reference_note) for t in todo))
                break
            except KeyboardInterrupt as exc:   # a signal (BatchInterrupted) or Ctrl-C: no worker outlives us
                # SIGINT to the group also reaches the workers, and a worker's KeyboardInterrupt
                # can come back through joblib before our own handler has run: the same
                # interruption.  Our signal, still pending, must not cut the kill short.
                with _signals_blocked():
                    _kill_local_workers()
                if not isinstance(exc, BatchInterrupted):
                    raise BatchInterrupted(signal.SIGINT) from None
                raise
            except TerminatedWorkerError as exc:
                attempt += 1
                if attempt > retries:
                    raise
                left = len([t for t in tasks if t.folder_name not in rows])
                print(f"batch: a worker process died ({type(exc).__name__}); resubmitting the {left} runs without "
                      "a result (finished ones are skipped, interrupted ones resumed)", file=sys.stderr)
    elif backend == "dask":
        own = client is None
        if own:
            if not scheduler:
                raise BackendError("--backend dask needs --scheduler tcp://HOST:PORT")
            client = connect_dask(scheduler, timeout)
        try:
            Path(out_abs).mkdir(parents=True, exist_ok=True)
            check_shared_folder(client, out_abs)
            # every run at once: Dask balances them over the worker threads (joblib's Dask
            # backend always uses all of them, whatever n_jobs says)
            with parallel_config(backend="dask", client=client, retries=retries, n_jobs=-1,
                                 wait_for_workers_timeout=timeout):
                collect(Parallel(return_as="generator_unordered", batch_size=1, pre_dispatch="all")(
                    delayed(run_task)(t, out_abs, reference_note=reference_note) for t in tasks))
        finally:
            if own:
                client.close()
    else:
        raise ValueError(f"unknown backend {backend!r}; expected local or dask")
    return sorted(rows.values(), key=lambda r: (str(r["config"]), r["seed"]))
