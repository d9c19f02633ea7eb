"""The described mechanisms' drawing data: base joints, actuated points and
platform points of every leg at poses (the report's 3-D views)."""
from __future__ import annotations

import numpy as np

__all__ = ["drawing"]


def drawing(mech, X) -> dict:
    st = mech.leg_state(np.asarray(X, dtype=float))
    C = mech.constants
    b, a = st["b"], st["a"]                                              # (N, n, 3)
    bad = ~st["reachable"]
    b = np.where(bad[:, None, None], np.nan, b)
    A = np.broadcast_to(C.A, b.shape)
    kind = np.broadcast_to(np.asarray(C.kind), b.shape[1:2])
    legs = [np.stack([A[:, i], b[:, i]] if kind[i] == 2 else [A[:, i], a[:, i], b[:, i]], axis=1)
            for i in range(b.shape[1])]
    rod = [i for i in range(b.shape[1]) if kind[i] != 2]
    rods = np.stack([a[:, rod], b[:, rod]], axis=-2) if rod else np.zeros((b.shape[0], 0, 2, 3))
    Lr = np.broadcast_to(np.asarray(C.Lr, float), kind.shape)
    return {"base": A.copy(), "platform": b, "joints": np.concatenate([A, a, b], 1), "legs": legs,
            "rods": rods, "rod_lengths": np.array([float(Lr[i]) for i in rod])}


def chain_drawing(mech, X) -> dict:
    """The drawing of one design of a chain mechanism at poses X (N, n) (the
    independent coordinates): each chain leg as the polyline of its joints'
    points at the solved configuration (one point per joint: the variables
    of a U, S or C share it; a slide between two joints shows as the line
    between them, a slide that starts the chain is drawn from where its
    displacement is zero), ending at the platform point; the platform polygon
    through the legs' platform points; in m, NaN where a pose is not
    reachable.  Shorthand legs of a chain description are drawn from the base
    point to the platform point."""
    from .chain_constants import SLIDE
    from .chain_poe import _mv, chain_poe

    X = np.asarray(X, dtype=float)
    core = mech.state(X).core
    N = X.shape[0]
    ok = np.asarray(core["reachable"]).reshape(N)
    fr = core["st"]["frames"]
    R, o = fr.R.reshape(N, 3, 3), fr.origin.reshape(N, 3)
    legs, rods = [], []
    for i, leg in enumerate(mech.chain_constants.legs):
        d = leg.as_dict()
        th = np.asarray(core["theta"][i], dtype=float).reshape(N, leg.k)
        ch = chain_poe(d, np.nan_to_num(th), links=True)
        at = lambda v, j: np.broadcast_to(np.asarray(v, float)[..., j, :], (N, 3))
        end = _mv(ch["Rs"][leg.k], np.broadcast_to(np.asarray(d["end"], float), (N, 3))) + ch["ps"][leg.k]
        pts, last = [], None
        for j in range(leg.k):
            if leg.joint_of[j] == last:
                continue
            last = leg.joint_of[j]
            if d["codes"][j] != SLIDE:
                pts.append((j, _mv(ch["Rs"][j], at(d["point"], j)) + ch["ps"][j]))
            elif j == 0:
                pts.append((j, None))                   # filled below: the next point less the slide's travel
        for n, (j, pt) in enumerate(pts):
            if pt is None:
                nxt = pts[n + 1][1] if n + 1 < len(pts) else end
                pts[n] = (j, nxt - _mv(ch["Rs"][j], at(d["axis"], j)) * th[:, j:j + 1])
        j_last = pts[-1][0] if pts else None
        same_end = (j_last is not None and d["codes"][j_last] != SLIDE
                    and np.allclose(np.asarray(d["point"], float)[..., j_last, :], np.asarray(d["end"], float), rtol=0, atol=1e-12))
        if not same_end:
            pts.append((leg.k, end))
        legs.append(np.stack([pt for _, pt in pts], axis=1))
        # the last link, a rod where no slide lies between its two joints
        if len(pts) > 2 and SLIDE not in d["codes"][pts[-2][0]:pts[-1][0]]:
            rods.append(np.where(ok[:, None, None], np.stack([pts[-2][1], pts[-1][1]], axis=1), np.nan))
    C = mech.constants if mech.description.legs else None
    for k in range(len(mech.description.legs)):        # shorthand legs: base point to platform point
        A = np.broadcast_to(np.asarray(C.A, float)[k], (N, 3))
        b = o + _mv(R, np.broadcast_to(np.asarray(C.P, float)[k], (N, 3)))
        legs.append(np.stack([A, b], axis=1))
    legs = [np.where(ok[:, None, None], leg, np.nan) for leg in legs]
    rods = np.stack(rods, axis=1) if rods else np.zeros((N, 0, 2, 3))
    seg = np.linalg.norm(rods[:, :, 1] - rods[:, :, 0], axis=-1)
    lengths = seg[np.flatnonzero(ok)[0]] if ok.any() else np.full(rods.shape[1], np.nan)
    return {"base": np.stack([leg[:, 0] for leg in legs], axis=1), "platform": np.stack([leg[:, -1] for leg in legs], axis=1),
            "joints": np.concatenate(legs, axis=1), "legs": legs, "rods": rods, "rod_lengths": lengths}
