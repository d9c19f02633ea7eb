"""The switch of the compiled (numba) paths and the loader their kernel modules share.

A mechanism owns its compiled path (for example
:mod:`optdesign.mechanisms.p4s.compiled`) and answers
``Mechanism.global_statistics`` from it; this module only says whether compiled
paths may be used and loads kernel modules safely:

* the environment variable ``OPTDESIGN_FAST`` set to ``0`` (or
  ``false``/``off``/``no``), or :func:`set_enabled` / :func:`disabled`, turns every
  compiled path off (the numpy model, the reference, runs instead);
* :class:`KernelModule` imports a kernel module on first use and remembers a
  failure (numba missing, a compile error at the first call), after which the
  numpy path is used for the rest of the process, with one warning.

The numba options every kernel module uses are in :mod:`optdesign.fast._jit`.
"""
from __future__ import annotations

import importlib
import os
import warnings
from contextlib import contextmanager

__all__ = ["ENV_VAR", "enabled", "set_enabled", "disabled", "KernelModule", "set_compile_notice", "kernel_cache_present",
           "worth_compiling", "SMALL_WORK", "terminal_notice"]

ENV_VAR = "OPTDESIGN_FAST"

_override: bool | None = None


def enabled() -> bool:
    """Whether compiled paths may be used (``set_enabled`` first, then ``OPTDESIGN_FAST``)."""
    if _override is not None:
        return _override
    return os.environ.get(ENV_VAR, "1").strip().lower() not in ("0", "false", "off", "no")


#: design-points (designs x workspace points) below which a one-shot command
#: (``optdesign evaluate``) takes the numpy path unless OPTDESIGN_FAST=1 asks
#: for the compiled one: loading numba and the cached kernels costs about a
#: second, which the numpy path does not spend below this much work (10-100
#: thousand design-points a second for the described mechanisms)
SMALL_WORK = 50_000


def worth_compiling(work: int) -> bool:
    """Whether a one-shot computation of ``work`` design-points should take the
    compiled path: always when it was asked for (``set_enabled(True)``,
    ``OPTDESIGN_FAST=1``), never when switched off, else from SMALL_WORK on."""
    if _override is not None:
        return _override
    value = os.environ.get(ENV_VAR)
    if value is not None:
        return enabled()
    return work >= SMALL_WORK


def set_enabled(value: bool | None) -> None:
    """Force compiled paths on or off for this process; ``None`` returns to the environment variable."""
    global _override
    _override = value


@contextmanager
def disabled():
    """Context manager: the numpy path inside the block."""
    global _override
    old = _override
    _override = False
    try:
        yield
    finally:
        _override = old


def _passive_workers() -> None:
    # idle OpenMP workers must sleep, not spin: the optimizer alternates
    # kernel calls with numpy (OpenBLAS) work, and on a 2-core machine
    # spinning workers slow both down by two orders of magnitude
    # (docs/performance.md).  Read by libgomp when numba first loads it.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


#: called with a kernel module's name before it is first loaded without a cache (see set_compile_notice)
_compile_notice = None


def set_compile_notice(fn):
    """``fn(module_name)`` is called once, before the first kernel module whose
    compiled code is not in numba's cache compiles (once per machine); if it
    returns a callable, that is called with the seconds the compile took when
    it ends (its progress: see :func:`terminal_notice`).  None: no notice.
    Returns the previous one."""
    global _compile_notice
    old, _compile_notice = _compile_notice, fn
    return old


def terminal_notice(stream=None):
    """A compile notice for a terminal: one line on ``stream`` (stderr) that
    counts the seconds while the kernels compile, then says how long it took;
    nothing where the stream is not a terminal."""
    import sys
    import threading

    out = stream or sys.stderr

    def notice(name):
        if not getattr(out, "isatty", lambda: False)():
            return None
        text = "optdesign: compiling the engine's kernels (once per machine; every mechanism shape shares them)"
        stop = threading.Event()

        def tick():
            k = 0
            while not stop.wait(1.0):
                k += 1
                out.write(f"\r{text}: {k} s")
                out.flush()

        out.write(text)
        out.flush()
        th = threading.Thread(target=tick, daemon=True)
        th.start()

        def end(seconds):
            stop.set()
            th.join()
            out.write(f"\r{text}: done in {seconds:.0f} s\n")
            out.flush()
        return end
    return notice


