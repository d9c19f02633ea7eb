"""The continuous search of :mod:`optdesign.worstcase`: W's region, the
diverse worst samples, the zoom (pattern) search and the projected gradient
ascent, vectorized over every (design, start) pair."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..workspace import Workspace

__all__ = ["FULL_GRID", "ITERATIONS", "STARTS", "TOL", "H", "maximize", "region"]

#: worst samples per design the search starts from
STARTS = 3
#: most ascent steps per start
ITERATIONS = 30
#: the search of a start ends when its step (unit coordinates of W) is below this
TOL = 5e-4
#: where the value decides feasibility, the best start zooms on down to this (unit coordinates of W) ...
FINE_TOL = 1e-10
#: ... in at most this many more levels
FINE_LEVELS = 60
#: the zoom search's neighbours: all 3^f - 1 up to this many free axes, the 2 f along the axes beyond
FULL_GRID = 3
#: finite-difference step (unit coordinates of W)
H = 1e-6


def region(ws: Workspace) -> dict:
    """W's free axes and bounds: ``{"axes": indices of the free pose axes,
    "lo", "hi": their bounds (SI), "disc": (cx, cy, r) or None}`` (a cylinder's
    disc lies in the first two axes, always free)."""
    spec, names = ws.spec, ws.names
    if spec.type == "cylinder":
        cx, cy = spec.center
        r = float(spec.radius)
        z = spec.axes.get(names[2], (0.0, 0.0))
        axes = [0, 1] + ([2] if z[1] > z[0] else [])
        lo = [cx - r, cy - r] + ([z[0]] if z[1] > z[0] else [])
        hi = [cx + r, cy + r] + ([z[1]] if z[1] > z[0] else [])
        return {"axes": np.array(axes), "lo": np.array(lo, float), "hi": np.array(hi, float),
                "disc": (float(cx), float(cy), r)}
    axes = [i for i, a in enumerate(names) if spec.axes[a][1] > spec.axes[a][0]]
    return {"axes": np.array(axes, int), "lo": np.array([spec.axes[names[i]][0] for i in axes], float),
            "hi": np.array([spec.axes[names[i]][1] for i in axes], float), "disc": None}


def _diverse_worst(sampled: np.ndarray, U: np.ndarray, k: int) -> np.ndarray:
    """(D, k) indices of the worst samples (D, N) of each design, picked
    greedily, each at least two spacings (unit coordinates U (N, f)) from
    the picks before; where no sample is left so far, the next worst."""
    D, N = sampled.shape
    r2 = (2.0 * max(N, 2) ** (-1.0 / U.shape[1])) ** 2
    free = np.ones((D, N), bool)
    score = np.where(np.isnan(sampled), np.inf, sampled)
    picks = []
    for _ in range(k):
        s = np.where(free, score, -np.inf)
        i = np.argmax(s, axis=1)
        none = ~np.isfinite(s[np.arange(D), i]) & (s[np.arange(D), i] < 0)
        if none.any():     # every sample near a pick: the next worst not yet picked
            taken = np.zeros((D, N), bool)
            for p in picks:
                taken[np.arange(D), p] = True
            i = np.where(none, np.argmax(np.where(taken, -np.inf, score), axis=1), i)
        picks.append(i)
        d2 = sum((U[None, :, j] - U[i, j][:, None]) ** 2 for j in range(U.shape[1]))
        free &= d2 > r2
    return np.stack(picks, axis=1)


def _project(u: np.ndarray, reg: dict) -> np.ndarray:
    """Unit coordinates (M, f) back into W: the box [0, 1]^f, and the disc."""
    u = np.clip(u, 0.0, 1.0)
    if reg["disc"] is not None:
        # the disc is the circle inscribed in the unit square of its two axes
        d = u[:, :2] - 0.5
        n = np.sqrt(np.sum(d * d, axis=1))
        s = np.where(n > 0.5, 0.5 / np.maximum(n, 1e-300), 1.0)
        u = u.copy()
        u[:, :2] = 0.5 + d * s[:, None]
    return u


def maximize(make: Callable[[np.ndarray], Callable[[np.ndarray], np.ndarray]], ws: Workspace, sampled: np.ndarray,
             starts: int = STARTS, stop: float = np.inf, iterations: int = ITERATIONS, tol: float = TOL,
             active: np.ndarray | None = None, method: str = "auto", hills: bool = False,
             refine: float = np.inf):
    """(max over W (D,), its pose (D, dof) SI) of a local quantity for D
    designs, whose values at the workspace points ``ws.X`` are ``sampled``
    (D, N) (inf where not reachable, NaN taken as inf).  ``make(index)``
    (index (M,): the design of each start) returns the quantity
    ``f(X) -> (K, M)`` at poses X (K, M, dof) (SI) of those designs (see
    :func:`local_functions`).  ``active`` (D,) bool: the designs to search
    (the others keep their sampled maximum).  ``method``: ``"zoom"``
    (:func:`_zoom`: one call of ``f`` per level on 3^f - 1 poses per start),
    ``"ascent"`` (:func:`_ascent`: one call per step on 1 + f poses per start)
    or ``"auto"`` (the default): the zoom where ``make.compiled`` says the
    quantity has a compiled path (many poses per call cost little there),
    the ascent otherwise (fewer poses: on the numpy path the zoom costs more).
    ``refine``: the zoom's best start of each design whose value is at or
    above this (next to the limit, where the answer decides feasibility)
    goes on zooming down to :data:`FINE_TOL` (a maximum at W's boundary
    next to a reach limit is a steep peak: at the coarse ``tol`` the value
    can be a percent low).  With ``hills`` a third item (D, starts, dof): the pose where each start's
    search ended (a local maximum on its own hill, NaN for a design not
    searched), so that a caller can hold every hill's maximum, not only the
    largest."""
    sampled = np.where(np.isnan(sampled), np.inf, sampled)
    D, N = sampled.shape
    X0 = ws.X
    best_i = np.argmax(sampled, axis=1) if N else np.zeros(D, int)
    best = sampled[np.arange(D), best_i] if N else np.full(D, -np.inf)
    pose = X0[best_i].copy() if N else np.zeros((D, len(ws.names)))
    reg = region(ws)
    k = min(starts, N)
    ends = np.full((D, max(k, 1), X0.shape[1] if N else len(ws.names)), np.nan)
    if reg["axes"].size == 0 or N == 0:
        return (best, pose, ends) if hills else (best, pose)
    todo = np.isfinite(best) & (best < stop)
    if active is not None:
        todo &= np.asarray(active, bool)
    d_idx = np.flatnonzero(todo)
    if d_idx.size == 0:
        return (best, pose, ends) if hills else (best, pose)
    axes, lo, hi = reg["axes"], reg["lo"], reg["hi"]
    width = hi - lo
    worst = _diverse_worst(sampled[d_idx], (X0[:, axes] - lo) / width, k)
    design = np.repeat(d_idx, k)                       # (M,) the design of each start
    start_pts = worst.reshape(-1)
    base = X0[start_pts].copy()                        # (M, dof) the fixed axes stay
    u = (base[:, axes] - lo) / width
    val = sampled[design, start_pts].copy()
    spacing = max(N, 2) ** (-1.0 / axes.size)          # the samples' spacing (unit coordinates)
    quantity = _Quantity(make, design, base, reg)
    if method == "auto":
        method = "zoom" if getattr(make, "compiled", False) else "ascent"
    if method == "ascent":
        _ascent(quantity, u, val, np.full(design.size, 0.5 * spacing), stop, iterations, tol)
    elif method == "zoom":
        _zoom(quantity, u, val, spacing, stop, tol, iterations)
    else:
        raise ValueError(f"method {method!r}: expected 'zoom' or 'ascent'")
    if method == "zoom" and np.isfinite(refine):
        _refine(make, design, base, reg, u, val, stop, refine, tol)
    # the best start of each design
    found = np.full(D, -np.inf)
    np.maximum.at(found, design, val)
    better = found > best
    for dd in np.flatnonzero(better):
        m = np.flatnonzero((design == dd) & (val == found[dd]))[0]
        X = base[m].copy()
        X[axes] = lo + u[m] * width
        pose[dd] = X
    best = np.where(better, found, best)
    if hills:
        P = base.copy()
        P[:, axes] = lo + u * width
        ends[d_idx] = P.reshape(d_idx.size, k, -1)
        return best, pose, ends
    return best, pose


def _refine(make, design, base, reg, u, val, stop, above, tol):
    """The zoom continued from ``tol`` down to :data:`FINE_TOL`, in place, for
    the best start of each design whose value is in [above, stop)."""
    order = np.lexsort((-val, design))                  # per design, its best start first
    first = order[np.r_[True, design[order][1:] != design[order][:-1]]]
    sel = first[np.isfinite(val[first]) & (val[first] >= above) & (val[first] < stop)]
    if sel.size == 0:
        return
    uu, vv = u[sel].copy(), val[sel].copy()
    _zoom(_Quantity(make, design[sel], base[sel], reg), uu, vv, 4.0 * tol, stop, FINE_TOL, FINE_LEVELS)
    u[sel], val[sel] = uu, vv


class _Quantity:
    """The quantity at unit coordinates P (K, M, f) of the starts ``rows``
    (M,) bool: (K, M) values (inf for NaN, -inf at the other starts); one
    mechanism of the live starts' designs, rebuilt when that set changes."""

    def __init__(self, make, design, base, reg):
        self.make, self.design, self.base, self.reg = make, design, base, reg
        self.key, self.f = None, None

    def compiled_zoom(self, u, val, h, live, budget, grid, stop, tol):
        """The zoom of every start in the compiled path (the quantity's
        ``zoom``: ``Mechanism.zoom_cond``), in place: (done, bail) or None."""
        f = self.make(self.design)
        z = getattr(f, "zoom", None)
        if z is None:
            return None
        return z(self.base, self.reg, u, val, h, live, budget, grid, stop, tol)

    def __call__(self, P, rows):
        v = np.full(P.shape[:2], -np.inf)
        r = np.flatnonzero(rows)
        if r.size:
            key = r.tobytes()
            if key != self.key:
                self.key, self.f = key, self.make(self.design[r])
            reg = self.reg
            X = np.broadcast_to(self.base[r], (P.shape[0], r.size) + self.base.shape[1:]).copy()
            X[..., reg["axes"]] = reg["lo"] + P[:, r] * (reg["hi"] - reg["lo"])
            with np.errstate(all="ignore"):
                vr = np.asarray(self.f(X), float)
            v[:, r] = np.where(np.isnan(vr), np.inf, vr)
        return v


