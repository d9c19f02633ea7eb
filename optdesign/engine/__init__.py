"""The one compiled engine of every mechanism with a compiled path.

A mechanism answers the seams ``global_statistics`` and ``local_values_at``
through four steps, the engine's protocol:

* **plan** (:func:`plan`): which of the requested local indices the kernel
  computes, as ids of the one table of local values :mod:`optdesign.formulas`
  (with the factor each request scales its value by);
* **pack** (the mechanism's): its shape as codes (pose type, pose-column
  kinds, leg kinds and branches) and its per-design constants as arrays
  (``L`` per leg, ``F`` per design; :mod:`.layout`), plus the frame data of
  the points;
* **kernel** (:func:`run`): :mod:`.kernels`, compiled once per machine for
  every shape (the size n and the kinds are data), run on the caller's
  threads;
* **merge** (:mod:`optdesign.fast.merge`): the points the kernel leaves to
  the numpy path (ill-conditioned, not finite) are evaluated there and
  merged into the statistics.

numba is imported only when a kernel is first run.
"""
from __future__ import annotations

import numpy as np

from ..fast import KernelModule
from ..formulas import DYN, NVAL, kernel_value
from . import warmup
from .layout import CHUNK

__all__ = ["KERNELS", "kernel_module", "plan", "run", "zoom", "workers", "specialize", "tier", "TIER_VAR"]

#: loaded at the first use; if the engine's routines are not compiled yet,
#: a helper process starts compiling its share of them then (:mod:`.warmup`)
KERNELS = KernelModule("optdesign.engine.kernels", before_load=warmup.start)


def kernel_module():
    """The kernel module, or None if numba is not usable here."""
    return KERNELS.get()


def plan(requests, dof: int, has_dynamics: bool):
    """[(name, kernel value, factor)] for the requests the kernel computes (the
    others are left to the numpy path): the ids and factors of
    optdesign.formulas.kernel_value."""
    out = []
    for r in requests:
        kv = kernel_value(r.kind, r.convention, r.options, dof)
        if kv is not None and (kv[0] != DYN or has_dynamics):
            out.append((r.name,) + kv)
    return out


#: the environment variable that chooses the routines: ``generic`` (one
#: compiled code for every shape), ``specialized`` (the shape's generated
#: code, compiled once per shape) or ``auto`` (the default: see :func:`tier`)
TIER_VAR = "OPTDESIGN_KERNEL"

#: shapes (KernelSpec) that run on their specialized routines in this process (see :func:`specialize`)
_SPECIALIZED: set = set()


def specialize(spec) -> None:
    """Run the shape ``spec`` on its specialized routines from now on in this
    process (a long computation, such as an optimization run, whose kernel
    time outweighs compiling them once per machine)."""
    _SPECIALIZED.add(spec)


def tier(spec):
    """The spec to pass to :func:`run` for the shape ``spec``: itself where its
    specialized routines are chosen, else None (the generic ones)."""
    import os

    mode = os.environ.get(TIER_VAR, "auto").strip().lower()
    if mode == "specialized":
        return spec
    if mode == "generic":
        return None
    return spec if spec in _SPECIALIZED else None


def workers() -> int:
    """The number of threads a kernel call runs on: numba's thread count
    (``numba.set_num_threads`` sets it, ``NUMBA_NUM_THREADS`` bounds it)."""
    import numba

    return int(numba.get_num_threads())


_POOL = None
_SELECTORS: dict = {}
_NO_KEEP = np.zeros((0, 0, 0))
#: the workers' scratch kept between calls, and who holds it
_BUF = None
_BUF_LOCK = __import__("threading").Lock()
#: the kernel has run in this process (generic tier: True, specialized: False), so it is compiled or loaded
_READY: dict = {}


def _selector(spec):
    """spec.numba_args(), made once per spec (a record array each call would cost more than the call)."""
    sel = _SELECTORS.get(spec)
    if sel is None:
        sel = _SELECTORS[spec] = spec.numba_args()
    return sel
#: design-points below which a call runs on the calling thread only
SMALL_CALL = 8192


def _pool(nw):
    global _POOL
    from concurrent.futures import ThreadPoolExecutor

    if _POOL is None or _POOL._max_workers < nw:
        _POOL = ThreadPoolExecutor(max_workers=nw, thread_name_prefix="optdesign-engine")
    return _POOL


