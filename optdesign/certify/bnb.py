"""Branch and bound over boxes of the workspace W.

Each round takes a batch of boxes, asks the enclosure for a rigorous upper
bound of the constraint over each box and the float value at its midpoint:

* a box whose bound is <= the limit is proved (its volume counts);
* a midpoint whose float value exceeds the limit (or is not reachable)
  refutes the design: the pose and its value are the witness;
* any other box is bisected along its widest free coordinate (relative to
  W's extent on that axis).

The run stops when every box is proved (``certified``), at a refutation
(``refuted``) or when ``budget`` box evaluations are used (``unknown``, with
the share of W's volume proved).
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np

__all__ = ["branch_and_bound"]


def branch_and_bound(bound: Callable, value: Callable, lo: np.ndarray, hi: np.ndarray, limit: float,
                     budget: int = 1_000_000, batch: int = 8192, inside: Callable | None = None) -> dict:
    """``bound(lo, hi) -> (K,)`` upper bounds (inf: not proved), ``value(X) -> (K,)``
    float values at poses (inf where unreachable); ``lo, hi`` (dof,) W's box
    (an axis with lo == hi is fixed); ``inside(X) -> (K,)`` optional mask of
    poses in W (for regions that are not boxes; boxes entirely outside W are
    dropped by ``bound`` returning -inf)."""
    t0 = time.perf_counter()
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    free = hi > lo
    span = np.where(free, hi - lo, 1.0)
    total = float(np.prod(span[free])) if free.any() else 1.0
    stack_lo, stack_hi = [lo[None, :]], [hi[None, :]]
    proved, boxes, worst_open = 0.0, 0, -np.inf
    while stack_lo:
        L, H = np.concatenate(stack_lo), np.concatenate(stack_hi)
        take = min(batch, len(L), max(budget - boxes, 0))
        if take == 0:
            break
        bl, bh = L[-take:], H[-take:]
        stack_lo, stack_hi = [L[:-take]], [H[:-take]]
        boxes += take
        mid = 0.5 * bl + 0.5 * bh
        with np.errstate(all="ignore"):
            vals = np.asarray(value(mid), float)
        ok_mid = np.ones(take, bool) if inside is None else np.asarray(inside(mid), bool)
        bad = ok_mid & ~(vals <= limit)
        if bad.any():
            k = int(np.flatnonzero(bad)[np.argmax(np.where(np.isfinite(vals[bad]), vals[bad], np.inf))])
            return _result("refuted", boxes, proved / total, t0, witness=mid[k], value=float(vals[k]))
        with np.errstate(all="ignore"):
            ub = np.asarray(bound(bl, bh), float)
        vol = np.prod(np.where(free, bh - bl, 1.0), axis=-1) if free.any() else np.ones(take)
        done = ub <= limit
        proved += float(np.sum(vol[done & np.isfinite(ub)]))
        if np.any(ub == -np.inf):      # boxes outside W: nothing to prove, their volume is not W's
            done |= ub == -np.inf
        rest = ~done
        if not rest.any():
            continue
        worst_open = max(worst_open, float(np.max(ub[rest])))
        rl, rh = bl[rest], bh[rest]
        rel = np.where(free, (rh - rl) / span, -1.0)
        ax = np.argmax(rel, axis=-1)
        cut = 0.5 * rl[np.arange(len(rl)), ax] + 0.5 * rh[np.arange(len(rl)), ax]
        l2, h1 = rl.copy(), rh.copy()
        h1[np.arange(len(rl)), ax] = cut
        l2[np.arange(len(rl)), ax] = cut
        stack_lo += [rl, l2]
        stack_hi += [h1, rh]
    n_open = sum(len(s) for s in stack_lo)
    if n_open == 0:
        return _result("certified", boxes, 1.0, t0)
    return _result("unknown", boxes, min(proved / total, 1.0), t0, open_boxes=n_open)


def _result(status, boxes, share, t0, witness=None, value=None, open_boxes=0) -> dict:
    out = {"status": status, "witness": None if witness is None else [float(v) for v in witness],
           "value": value, "share_proved": float(share), "boxes": int(boxes),
           "seconds": time.perf_counter() - t0}
    if open_boxes:
        out["open_boxes"] = int(open_boxes)
    return out
