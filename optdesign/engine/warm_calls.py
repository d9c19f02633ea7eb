"""The two lists of calls of :mod:`.warmup`: numba's type inference runs over
them (it compiles, and caches, every routine whose call it types); they are
never run and never compiled themselves.  Their arguments are made as the
kernel makes them (:func:`.kernels._carve` of a worker's buffer, the kernel's
own arguments), so they type to the signatures the kernel's calls ask for.

``python -m optdesign.engine.warm_calls PID`` is the helper process of
:func:`.warmup.start` (PID: its parent's; it stops when the parent does, on
Linux)."""
from __future__ import annotations

import os
import sys

import numba
from numba.core import compiler, typed_passes
from numba.core.registry import cpu_target

from .eigen import COLS, ROWS
from .kernels import _carve, _chunk_stats, _load_block, combine, dyn_sel, inverse_sel, lmax_sel
from .layout import BLK, GG, NEWTON, NEWTON_DYN, VLU
from .legs import legs, pose_rows, rigid

__all__ = ["here", "KERNEL_TYPES", "COMBINE_TYPES"]

_t = numba.types
_i1, _b1 = _t.Array(_t.int64, 1, "C"), _t.Array(_t.bool_, 1, "C")
#: :func:`.kernels.run_tasks`'s arguments as :func:`optdesign.engine.run` passes
#: them on the generic tier (tests/test_engine.py checks them)
KERNEL_TYPES = (_t.int64, _t.int64, _t.int64, _i1, _i1, _i1, _t.Array(_t.float64, 3, "C"),
                _t.Array(_t.float64, 2, "C"), _t.Array(_t.float64, 3, "C", readonly=True), _t.int64, _b1, _b1,
                _t.Array(_t.int8, 2, "C"), _t.Array(_t.float64, 4, "C"), _t.Array(_t.int64, 2, "C"),
                _t.Array(_t.float64, 3, "C"), _t.none, _t.Array(_t.float64, 2, "C"))
#: :func:`.kernels.combine`'s arguments as :func:`optdesign.engine.run` passes them
COMBINE_TYPES = (_t.Array(_t.float64, 4, "C"), _t.Array(_t.int64, 2, "C"), _t.Array(_t.bool_, 1, "C"))


def here_calls(w, nw, ptype, ct, kind, branch, L, F, FR, N, want, flags, codes, part, cnt, keep, sel, buf):
    """This process's share, as :func:`.kernels._block` makes the calls: the
    legs, the platform's rigid body, the mass matrix and the chunk statistics."""
    n = kind.shape[0]
    scratch, FRb, vals, cbuf = _carve(buf[w], n)
    Lg, mats, B, T, V, S = scratch
    d = w
    m = n
    dyn_, rods, rot = flags[0], flags[4], flags[5]
    _load_block(FR[0], d, m, FRb)
    legs(L, F, d, ptype, kind, branch, FRb, m, Lg, V, dyn_, rot)
    rigid(ptype, F, d, FRb, m, Lg, B, n, rot)
    dyn_sel(B, Lg, mats[0], mats[2], FRb, mats[1], mats[3], S, n, ct, rods, m, False, sel)
    cnt[d, d] = _chunk_stats(vals, cbuf, m, want, part[d, d])


def helper_calls(w, nw, ptype, ct, kind, branch, L, F, FR, N, want, flags, codes, part, cnt, keep, sel, buf):
    """The helper's share: the pose rows, the inverse and the largest
    eigenvalues, as :func:`.kernels._block`, :func:`.kernels.tail_j` and
    :func:`.kernels.tail_w` make the calls."""
    n = kind.shape[0]
    scratch, FRb, vals, cbuf = _carve(buf[w], n)
    Lg, mats, B, T, V, S = scratch
    m = n
    pose_rows(Lg, GG, ct, FRb, m, mats[0], n)
    inverse_sel(mats[0], mats[1], V, S, n, m, sel)
    lmax_sel(mats[1], V[VLU * BLK:(VLU + 1) * BLK], T, V, S, n, m, ROWS, NEWTON, sel)
    lmax_sel(mats[3], V[VLU * BLK:(VLU + 1) * BLK], T, V, S, n, m, COLS, NEWTON_DYN, sel)


def type_calls(fn, argtypes) -> None:
    """numba's type inference over fn's body for argtypes."""
    cpu_target.typing_context.refresh()
    ir = compiler.run_frontend(fn)
    typed_passes.type_inference_stage(cpu_target.typing_context, cpu_target.target_context, ir, tuple(argtypes), None)


def here(args) -> None:
    """This process's share for the kernel's first call with ``args`` (its
    arguments but the worker's number and count), then :func:`.kernels.combine`."""
    type_calls(here_calls, tuple(numba.typeof(a) for a in (0, 1) + tuple(args)))
    combine.compile(COMBINE_TYPES)


def _main() -> int:
    parent = int(sys.argv[1])
    try:
        import ctypes

        ctypes.CDLL(None).prctl(1, 9)          # PR_SET_PDEATHSIG: SIGKILL when the parent dies
    except Exception:  # noqa: BLE001
        pass
    if os.getppid() != parent:
        return 0
    type_calls(helper_calls, KERNEL_TYPES)
    return 0


if __name__ == "__main__":
    sys.exit(_main())