def kernel_cache_present(module_name: str, pattern: str | None = None) -> bool:
    """Whether numba's cache holds index files of the module's kernels (where
    numba looks: NUMBA_CACHE_DIR, the module's __pycache__, the user's cache
    folder), or files matching ``pattern`` in that folder.  True when this
    cannot be told (no notice rather than a wrong one)."""
    try:
        from importlib.util import find_spec
        from pathlib import Path

        spec = find_spec(module_name)
        if spec is None or not spec.origin:
            return True
        from numba.core import config
        from numba.core.caching import _CacheLocator
        from numba.misc.appdirs import AppDirs

        src = Path(spec.origin)
        sub = _CacheLocator.get_suitable_cache_subpath(str(src))
        dirs = [src.parent / "__pycache__", Path(AppDirs(appname="numba", appauthor=False).user_cache_dir) / sub]
        if config.CACHE_DIR:   # numba then uses that folder alone
            dirs = [Path(config.CACHE_DIR) / sub]
        return any(d.is_dir() and any(d.glob(pattern or f"{src.stem}.*.nbi")) for d in dirs)
    except Exception:  # noqa: BLE001
        return True


class KernelModule:
    """A kernel module imported on first use; ``None`` from then on if that failed."""

    #: every kernel module declared so far (their caches tell whether a compile is ahead)
    instances: list = []

    def __init__(self, name: str, before_load=None):
        KernelModule.instances.append(self)
        self.name = name
        #: called (no arguments) before the module is first loaded; its errors are ignored
        self.before_load = before_load
        self.module = None
        self.error: BaseException | None = None
        #: the module was loaded with no cache of its kernels (they compile at their first call)
        self.cold = False

    def get(self):
        """The module, or None if it cannot be used here."""
        if self.module is None and self.error is None:
            _passive_workers()
            self.cold = not kernel_cache_present(self.name)
            if self.before_load is not None:
                try:
                    self.before_load()
                except Exception:  # noqa: BLE001 - a head start only
                    pass
            try:
                self.module = importlib.import_module(self.name)
            except Exception as exc:  # numba missing or broken: the numpy path
                self.error = exc
        return self.module

    @contextmanager
    def compiling(self):
        """Around a first call of the module's kernels: when they compile (no
        cache on this machine), the compile notice (once per process) and, if
        it returned one, its end with the seconds taken."""
        global _compile_notice
        if not self.cold or _compile_notice is None:
            yield
            return
        self.cold = False
        notice, _compile_notice = _compile_notice, None   # once: the other modules follow at once
        done = None
        try:
            done = notice(self.name)
        except Exception:  # noqa: BLE001 - a notice never stops the computation
            pass
        import time

        t0 = time.perf_counter()
        try:
            yield
        finally:
            if callable(done):
                try:
                    done(time.perf_counter() - t0)
                except Exception:  # noqa: BLE001
                    pass

    def require(self):
        """The module; RuntimeError if it cannot be used."""
        mod = self.get()
        if mod is None:
            raise RuntimeError(f"compiled kernels not available: {self.error}")
        return mod

    def available(self) -> bool:
        return self.get() is not None

    def fail(self, exc: BaseException | None) -> None:
        """Mark the module unusable (``exc``: why), or usable again (None; tests)."""
        self.module, self.error = None, exc

    def guarded(self, fn, *args):
        """``fn(*args)``, or None (with one warning, and this module off from now
        on) if it raises: a compile failure at the first call of a kernel.  A
        Ctrl-C or a signal inside the kernel is re-raised."""
        try:
            return fn(*args)
        except Exception as exc:
            cause = exc.__cause__ or exc.__context__
            if isinstance(cause, BaseException) and not isinstance(cause, Exception):
                raise cause from None
            self.fail(exc)
            warnings.warn(f"{self.name}: compiled kernel failed ({exc}); using the numpy path", RuntimeWarning)
            return None
