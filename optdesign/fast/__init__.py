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

__all__ = ["ENV_VAR", "enabled", "set_enabled", "disabled", "KernelModule", "set_compile_notice", "kernel_cache_present"]

ENV_VAR = "OPTDESIGN_FAST"

_override: bool | None = None


def enabled() -> bool:
    """Whether compiled paths may be used (``set_enabled`` first, then ``OPTDESIGN_FAST``)."""
    if _override is not None:
        return _override
    return os.environ.get(ENV_VAR, "1").strip().lower() not in ("0", "false", "off", "no")


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
    compiled code is not in numba's cache is loaded (its kernels then compile,
    which takes a while once per machine); None: no notice.  Returns the previous one."""
    global _compile_notice
    old, _compile_notice = _compile_notice, fn
    return old


def kernel_cache_present(module_name: str) -> bool:
    """Whether numba's cache holds index files of the module's kernels (where
    numba looks: NUMBA_CACHE_DIR, the module's __pycache__, the user's cache
    folder).  True when this cannot be told (no notice rather than a wrong one)."""
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
        return any(d.is_dir() and any(d.glob(f"{src.stem}.*.nbi")) for d in dirs)
    except Exception:  # noqa: BLE001
        return True


class KernelModule:
    """A kernel module imported on first use; ``None`` from then on if that failed."""

    #: every kernel module declared so far (their caches tell whether a compile is ahead)
    instances: list = []

    def __init__(self, name: str):
        KernelModule.instances.append(self)
        self.name = name
        self.module = None
        self.error: BaseException | None = None

    def get(self):
        """The module, or None if it cannot be used here."""
        if self.module is None and self.error is None:
            _passive_workers()
            global _compile_notice
            if _compile_notice is not None and not kernel_cache_present(self.name):
                notice, _compile_notice = _compile_notice, None   # once: the other modules follow at once
                try:
                    notice(self.name)
                except Exception:  # noqa: BLE001 - a notice never stops the computation
                    pass
            try:
                self.module = importlib.import_module(self.name)
            except Exception as exc:  # numba missing or broken: the numpy path
                self.error = exc
        return self.module

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
