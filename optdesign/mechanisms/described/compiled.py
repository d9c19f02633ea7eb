"""The compiled path of described mechanisms: the seam ``global_statistics``.

One generic kernel (:mod:`._kernels`) serves every leg kind and pose type;
what differs between mechanisms is data: the per-design constant arrays
packed here from :class:`~.constants.Constants` (evaluated from the
expressions in numpy, vectorized over the designs).

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
from ...engine import plan
from ...engine import layout as K
from ...fast import enabled
from ...fast.merge import add_points
from ...formulas import COL0, DYN, FRO, NVAL, SMIN, SMIN2, TWO, Operands, select, singular_values
from ..base import IndexRequest

__all__ = ["IndexRequest", "global_statistics", "local_values", "local_values_at", "reach_codes", "plan", "kernels",
           "pack"]


_PTYPE = {"translation": 0, "planar": 1, "rotation": 2, "spatial": 3}
#: pose-column kinds of the kernel in the rates convention: a twist component, or roll's / pitch's Euler column
_RATE_COLUMN = {"x": 0, "y": 1, "z": 2, "roll": 6, "pitch": 7, "yaw": 5}


def pack(mech):
    """(codes: ptype, ct, kind, branch; L (D, n, NL); F (D, NF), D) for the designs
    of mech, computed once per mechanism (its parameters do not change: the
    worst-case search calls the kernel thousands of times for one design)."""
    memo = mech.__dict__.get("_engine_pack")
    if memo is None:
        memo = _pack(mech)
        mech.__dict__["_engine_pack"] = memo
    return memo


def _pack(mech):
    C = mech.constants
    shape = C.shape
    if len(shape) > 2 or (len(shape) == 2 and shape[1] != 1):
        raise ValueError(f"design parameters of shape {shape}: expected (D,) or (D, 1)")
    D = int(np.prod(shape)) if shape else 1
    n = len(C.kind)

    def per_design(a, tail):
        return np.broadcast_to(np.asarray(a, dtype=float), shape + tail).reshape((D,) + tail)

    L = np.empty((D, n, K.NL))
    L[:, :, K.LA:K.LA + 3] = per_design(C.A, (n, 3))
    L[:, :, K.LP:K.LP + 3] = per_design(C.P, (n, 3))
    L[:, :, K.LU:K.LU + 3] = per_design(C.U, (n, 3))
    L[:, :, K.LR0:K.LR0 + 3] = per_design(C.R0, (n, 3))
    L[:, :, K.LS0:K.LS0 + 3] = per_design(C.S0, (n, 3))
    L[:, :, K.LLA] = per_design(C.La, (n,))
    L[:, :, K.LLR] = per_design(C.Lr, (n,))
    B = {k: per_design(v, (n,)) for k, v in C.body.items()}
    kind = C.kind
    L[:, :, K.LMACT] = np.where(kind == 0, B["slider_mass"], np.where(kind == 1, B["crank_inertia"], 0.0))
    L[:, :, K.LMROD] = np.where(kind != 2, B["rod_mass"] * B["rod_count"], 0.0)
    L[:, :, K.LIROD] = np.where(kind != 2, B["rod_inertia"] * B["rod_count"], 0.0)
    L[:, :, K.LFROD] = B["rod_centre"]
    L[:, :, K.LM1] = np.where(kind == 2, B["lower_mass"], 0.0)
    L[:, :, K.LE1] = B["lower_centre"]
    L[:, :, K.LM2] = np.where(kind == 2, B["upper_mass"], 0.0)
    L[:, :, K.LE2] = B["upper_centre"]
    L[:, :, K.LI12] = np.where(kind == 2, B["lower_inertia"] + B["upper_inertia"], 0.0)
    L[:, :, K.LSG] = per_design(C.sign, (n,))
    F = np.empty((D, K.NF))
    F[:, K.FCEN:K.FCEN + 3] = per_design(C.centre, (3,))
    F[:, K.FFIX:K.FFIX + 3] = per_design(C.fixed, (3,))
    F[:, K.FMP] = per_design(C.m_platform, ())
    F[:, K.FIP:K.FIP + 9] = per_design(C.I_platform, (3, 3)).reshape(D, 9)
    F[:, K.FCOM:K.FCOM + 3] = per_design(C.com, (3,))
    return shape_codes(mech), L, F, D


def shape_codes(mech):
    """(ptype, ct, kind, branch): the pose type, the pose-column kinds, the leg
    kinds and branches of mech (the same for all its designs)."""
    from .poses import twist_columns

    spec = mech.pose_spec
    ptype = _PTYPE[spec.type]
    if spec.jacobian == "angular_velocity" or ptype < 2:
        ct = np.array(twist_columns(spec), dtype=np.int64)
    else:
        ct = np.array([_RATE_COLUMN[r] for r in spec.roles], dtype=np.int64)
    C = mech.constants
    return (ptype, ct, np.ascontiguousarray(C.kind, dtype=np.int64), np.ascontiguousarray(C.branch, dtype=np.int64))


def kernel_spec(codes):
    """The specialized tier's compile-time choices (a KernelSpec) for pack's codes."""
    from ...engine.codegen import KernelSpec

    ptype, ct, kind, _ = codes
    key = (ptype, ct.tobytes(), kind.tobytes())
    spec = _SPECS.get(key)
    if spec is None:
        spec = _SPECS[key] = KernelSpec(tuple(ct), bool(np.any(kind != 2)), ptype != 0)
    return spec


#: KernelSpec of each shape seen (the worst-case search asks thousands of times)
_SPECS: dict = {}


def kernel_source(mech, title: str) -> str:
    """The generated routines of the kernel for mech's shape as a module's source."""
    from ...engine.codegen import module_source

    return module_source(kernel_spec(shape_codes(mech)), title)


def frame_rows(mech, X, fixed):
    """The kernel's per-point frame data (g, N, rows) from the numpy path's own
    frames (optdesign.mechanisms.described.poses), for fixed angles (g, 1, 3)
    shaped as the numpy path's design axis: the origin from the pose (0 for a
    rotation pose, whose centre the kernel adds), R (not for translation
    poses) and the entries of the Euler columns (rotation and spatial poses)."""
    from .poses import frames

    spec = mech.pose_spec
    g, N = fixed.shape[0], X.shape[0]
    if spec.type == "translation":
        # the origin is the pose itself (frames' x + 0 differs from x only in the sign of a zero)
        return np.ascontiguousarray(X, dtype=float)[None]
    out = np.zeros((g, N, K.FR_ROWS[_PTYPE[spec.type]]))
    fr = frames(spec, X, np.zeros(3), fixed)
    if spec.type != "rotation":
        out[:, :, K.FRO_:K.FRO_ + 3] = fr.origin
    out[:, :, K.FRR:K.FRR + 9] = np.broadcast_to(fr.R, (g, N, 3, 3)).reshape(g, N, 9)
    if spec.type in ("rotation", "spatial"):
        cp, sp = np.cos(fr.angles["pitch"]), np.sin(fr.angles["pitch"])
        cy, sy = np.cos(fr.angles["yaw"]), np.sin(fr.angles["yaw"])
        for k, v in enumerate((cy * cp, sy * cp, -sp, -sy, cy)):
            out[:, :, K.FRE + k] = v
    return out


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


def _local_numpy(kind, conv, opts, J, svJ, svM):
    """The numpy path's local value of one index (its row of the table
    optdesign.formulas.VALUES, as optdesign.indices computes it, so the values
    are the same); svJ, svM: singular_values(J), singular_values(M) computed once."""
    opts = {**opts, "k": float(opts.get("k", 1.0))}
    row, c, a = select(kind, conv, opts, J.shape[-1])
    return row.value(Operands(J=J, svJ=svJ, svM=svM), c, a)


def _mass_at(KM, mech, codes, L, F, X, dd, jj):
    """The kernel's M_p (K, n, n) at the pairs (design dd[i], point jj[i]), dd
    sorted: each design's points in blocks of their own."""
    ptype, ct, kind, branch = codes
    n = len(kind)
    starts = np.flatnonzero(np.r_[True, dd[1:] != dd[:-1]])
    ends = np.r_[starts[1:], len(dd)]
    fix = F[:, K.FFIX:K.FFIX + 3]
    frs, nbs = [], []
    for a, b in zip(starts, ends):
        fr = frame_rows(mech, X[jj[a:b]], fix[dd[a]:dd[a] + 1, None, :])[0]
        nb = -(-(b - a) // K.BLK)
        frs.append(np.concatenate([fr, np.zeros((nb * K.BLK - (b - a), fr.shape[1]))]))
        nbs.append(nb)
    bd = np.repeat(dd[starts].astype(np.int64), nbs)
    Mp = KM.mass_blocks(ptype, ct, kind, branch, L, F, np.concatenate(frs), bd, None)
    Mp = Mp.reshape(-1, n * n, K.BLK).transpose(0, 2, 1).reshape(-1, n, n)
    offs = np.cumsum([0] + nbs[:-1]) * K.BLK
    rows = np.concatenate([o + np.arange(b - a) for a, b, o in zip(starts, ends, offs)])
    return Mp[rows]


def _take(C, dd):
    """The Constants C (design shape S) at the designs dd (shape (K,))."""
    import dataclasses

    S = C.shape
    D = int(np.prod(S)) if S else 1

    def take(a):
        a = np.asarray(a)
        tail = a.shape[len(S):]
        return np.broadcast_to(a, S + tail).reshape((D,) + tail)[dd]

    out = {}
    for f in dataclasses.fields(C):
        v = getattr(C, f.name)
        if f.name == "shape":
            out[f.name] = (len(dd),)
        elif f.name in ("kind", "branch"):
            out[f.name] = v
        elif isinstance(v, dict):
            out[f.name] = {k: take(x) for k, x in v.items()}
        else:
            out[f.name] = take(v)
    return type(C)(**out)


def _numpy_values(mech, X, dd, jj, entries, KM=None, packed=None):
    """The numpy path's local values (len(entries), K) at the pairs (design dd[i], point jj[i]):
    J from the numpy path itself; for the dynamic index M = J^-T M_p with the
    kernel's M_p (packed: pack(mech)) where the kernel is given.  A mechanism
    that is the description of a hand-written one names that one as its
    ``numpy_reference`` (the same designs): its own numpy model gives J and M."""
    from .mechanism import _solve_T

    ref = getattr(mech, "numpy_reference", None)
    if ref is not None:
        return _reference_values(ref, X, dd, jj, entries)
    C = mech.constants
    shape = C.shape
    D = int(np.prod(shape)) if shape else 1
    params = {k: np.broadcast_to(np.asarray(v, dtype=float), shape).reshape(D)[dd] if np.ndim(v) else v
              for k, v in mech.params.items()}
    sub = type(mech)(**params)
    # its constants: the mechanism's own at the designs dd (the same numbers
    # its expressions would give, without evaluating them again)
    sub.__dict__["_constants"] = _take(C, dd)
    X = np.asarray(X, dtype=float)
    Xk = X[jj]
    dyn = any(e[0] == "dynamic" for e in entries)
    with np.errstate(all="ignore"):
        if dyn and KM is not None:
            J = sub.index_matrices(Xk, {"J"})["J"]
            codes, L, F, _ = packed
            M = _solve_T(J, _mass_at(KM, mech, codes, L, F, X, dd, jj))
        else:
            mats = sub.index_matrices(Xk, {"J"} | ({"M"} if dyn else set()))
            J, M = mats["J"], mats.get("M")
        svJ = singular_values(J) if any(e[0] in ("stiffness", "isotropy", "dexterity") for e in entries) else None
        svM = singular_values(M) if dyn else None
        return np.stack([_local_numpy(kind, conv, opts, J, svJ, svM) for kind, conv, opts in entries])


def _reference_values(ref, X, dd, jj, entries):
    """:func:`_numpy_values` from the hand-written mechanism ``ref`` (its numpy model)."""
    shape = ref.design_shape
    D = int(np.prod(shape)) if shape else 1
    params = {k: np.broadcast_to(np.asarray(v, dtype=float), shape).reshape(D)[dd] if np.ndim(v) else v
              for k, v in ref.params.items()}
    sub = type(ref)(**params)
    dyn = any(e[0] == "dynamic" for e in entries)
    with np.errstate(all="ignore"):
        mats = sub.index_matrices(np.asarray(X, dtype=float)[jj], {"J"} | ({"M"} if dyn else set()))
        J, M = mats["J"], mats.get("M")
        svJ = singular_values(J) if any(e[0] in ("stiffness", "isotropy", "dexterity") for e in entries) else None
        svM = singular_values(M) if dyn else None
        return np.stack([_local_numpy(kind, conv, opts, J, svJ, svM) for kind, conv, opts in entries])


def _merge(stats, counts, extra, dd):
    """Add values extra (V, K) of designs dd (K,) to per-design (sum, min, max, M2) stats (D, V, 4)."""
    stats = stats.copy()
    for v in range(extra.shape[0]):
        stats[:, v, :] = add_points(stats[:, v, :].T, counts, extra[v], dd).T
    return stats, counts + np.bincount(dd, minlength=counts.shape[0])


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
    stats, counts, cd = res
    # per request: the kernel's sums scaled by the request's factor (factors are positive)
    names = [name for name, _, _ in pl] + (["_max_cond_2"] if want_max_cond else [])
    scales = [(v, fac) for _, v, fac in pl] + ([(TWO, 1.0)] if want_max_cond else [])
    st = np.stack([stats[:, v, :] * np.array([fac, fac, fac, fac * fac]) for v, fac in scales], axis=1)
    dd, jj = np.nonzero(cd == 2)
    if len(dd):
        byname = {r.name: r for r in requests}
        entries = [(byname[nm].kind, byname[nm].convention, dict(byname[nm].options or ())) for nm, _, _ in pl]
        if want_max_cond:
            entries.append(("isotropy", "two_norm", {}))
        extra = _numpy_values(mech, X, dd, jj, entries, KM, (codes, L, F, D))
        st, counts = _merge(st, counts, extra, dd)
    ok = counts > 0
    summary = {}
    with np.errstate(all="ignore"):
        for i, name in enumerate(names):
            mean = np.where(ok, st[:, i, 0] / counts, np.nan)
            summary[name] = {"mean": mean, "min": np.where(ok, st[:, i, 1], np.nan),
                             "max": np.where(ok, st[:, i, 2], np.nan),
                             "std": np.where(ok & np.isfinite(mean), np.sqrt(st[:, i, 3] / counts), np.nan),
                             "count": counts}
    if want_max_cond:
        summary["_max_cond_2"] = summary["_max_cond_2"]["max"]
    return summary, cd != 0


def _flags(want, codes):
    """The kernel's flags (dynamic, sigma_min, sigma_max, column norms, rods, rotations) for the wanted values."""
    ptype, _, kind, _ = codes
    return (bool(want[DYN]), bool(want[SMIN] or want[SMIN2] or want[TWO]), bool(want[TWO]),
            bool(want[COL0:].any()), kernel_spec(codes).rods, ptype != 0)


def _plan_of(mech, requests):
    """(plan, want, flags) of the requests for mech's shape, kept per request
    list (the worst-case search asks with the same requests thousands of times)."""
    key = tuple((r.name, r.kind, r.convention, tuple(sorted((r.options or {}).items()))
                 if isinstance(r.options, dict) else r.options) for r in requests)
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
    cd = res[2]
    out = {}
    for name, v, fac in pl:
        out[name] = keep[:, v, :] * fac if fac != 1.0 else keep[:, v, :].copy()
    dd, kk = np.nonzero(cd == 2)
    if len(dd):
        byname = {r.name: r for r in requests}
        entries = [(byname[nm].kind, byname[nm].convention, dict(byname[nm].options or ())) for nm, _, _ in pl]
        if per_design:
            extra = _numpy_values(mech, X.reshape(D * n_pts, -1), dd, dd * n_pts + kk, entries, KM, (codes, L, F, D))
        else:
            extra = _numpy_values(mech, X, dd, kk, entries, KM, (codes, L, F, D))
        for i, (name, _, _) in enumerate(pl):
            out[name][dd, kk] = extra[i]
    reach = cd != 0
    for x in out.values():
        x[~reach] = np.nan
    return out, reach


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


def reach_codes(mech, X) -> np.ndarray:
    """The kernel's reach codes (D, N): 0 unreachable, 1 reachable, 2 left to the numpy path."""
    codes, L, F, D = pack(mech)
    want = np.zeros(NVAL, dtype=np.bool_)
    want[FRO] = True
    return _run_kernel(mech, codes, L, F, np.asarray(X, dtype=float), want)[2]
