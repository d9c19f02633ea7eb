"""The points the engine leaves to the numpy path (ill-conditioned, not
finite): their local values from the numpy path's own matrices (optdesign.linalg
formulas of :mod:`optdesign.formulas`), merged into the engine's statistics."""
from __future__ import annotations

import numpy as np

from ...engine import layout as K
from ...fast.merge import add_points
from ...formulas import TWO, Operands, select, singular_values
from .packing import frame_rows

__all__ = ["entries_of", "merge", "numpy_values", "point_values_of", "summary_of"]

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


def numpy_values(mech, X, dd, jj, entries, KM=None, packed=None):
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


def merge(stats, counts, extra, dd):
    """Add values extra (V, K) of designs dd (K,) to per-design (sum, min, max, M2) stats (D, V, 4)."""
    stats = stats.copy()
    for v in range(extra.shape[0]):
        stats[:, v, :] = add_points(stats[:, v, :].T, counts, extra[v], dd).T
    return stats, counts + np.bincount(dd, minlength=counts.shape[0])


def entries_of(requests, pl) -> list:
    """(kind, convention, options) of each request of the plan ``pl``, as :func:`numpy_values` takes them."""
    byname = {r.name: r for r in requests}
    return [(byname[nm].kind, byname[nm].convention, dict(byname[nm].options or ())) for nm, _, _ in pl]


def summary_of(res, requests, pl, want_max_cond: bool, extra_values):
    """The seam ``global_statistics``'s answer from a kernel's result ``res``
    = (stats (D, NVAL, 4), counts (D,), codes (D, N)): per request of the plan
    ``pl`` its sums scaled by the request's factor (factors are positive), the
    points the kernel left to the numpy path (code 2) evaluated by
    ``extra_values(dd, jj, entries)`` and merged in; ``(summary, reachable)``."""
    stats, counts, cd = res
    names = [name for name, _, _ in pl] + (["_max_cond_2"] if want_max_cond else [])
    scales = [(v, fac) for _, v, fac in pl] + ([(TWO, 1.0)] if want_max_cond else [])
    st = np.stack([stats[:, v, :] * np.array([fac, fac, fac, fac * fac]) for v, fac in scales], axis=1)
    dd, jj = np.nonzero(cd == 2)
    if len(dd):
        entries = entries_of(requests, pl)
        if want_max_cond:
            entries.append(("isotropy", "two_norm", {}))
        st, counts = merge(st, counts, extra_values(dd, jj, entries), dd)
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


def point_values_of(keep, codes, requests, pl, X, per_design: bool, extra_values):
    """The seams ``local_values`` / ``local_values_at`` from a kernel's kept
    values ``keep`` (D, NVAL, K) and reach codes (D, K): per request of the plan
    ``pl`` its row scaled by its factor, the points left to the numpy path
    (code 2) from ``extra_values(X, dd, jj, entries)`` (X flattened to (D K,
    dof) when each design has its own points), NaN where not reachable;
    ``(values {name: (D, K)}, reachable (D, K))``."""
    D, _, K = keep.shape
    out = {name: (keep[:, v, :] * fac if fac != 1.0 else keep[:, v, :].copy()) for name, v, fac in pl}
    dd, kk = np.nonzero(codes == 2)
    if len(dd):
        entries = entries_of(requests, pl)
        if per_design:
            extra = extra_values(X.reshape(D * K, -1), dd, dd * K + kk, entries)
        else:
            extra = extra_values(X, dd, kk, entries)
        for i, (name, _, _) in enumerate(pl):
            out[name][dd, kk] = extra[i]
    reach = codes != 0
    for x in out.values():
        x[~reach] = np.nan
    return out, reach
