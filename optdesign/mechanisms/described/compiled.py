"""The compiled path of described mechanisms: the seams ``global_statistics``,
``local_values`` and ``local_values_at``, on the one engine (:mod:`optdesign.engine`).

The engine's kernel serves every leg kind and pose type; what differs
between mechanisms is data: the per-design constant arrays packed from
:class:`~.constants.Constants` (:mod:`.packing`), the points the kernel
leaves to the numpy path evaluated there (:mod:`.fallback`).

``global_statistics(mech, requests, X)`` returns ``(summary, reachable)``
with ``summary[name] = {"mean", "min", "max", "std", "count"}`` (arrays (D,))
over the reachable points for the requests the kernel computes (every index
kind of optdesign.indices with its conventions and options ``k``, ``axis``;
the caller runs the numpy path for any other), or ``None`` when the compiled
path cannot answer (disabled with ``OPTDESIGN_FAST=0``, numba missing).
Points the kernel flags (``cond_F(J) >= 1000`` or not finite) are evaluated
with the numpy path's formulas (optdesign.linalg on this mechanism's own
matrices) and merged in, so the results equal the numpy path's to round-off
(1e-12 relative) and do not depend on the number of threads.  With
``want_max_cond`` the summary also has ``"_max_cond_2"``: the largest
cond_2(J) over the reachable points, (D,).
"""
from __future__ import annotations

import numpy as np

from ... import engine
from ...engine import kernel_module as kernels
from ...engine import layout as K
from ...engine import plan
from ...fast import enabled
from ...formulas import COL0, DYN, FRO, NVAL, SMIN, SMIN2, TWO
from ..base import IndexRequest
from .fallback import numpy_values, point_values_of, summary_of
from .packing import frame_rows, kernel_source, kernel_spec, pack, shape_codes  # noqa: F401 (the packing's names)

__all__ = ["IndexRequest", "global_statistics", "local_values", "local_values_at", "zoom_cond", "reach_codes", "plan",
           "kernels",
           "pack", "kernel_spec", "kernel_source", "frame_rows", "shape_codes"]


#: frame data per design at most this many values per kernel call (designs in groups beyond)
_FR_BUDGET = 4_000_000


#: summary's ``keep`` when no point's values are kept
_NO_KEEP = np.zeros((0, 0, 0))


def _run_kernel(mech, codes, L, F, X, want):
    """The kernel's (stats, counts, codes) for every design: one call when the
    frames are the same for all designs (a rotation pose's fixed angles do not
    vary), else per group of designs with their own frames."""
    N = X.shape[0]
    flags = _flags(want, codes)
    fix = F[:, K.FFIX:K.FFIX + 3]
    D = F.shape[0]
    spec = mech.pose_spec
    if spec.type != "rotation" or len(spec.roles) == 3 or np.all(fix == fix[0]):
        FR = frame_rows(mech, X, fix[:1, None, :])
        return engine.run(codes, L, F, FR, N, want, flags, spec=engine.tier(kernel_spec(codes)))
    step = max(1, _FR_BUDGET // (K.NFR * max(1, X.shape[0])))
    parts = []
    for lo in range(0, D, step):
        sl = slice(lo, min(D, lo + step))
        FR = frame_rows(mech, X, fix[sl, None, :])
        res = engine.run(codes, np.ascontiguousarray(L[sl]), np.ascontiguousarray(F[sl]), FR, N, want, flags,
                         spec=engine.tier(kernel_spec(codes)))
        if res is None:
            return None
        parts.append(res)
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(3))


def global_statistics(mech, requests, X, want_max_cond: bool = False):
    if not enabled():
        return None
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != mech.dof:
        return None
    KM = kernels()
    if KM is None:
        return None
    pl = plan(requests, mech.dof, mech.description.has_dynamics)
    if not pl and not want_max_cond:
        return None
    try:
        codes, L, F, D = pack(mech)
    except ValueError:
        return None
    rows = sorted({v for _, v, _ in pl} | ({TWO} if want_max_cond else set()))
    want = np.zeros(NVAL, dtype=np.bool_)
    want[rows] = True
    res = _run_kernel(mech, codes, L, F, X, want)
    if res is None:
        return None
    return summary_of(res, requests, pl, want_max_cond,
                      lambda dd, jj, entries: numpy_values(mech, X, dd, jj, entries, KM, (codes, L, F, D)))


def _flags(want, codes):
    """The kernel's flags (dynamic, sigma_min, sigma_max, column norms, rods,
    rotations) for the wanted values, as a bool array (numba types it fast)."""
    ptype, _, kind, _ = codes
    return np.array([want[DYN], want[SMIN] or want[SMIN2] or want[TWO], want[TWO], want[COL0:].any(),
                     kernel_spec(codes).rods, ptype != 0], dtype=np.bool_)


def _plan_of(mech, requests):
    """(plan, want, flags) of the requests for mech's shape, kept per request
    tuple (the worst-case search asks with the same requests thousands of times)."""
    key = tuple(requests)
    memo = mech.__dict__.setdefault("_engine_plans", {})
    got = memo.get(key)
    if got is None:
        pl = plan(requests, mech.dof, mech.description.has_dynamics)
        want = np.zeros(NVAL, dtype=np.bool_)
        want[sorted({v for _, v, _ in pl})] = True
        got = memo[key] = (pl, want, _flags(want, pack(mech)[0]))
    return got


