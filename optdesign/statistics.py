"""Statistics over W of the local indices of a population of designs: the
compiled path's answer where the mechanism has one (``global_statistics``,
``local_values``), the numpy path otherwise; the weighted quadrature, the
adaptive cubature's means and the error estimate of each mean (the
workspace's error rule).  Used by :mod:`optdesign.evaluate`; no config here."""
from __future__ import annotations

import numpy as np

from .cubature import integrate
from .indices import INDEX_KINDS, global_summary, local_index, weighted_summary
from .mechanisms import Mechanism
from .mechanisms.base import IndexRequest
from .workspace import Workspace

__all__ = ["local_values", "statistics", "adaptive_means", "mean_errors"]


def local_values(mech: Mechanism, X: np.ndarray, requests: list[IndexRequest], D: int):
    """(local values {name: (D, N)}, reachable (D, N)): the mechanism's compiled
    local values when it has them, else the numpy path."""
    fast = mech.local_values(requests, X)
    if fast is not None:
        vals, reach = fast
        return {k: np.broadcast_to(v, (D, X.shape[0])) for k, v in vals.items()}, np.broadcast_to(reach, (D, X.shape[0]))
    needs = {INDEX_KINDS[r.kind].needs for r in requests}
    with np.errstate(all="ignore"):
        st = mech.state(X)        # one inverse kinematics for the mask and the matrices
        reach = np.broadcast_to(st.reachable, (D, X.shape[0]))
        mats = st.matrices(needs)
        vals = {r.name: np.broadcast_to(local_index(r.kind, J=mats.get("J"), M=mats.get("M"), C=mats.get("C"),
                                                    convention=r.convention, options=r.option_dict()), reach.shape)
                for r in requests}
    return vals, reach


def _weighted_statistics(mech: Mechanism, X: np.ndarray, requests: list[IndexRequest], D: int, keep_local: bool,
                         weights: np.ndarray):
    vals, reach = local_values(mech, X, requests, D)
    with np.errstate(all="ignore"):
        summary = {k: weighted_summary(v, reach, weights) for k, v in vals.items()}
        local = {k: np.where(reach, v, np.nan) for k, v in vals.items()} if keep_local else None
    return summary, reach, local


def statistics(mech: Mechanism, X: np.ndarray, requests: list[IndexRequest], D: int, keep_local: bool,
                weights: np.ndarray | None = None):
    """(summary, reachable (D, N), local or None): the compiled path's answer
    for the requests it computes (never when local values are kept), the numpy
    path for the others (with the compiled path's reachable mask, which equals
    the numpy model's bitwise); with ``weights`` (N,) the weighted quadrature
    of the local values."""
    if weights is not None:
        return _weighted_statistics(mech, X, requests, D, keep_local, weights)
    reach = None
    if not keep_local:
        fast = mech.global_statistics(requests, X)
        if fast is not None:
            summary, reach = fast
            rest = [r for r in requests if r.name not in summary]
            if not rest:
                return summary, reach, None
            more, _, _ = _numpy_statistics(mech, X, rest, D, False, reach)
            return {**summary, **more}, reach, None
    return _numpy_statistics(mech, X, requests, D, keep_local, reach)


def _numpy_statistics(mech: Mechanism, X: np.ndarray, requests: list[IndexRequest], D: int, keep_local: bool,
                      reach: np.ndarray | None):
    needs = {INDEX_KINDS[r.kind].needs for r in requests}
    summary, local = {}, {}
    with np.errstate(all="ignore"):
        st = mech.state(X)        # one inverse kinematics for the mask and the matrices
        if reach is None:
            reach = np.broadcast_to(st.reachable, (D, X.shape[0]))
        mats = st.matrices(needs)
        for r in requests:
            vals = local_index(r.kind, J=mats.get("J"), M=mats.get("M"), C=mats.get("C"), convention=r.convention,
                               options=r.option_dict())
            vals = np.broadcast_to(vals, reach.shape)
            summary[r.name] = global_summary(vals, reach)
            if keep_local:
                local[r.name] = np.where(reach, vals, np.nan)
    return summary, reach, (local if keep_local else None)


def adaptive_means(mech: Mechanism, ws: Workspace, requests: list[IndexRequest], D: int, summary: dict):
    """``sampling: adaptive``: the cubature's means over W replace the starting
    rule's in ``summary`` (in place); returns (reachable fraction (D,), errors, statuses)."""
    spec = ws.spec
    res = integrate(lambda X: local_values(mech, X, requests, D), spec, ws.names, D, [r.name for r in requests],
                    spec.tolerance, spec.max_points)
    for k in res.mean:
        summary[k] = {"mean": res.mean[k], "min": res.min[k], "max": res.max[k], "std": res.std[k],
                      "count": res.count}
    return res.reachable_fraction, res.error, res.status


def mean_errors(mech: Mechanism, ws: Workspace, requests: list[IndexRequest], D: int, summary: dict) -> dict:
    """The error estimate (D,) of each mean of ``summary`` by the workspace's
    error rule (see :class:`~optdesign.workspace.ErrorRule`)."""
    rule = ws.error_rule
    names = [r.name for r in requests]
    if rule is None:
        return {k: np.full(D, np.nan) for k in names}
    if rule.method == "sample":
        out = {}
        for k in names:
            s = summary[k]
            with np.errstate(all="ignore"):
                out[k] = np.where(s["count"] > 1, s["std"] / np.sqrt(s["count"]), np.nan)
        return out
    means = [statistics(mech, r.X, requests, D, False, r.weights)[0] for r in rule.rules]
    out = {}
    with np.errstate(all="ignore"):
        for k in names:
            q = summary[k]["mean"]
            if rule.method == "scramblings":
                qs = np.stack([m[k]["mean"] for m in means])
                e = np.std(qs, axis=0, ddof=1) / np.sqrt(len(means))
            else:
                e = rule.factor * np.abs(q - means[0][k]["mean"])
            out[k] = np.where(np.isfinite(q) & np.isfinite(e), e, np.nan)
    return out
