"""The engine's first compile on two processes.

:func:`.kernels.run_tasks` links the engine's routines (:func:`.digest.leaf`:
the legs, the inverse, the largest eigenvalues, the mass matrix), each
compiled once per machine into numba's cache.  When none of this version is
cached yet (the first evaluation on a machine, or after an edit of the
engine), they compile on both cores before the kernel does:

* :func:`start`, called as the kernel module is first loaded, starts a helper
  process (``python -m optdesign.engine.warm_calls``) that compiles the
  routines of :func:`.warm_calls.helper_calls` into the cache;
* :func:`finish`, called before the kernel's first call, compiles those of
  :func:`.warm_calls.here_calls` and :func:`.kernels.combine` in this process
  and waits for the helper;
* the kernel then compiles itself, loading every routine from the cache.

The kernel's results do not depend on any of this: a routine the two lists
missed, or a helper that failed, is compiled by the kernel itself (the same
code), and only the time is lost.  This module imports neither numba nor the
kernels, so that the helper starts before this process loads them.
"""
from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

__all__ = ["start", "finish", "needed", "ENV_VAR"]

#: ``0`` turns the two-process first compile off (the kernel then compiles every routine itself)
ENV_VAR = "OPTDESIGN_WARMUP"
#: the longest wait for the helper (s); past it the kernel compiles what is missing
TIMEOUT = 300.0

_LOCK = threading.Lock()
_HELPER: subprocess.Popen | None = None
_DONE = False


def needed() -> bool:
    """Whether the engine's routines are still to be compiled: none of this
    version (:func:`.digest.leaf_key`) is in numba's cache, and the two-process
    compile is not turned off (:data:`ENV_VAR`)."""
    if os.environ.get(ENV_VAR, "1").strip() == "0":
        return False
    from ..fast import kernel_cache_present
    from .digest import leaf_key

    return not kernel_cache_present("optdesign.engine.kernels", f"legs.legs__{leaf_key()}-*.nbi")


def start() -> None:
    """Start the helper process if the routines are to be compiled (once per process)."""
    global _HELPER
    with _LOCK:
        if _HELPER is not None or _DONE or not needed():
            return
        env = dict(os.environ)
        top = str(Path(__file__).resolve().parents[2])      # the folder of this optdesign package
        env["PYTHONPATH"] = top + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        try:
            _HELPER = subprocess.Popen([sys.executable, "-m", "optdesign.engine.warm_calls", str(os.getpid())],
                                       stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                       stderr=subprocess.DEVNULL, env=env)
        except OSError:
            _HELPER = None


def finish(args) -> None:
    """Before the kernel's first call with ``args`` (its arguments but w, nw:
    the generic tier's): compile this process's share of the routines and wait
    for the helper's.  Does nothing if :func:`start` found them cached."""
    global _DONE, _HELPER
    with _LOCK:
        if _DONE:
            return
        _DONE = True
        helper, _HELPER = _HELPER, None
        if helper is None:
            return
        try:
            from .warm_calls import here

            here(args)
        except Exception:  # noqa: BLE001 - the kernel compiles what is missing
            pass
        except BaseException:       # a signal: the helper goes too
            _stop(helper)
            raise
        try:
            helper.wait(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            _stop(helper)
        except BaseException:
            _stop(helper)
            raise


def _stop(helper) -> None:
    helper.kill()
    helper.wait()
