"""The engine's entry for chain mechanisms (docs/lower-mobility.md): the
kernel of :mod:`.chain_kernels` over every (design, point) task, on the
threads of :mod:`optdesign.engine` (the same pool and worker count), with the
same chunk statistics as :func:`optdesign.engine.run`, so results do not
depend on the thread count.  The packing is the mechanism's
(:mod:`optdesign.mechanisms.described.chain_compiled`); numba is imported
only when the kernel is first run."""
from __future__ import annotations

import numpy as np

from ..fast import KernelModule
from ..formulas import NVAL
from .layout import CHUNK

__all__ = ["CHAIN_KERNELS", "run_chain"]

CHAIN_KERNELS = KernelModule("optdesign.engine.chain_kernels")

#: design-points below which a call runs on the calling thread only (a chain
#: point costs tens of microseconds: a pool pays off sooner than the described kernel's)
SMALL_CALL = 256
_NO_KEEP = np.zeros((0, 0, 0))
#: the kernel has run in this process (compiled or loaded from numba's cache)
_READY = [False]


def run_chain(ints, VF, LF, SF, BF, GF, UH, PX, want, flags, keep=None, stats=True):
    """The chain kernel over every design of the packed arrays at the N points
    of PX (1 or D, N, n + n n): (stats (D, NVAL, 4), counts (D,), reach codes
    (D, N) int8) as :func:`optdesign.engine.run`, or None if the kernel
    cannot run here (a warning says why once).  keep (D, NVAL, N): receives
    every point's wanted values; stats False: (None, None, codes)."""
    from . import _pool, workers

    CK = CHAIN_KERNELS.get()
    if CK is None:
        return None
    D = GF.shape[0]
    N = PX.shape[1]
    n = int(ints[0][2])
    if PX.ndim != 3 or PX.shape[2] != n + n * n or PX.shape[0] not in (1, D):
        raise ValueError(f"points of shape {PX.shape}: expected (1 or {D}, N, {n + n * n})")
    nch = (N + CHUNK - 1) // CHUNK
    codes = np.empty((D, N), dtype=np.int8)
    part = np.empty((D, nch, NVAL, 4))
    cnt = np.empty((D, nch), dtype=np.int64)
    keep = _NO_KEEP if keep is None else keep
    nw = 1 if D * N < SMALL_CALL else max(1, min(workers(), D * nch))
    buf = np.zeros((nw, CK.WORDS))
    args = (ints, VF, LF, SF, BF, GF, UH, PX, N, want, flags, codes, part, cnt, keep, buf)

    def task(w):
        return CK.run_tasks(w, nw, *args)

    if not _READY[0]:
        # the machine's first call compiles the kernel (or loads it): this thread's share first
        with CHAIN_KERNELS.compiling():
            CHAIN_KERNELS.guarded(task, 0)
        if CHAIN_KERNELS.module is None:
            return None
        _READY[0] = True
        first = 1
    else:
        first = 0
    if nw > 1:
        futures = [_pool(nw - 1).submit(task, w) for w in range(1, nw)]
        if not first:
            CHAIN_KERNELS.guarded(task, 0)
        for f in futures:
            f.result()
    elif not first:
        CHAIN_KERNELS.guarded(task, 0)
    if CHAIN_KERNELS.module is None:
        return None
    if not stats:
        return None, None, codes
    st, counts = CK.combine(part, cnt, want)
    return st, counts, codes