def _settle(P, v, rows, u, val, stop):
    """Starts whose poses P (K, M, f) met a value (K, M) past the stop (or not
    finite) take it and end: the bool (M,) of those."""
    vmax = v.max(axis=0)
    hit = rows & ~(vmax < stop) & (vmax > val)
    if hit.any():
        jj = np.argmax(v, axis=0)
        h = np.flatnonzero(hit)
        u[h] = P[jj[h], h]
        val[h] = vmax[h]
    return hit


def _zoom(quantity, u, val, spacing, stop, tol, iterations):
    """The zoom search (a pattern search), in place on the starts' unit
    coordinates u (M, f) and values val (M,): each level evaluates the
    3^f - 1 neighbours of every live start at offsets of -h, 0, h per axis
    (projected into W; with more than ``FULL_GRID`` free axes the 2 f at -h
    and h along each axis), all starts in one call of the quantity, and moves each
    start to its best neighbour if that gains (keeping its h), else halves
    its h; h starts at half the samples' spacing, a start ends when its h is
    below ``tol`` (unit coordinates), its value passes ``stop`` or is not
    finite (infeasible), or after ``iterations`` levels.  Where the quantity's
    mechanism has the search in its compiled path (``Mechanism.zoom_cond``:
    every level in one call, the same operations) it runs there, and a start
    it hands back (it met a point left to the numpy path) goes on here."""
    n_free = u.shape[1]
    if n_free <= FULL_GRID:
        grid = np.stack(np.meshgrid(*[np.array([-1.0, 0.0, 1.0])] * n_free, indexing="ij"), axis=-1).reshape(-1, n_free)
        grid = grid[np.any(grid != 0, axis=1)]          # (3^f - 1, f): the centre is known
    else:                                               # (2 f, f): along the axes only
        grid = np.concatenate([np.eye(n_free), -np.eye(n_free)])
    h = np.full(u.shape[0], 0.5 * spacing)
    live = np.isfinite(val) & (val < stop)
    budget = np.full(u.shape[0], int(iterations), dtype=np.int64)
    fast = quantity.compiled_zoom(u, val, h, live, budget, grid, stop, tol) if live.any() else None
    if fast is not None:
        done, bail = fast
        live &= bail                                    # the starts handed back go on here, from their level
        budget = budget - done
    _levels(quantity, u, val, h, live, budget, grid, stop, tol)


