"""Certificates of single designs: the branch and bound of :mod:`.bnb` with
the enclosure of the design's mechanism (``Mechanism.enclosure``: the
hand-written 3-P(4S)'s and every described mechanism's with as many
actuators as pose coordinates).

:func:`certify_design` proves, over every pose of W (a box, or a cylinder:
a disc in the first two axes), that

* every pose is reachable (every leg closes),
* the singularity constraint holds: the condition number of the config's
  first isotropy index (its convention: ``frobenius`` or ``two_norm``; else
  cond_2) is <= the limit: per box the smaller of the preconditioned bound
  (:func:`.matrix.cond_fro_upper` or :func:`.matrix.cond_2_upper`) and the
  adjugate's (:func:`.matrix.cond_fro_upper_adjugate` or
  :func:`.matrix.cond_2_upper_adjugate`: det and adj J in mean-value form
  from the enclosure's duals of J),
* the actuator values lie within the stroke limits, when the config sets
  them (prismatic and strut legs; a revolute leg's angle is not enclosed,
  so a stroke limit with revolute legs leaves the design ``unknown``),

or refutes the design with a witness pose (the float model at that pose
breaks a constraint: what and by how much is recorded), or reports
``unknown`` with the share of W's volume proved when the budget of box
evaluations is spent.  A mechanism without an enclosure is
``not_supported``, with the reason.
"""
from __future__ import annotations

import numpy as np

from ..linalg import cond_2, cond_fro
from ..intervals.dual import Dual
from ..intervals.interval import Interval
from .bnb import branch_and_bound
from ..intervals.matrix import cond_2_upper, cond_2_upper_adjugate, cond_fro_upper, cond_fro_upper_adjugate

__all__ = ["certify_design", "region_of", "DEFAULT_BUDGET"]

#: box evaluations per design (a planar W needs a few hundred; the 6-D
#: Gough-Stewart uses the whole budget and reports the share proved)
DEFAULT_BUDGET = 300_000


def region_of(workspace) -> dict:
    """W's bounding box (SI, in the workspace's axis order) and, for a
    cylinder, the disc: ``{"lo", "hi", "disc": (cx, cy, r) or None}``."""
    spec, names = workspace.spec, workspace.names
    lo = np.array([spec.axes.get(a, (0.0, 0.0))[0] for a in names], float)
    hi = np.array([spec.axes.get(a, (0.0, 0.0))[1] for a in names], float)
    disc = None
    if spec.type == "cylinder":
        cx, cy = spec.center
        r = float(spec.radius)
        lo[:2] = (cx - r, cy - r)
        hi[:2] = (cx + r, cy + r)
        disc = (float(cx), float(cy), r)
    return {"lo": lo, "hi": hi, "disc": disc}


def _take(x, idx):
    """The boxes ``idx`` of nested lists of Interval / Dual (floats and None unchanged)."""
    if isinstance(x, (list, tuple)):
        return type(x)(_take(v, idx) for v in x)
    if isinstance(x, Interval):
        return x if x.lo.ndim == 0 else x[idx]
    if isinstance(x, Dual):
        return Dual(x.v[idx], [None if a is None else _take(a, idx) for a in x.d])
    return x


def _enclosure(mech):
    """(evaluate(lo, hi) -> dict, None) or (None, why not)."""
    try:
        return mech.enclosure(), None
    except NotImplementedError as exc:
        return None, str(exc)


def certify_design(mech, region: dict, limit: float, convention: str = "two_norm",
                   stroke_limits: tuple[float, float] | None = None, budget: int = DEFAULT_BUDGET,
                   adjugate: bool = True) -> dict:
    """The certificate of one design (``mech``: a mechanism instance of one
    design) over ``region`` (:func:`region_of`): a dict with ``status``
    (certified / refuted / unknown / not_supported), ``share_proved``,
    ``boxes``, ``seconds``, and for a refutation ``witness`` (the pose, SI)
    with ``value`` (the condition number there; inf where unreachable) and
    ``reason`` (unreachable, stroke or singularity).  ``adjugate=False``
    uses the preconditioned bound alone (benchmarks/bench_certify.py compares)."""
    enc, why = _enclosure(mech)
    if enc is None:
        return {"status": "not_supported", "reason": why, "share_proved": 0.0, "boxes": 0}
    disc = region["disc"]
    cond = cond_fro if convention == "frobenius" else cond_2
    upper = cond_fro_upper if convention == "frobenius" else cond_2_upper
    upper_adj = cond_fro_upper_adjugate if convention == "frobenius" else cond_2_upper_adjugate

    def inside(X):
        if disc is None:
            return np.ones(X.shape[0], bool)
        cx, cy, r = disc
        return (X[:, 0] - cx) ** 2 + (X[:, 1] - cy) ** 2 <= r * r

    def outside_box(lo, hi):
        if disc is None:
            return np.zeros(lo.shape[0], bool)
        cx, cy, r = disc
        nx = np.clip(cx, lo[:, 0], hi[:, 0]) - cx
        ny = np.clip(cy, lo[:, 1], hi[:, 1]) - cy
        return nx * nx + ny * ny > r * r * (1 + 1e-12)

    def bound(lo, hi):
        e = enc(lo, hi)
        J = e["J"]
        if not adjugate or e.get("J_dual") is None:
            c = upper(J)
        else:       # the cheaper bound first (measured: the adjugate's for cond_2), the other where it fails
            pre = lambda J, Jd, Jm, lo, hi: upper(J)  # noqa: E731
            first, second = (pre, upper_adj) if convention == "frobenius" else (upper_adj, pre)
            c = first(J, e["J_dual"], e["J_mid"], lo, hi)
            need = np.flatnonzero(~(c <= limit))
            if need.size:
                sub = _take((J, e["J_dual"], e["J_mid"]), need)
                c[need] = np.minimum(c[need], second(*sub, lo[need], hi[need]))
        ub = np.where(e["reach_lo"] > 0, c, np.inf)
        if stroke_limits is not None:
            s_lo, s_hi = stroke_limits
            for q in e["q"]:
                if q is None:
                    ub = np.full_like(ub, np.inf)
                    break
                ub = np.where((q.lo >= s_lo) & (q.hi <= s_hi), ub, np.inf)
        return np.where(outside_box(lo, hi), -np.inf, ub)

    def value(X):
        with np.errstate(all="ignore"):
            st = mech.state(X)
            reach = np.asarray(st.reachable, bool).reshape(-1)
            J = st.J
            J = J.reshape((X.shape[0],) + J.shape[-2:])
            c = np.where(reach, cond(J), np.inf)
            if stroke_limits is not None:
                Q = np.asarray(st.q).reshape(X.shape[0], -1)
                bad = np.any((Q < stroke_limits[0]) | (Q > stroke_limits[1]), axis=-1)
                c = np.where(bad, np.inf, c)
        return np.where(np.isfinite(c), c, np.inf)

    out = branch_and_bound(bound, value, region["lo"], region["hi"], limit, budget=budget,
                           inside=None if disc is None else inside)
    if out["status"] == "refuted":
        X = np.array([out["witness"]])
        with np.errstate(all="ignore"):
            st = mech.state(X)
            reach = bool(np.asarray(st.reachable).reshape(-1)[0])
            Q = np.asarray(st.q).reshape(-1)
        stroke = stroke_limits is not None and bool(np.any((Q < stroke_limits[0]) | (Q > stroke_limits[1])))
        out["reason"] = "unreachable" if not reach else "stroke" if stroke else "singularity"
        if out["value"] is not None and not np.isfinite(out["value"]):
            out["value"] = None
    out["limit"] = float(limit)
    return out