def _same_frames(mech, F) -> bool:
    """Whether every design has the same frames (all but a rotation pose whose
    fixed angles differ between designs), kept per mechanism."""
    same = mech.__dict__.get("_engine_same")
    if same is None:
        fix = F[:, K.FFIX:K.FFIX + 3]
        spec = mech.pose_spec
        same = mech.__dict__["_engine_same"] = bool(spec.type != "rotation" or len(spec.roles) == 3
                                                    or np.all(fix == fix[0]))
    return same


def _point_values(mech, requests, X, per_design: bool):
    """Every point's values of the requests: X (D, K, dof) each design at its
    own points (per_design), or X (N, dof) shared by the designs; ``(values
    {name: (D, K)}, reachable (D, K))``, NaN where not reachable, or None when
    the kernel does not compute every request.  Points the kernel flags get the
    numpy path's values, as in :func:`global_statistics`."""
    if not enabled():
        return None
    X = np.asarray(X, dtype=float)
    KM = kernels()
    if KM is None or X.ndim != (3 if per_design else 2) or X.shape[-1] != mech.dof or X.shape[-2] == 0:
        return None
    try:
        codes, L, F, D = pack(mech)
    except ValueError:
        return None
    pl, want, flags = _plan_of(mech, requests)
    if len(pl) != len(requests):
        return None
    if per_design and X.shape[0] != D:
        return None
    ptype = codes[0]
    n_pts = X.shape[-2]
    rows = K.FR_ROWS[ptype]
    fix = F[:, K.FFIX:K.FFIX + 3]
    same = _same_frames(mech, F)
    if not per_design:
        if not same:     # a rotation pose whose fixed angles differ between designs: each design at the points
            return _point_values(mech, requests, np.broadcast_to(X, (D,) + X.shape), True)
        FR = frame_rows(mech, X, fix[:1, None, :])
    elif same:
        FR = frame_rows(mech, X.reshape(D * n_pts, -1), fix[:1, None, :])[0].reshape(D, n_pts, rows)
    else:       # each design's own frames
        FR = np.stack([frame_rows(mech, X[d], fix[d:d + 1, None, :])[0] for d in range(D)])
    keep = np.zeros((D, NVAL, n_pts))
    res = engine.run(codes, L, F, np.ascontiguousarray(FR), n_pts, want, flags, keep,
                     spec=engine.tier(kernel_spec(codes)), stats=False)
    if res is None:
        return None
    return point_values_of(keep, res[2], requests, pl, X, per_design,
                           lambda Xp, dd, jj, entries: numpy_values(mech, Xp, dd, jj, entries, KM, (codes, L, F, D)))


def local_values_at(mech, requests, X):
    """The seam ``Mechanism.local_values_at``: each of the D designs at its own
    K points X (D, K, dof), ``(values {name: (D, K)}, reachable (D, K))``, NaN
    where not reachable, or None when the kernel does not compute every
    request (the caller then runs the numpy path)."""
    return _point_values(mech, requests, X, True)


def local_values(mech, requests, X):
    """The seam ``Mechanism.local_values``: the D designs at the points X (N,
    dof), ``(values {name: (D, N)}, reachable (D, N))``, or None."""
    return _point_values(mech, requests, X, False)


def zoom_cond(mech, request, base, reg, u, val, h, live, budget, grid, stop, tol):
    """The seam ``Mechanism.zoom_cond``: the worst-case search's zoom (see
    optdesign.worstcase.search) of the request's value, each design m of mech
    from its start (base[m], u[m], val[m], h[m], live[m]), in the engine, in
    place: (done (M,) levels, bail (M,)) or None where it does not apply (not
    a translation pose, a request the kernel does not compute, the engine off)."""
    if not enabled() or mech.pose_spec.type != "translation":
        return None
    try:
        codes, L, F, D = pack(mech)
    except ValueError:
        return None
    pl, want, flags = _plan_of(mech, [request])
    if len(pl) != 1 or D != u.shape[0]:
        return None
    axes = np.ascontiguousarray(reg["axes"], dtype=np.int64)
    lo = np.ascontiguousarray(reg["lo"], dtype=float)
    width = np.ascontiguousarray(reg["hi"] - reg["lo"], dtype=float)
    return engine.zoom(codes, L, F, np.ascontiguousarray(base, dtype=float), axes, lo, width, reg["disc"] is not None,
                       u, val, h, live, budget, np.ascontiguousarray(grid, dtype=float), stop, tol, pl[0][1:], want,
                       flags, spec=engine.tier(kernel_spec(codes)))


def reach_codes(mech, X) -> np.ndarray:
    """The kernel's reach codes (D, N): 0 unreachable, 1 reachable, 2 left to the numpy path."""
    codes, L, F, D = pack(mech)
    want = np.zeros(NVAL, dtype=np.bool_)
    want[FRO] = True
    return _run_kernel(mech, codes, L, F, np.asarray(X, dtype=float), want)[2]