def run(codes, L, F, FR, N, want, flags, keep=None, spec=None, stats=True):
    """The kernel over every design of L, F at the N points of the frame data
    FR: (stats (D, NVAL, 4), counts (D,), reach codes (D, N) int8), or None if
    the kernel cannot run here (a warning says why once).  keep (D, NVAL, N):
    receives every point's wanted values too; spec: a KernelSpec (the shape's
    generated routines, :mod:`.codegen`, compiled once per shape) or None (the
    generic ones, compiled once for every shape; the same results); stats
    False: (None, None, codes), the values in keep only.  The tasks (CHUNK points of one
    design) are shared among :func:`workers` threads in a fixed pattern, each
    task's results its own, so results do not depend on the thread count."""
    K = kernel_module()
    if K is None:
        return None
    ptype, ct, kind, branch = codes
    D = L.shape[0]
    nch = (N + CHUNK - 1) // CHUNK
    out_codes = np.empty((D, N), dtype=np.int8)        # every entry written by its task
    part = np.empty((D, nch, NVAL, 4))
    cnt = np.empty((D, nch), dtype=np.int64)
    keep = _NO_KEEP if keep is None else keep
    # small calls on this thread alone: waking a pool thread costs more than it saves
    nw = 1 if D * N < SMALL_CALL else max(1, min(workers(), D * nch))
    sel = None if spec is None else _selector(spec)
    buf, lock = _buffers(K, nw)
    try:
        return _run(K, nw, (ptype, ct, kind, branch, L, F, _read_only(FR), N, want, flags, out_codes, part, cnt, keep,
                            sel, buf),
                    sel, stats, part, cnt, want, out_codes)
    finally:
        if lock is not None:
            lock.release()


def zoom(codes, L, F, base, axes, lo, width, disc, u, val, h, live, budget, grid, stop, tol, value, want, flags,
         spec=None):
    """The worst-case search's zoom on a translation pose, every level in the
    kernel (:func:`.kernels.zoom`), in place on u (M, f), val, h, live (M,):
    (done (M,) levels, bail (M,) bool: stopped at a point the kernel leaves to
    the numpy path) or None if the kernel cannot run.  value: (id, factor) of
    the quantity."""
    K = kernel_module()
    if K is None or not _READY.get(spec is None):
        return None
    M = u.shape[0]
    done = np.zeros(M, dtype=np.int64)
    bail = np.zeros(M, dtype=np.bool_)
    sel = None if spec is None else _selector(spec)
    ptype, ct, kind, branch = codes
    uc = np.ascontiguousarray(u)        # one compiled signature: u in C order (and back into u below)
    buf, lock = _buffers(K, 1)
    try:
        KERNELS.guarded(K.zoom, ptype, ct, kind, branch, L, F, base, axes, lo, width, bool(disc), uc, val, h, live,
                        budget, done, bail, grid, float(stop), float(tol), int(value[0]), float(value[1]), want, flags,
                        sel, buf)
    finally:
        if lock is not None:
            lock.release()
    if uc is not u:
        u[...] = uc
    if KERNELS.module is None:
        return None
    return done, bail


def _read_only(a):
    """a as a read-only view: numba compiles a kernel once per argument type,
    and a read-only array is another type than a writeable one (the frame data
    come both ways, e.g. from np.broadcast_to): one signature, one compile."""
    if not a.flags.writeable:
        return a
    v = a.view()
    v.flags.writeable = False
    return v


def _buffers(K, nw):
    """(buf (nw, WORDS), lock or None): the workers' scratch kept between calls
    (zeroed once), or a fresh one while another thread's call holds it."""
    global _BUF
    if _BUF_LOCK.acquire(blocking=False):
        if _BUF is None or _BUF.shape[0] < nw:
            _BUF = np.zeros((nw, K.WORDS))
        return _BUF, _BUF_LOCK
    return np.zeros((nw, K.WORDS)), None


def _run(K, nw, args, sel, stats, part, cnt, want, out_codes):
    """The kernel's call on nw threads (see :func:`run`)."""

    def task(w):
        return K.run_tasks(w, nw, *args)

    ready = _READY.get(sel is None)
    if nw == 1 and ready:
        # the common small call (a search's few poses): no pool, no notice
        KERNELS.guarded(K.run_tasks, 0, 1, *args)
    elif nw > 1 and ready:
        # the other shares on the pool's threads, this one here (the kernel releases the GIL)
        futures = [_pool(nw - 1).submit(task, w) for w in range(1, nw)]
        KERNELS.guarded(task, 0)
        for f in futures:
            f.result()
    else:
        # one thread, or the machine's first call (it compiles the kernel): this thread's share first
        with KERNELS.compiling():
            if sel is None:
                warmup.finish(args)       # the routines on two processes, where none is cached yet
            KERNELS.guarded(task, 0)
        if KERNELS.module is None:      # it failed (a warning said why): the numpy path from now on
            return None
        _READY[sel is None] = True
        if nw > 1:
            futures = [_pool(nw - 1).submit(task, w) for w in range(1, nw)]
            for f in futures:
                f.result()
    if KERNELS.module is None:
        return None
    if not stats:
        return None, None, out_codes
    st, counts = K.combine(part, cnt, want)
    return st, counts, out_codes
