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