def _levels(quantity, u, val, h, live, budget, grid, stop, tol):
    """The zoom's levels here, at most budget[m] for start m (see :func:`_zoom`)."""
    n_free = u.shape[1]
    cols = np.arange(u.shape[0])
    for level in range(int(budget.max(initial=0))):
        live &= level < budget
        if not live.any():
            break
        P = _project((u[None] + h[None, :, None] * grid[:, None]).reshape(-1, n_free),
                     quantity.reg).reshape(grid.shape[0], -1, n_free)
        v = quantity(P, live)
        j = np.argmax(v, axis=0)
        vj = v[j, cols]
        gain = live & (vj > val)
        u[gain], val[gain] = P[j[gain], cols[gain]], vj[gain]
        h[:] = np.where(gain, h, 0.5 * h)
        live &= (val < stop) & (h >= tol)               # past the stop or not finite: infeasible, the search ends


def _ascent(quantity, u, val, step, stop, iterations, tol):
    """The projected gradient ascent (the earlier search), in place on u (M, f)
    and val (M,): forward differences in unit coordinates (backward at an
    upper bound), a step along the normalized gradient that doubles on a gain
    and halves otherwise, from ``step`` (M,), until it is below ``tol`` or
    after ``iterations`` steps."""
    reg = quantity.reg
    n_free = u.shape[1]
    step = np.array(step, float)
    eye = np.eye(n_free) * H

    def probe(uu, rows):
        nb = [uu] + [np.where(uu[:, j:j + 1] + H <= 1.0, uu + eye[j], uu - eye[j]) for j in range(n_free)]
        P = np.stack([_project(q, reg) for q in nb])
        v = quantity(P, rows)
        with np.errstate(all="ignore"):
            g = np.stack([(v[1 + j] - v[0]) / (P[1 + j, :, j] - P[0, :, j]) for j in range(n_free)], axis=1)
        return P, v, np.where(np.isfinite(g), g, 0.0)

    live = np.isfinite(val) & (val < stop)
    P, v, g = probe(u, live)
    live &= ~_settle(P, v, live, u, val, stop)
    for _ in range(iterations):
        norm = np.sqrt(np.sum(g * g, axis=1))
        live &= norm > 0                                # a flat point (zero gradient): stationary
        if not live.any():
            break
        d = g / np.maximum(norm, 1e-300)[:, None]
        trial = _project(u + step[:, None] * d, reg)
        P, v, gt = probe(trial, live)
        gain = live & (v[0] > val)
        u[gain], val[gain], g[gain] = trial[gain], v[0][gain], gt[gain]
        step = np.where(live, np.where(gain, np.minimum(step * 2.0, 0.5), step * 0.5), step)
        live &= ~_settle(P, v, live, u, val, stop)      # a probed pose past the stop, gained or not
        live &= np.isfinite(val) & (val < stop) & (step >= tol)
