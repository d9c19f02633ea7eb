"""The 3-P(4S)'s compiled path: the one engine (:mod:`optdesign.engine`) on
the mechanism's description.

The 3-P(4S) is three prismatic legs (a slider on an inclined rail, a 4S
parallelogram that moves as one rod of length L) and a translating platform:
:data:`DESCRIPTION` writes it as data (the same as ``configs/p4s_legs.yaml``),
and the seams of :class:`~.model.P4S` (``global_statistics``,
``local_values``, ``local_values_at``) are answered by the described
mechanism of the same parameters, whose compiled path packs them for the
engine.  Points the engine leaves to the numpy path (ill-conditioned, not
finite) are evaluated by this mechanism's own numpy model (:mod:`.model`), so
the answers equal it to round-off (tests/test_p4s_compiled.py: 1e-12
relative, the reachable mask the same).

The fused kernel written by hand for this mechanism alone (faster, but a
second compiled stack to keep) is now a benchmark reference only:
``benchmarks/p4s_hand_kernel.py``.
"""
from __future__ import annotations

import numpy as np

__all__ = ["DESCRIPTION", "described_class", "described", "pack", "global_statistics", "local_values",
           "local_values_at"]

#: the 3-P(4S) as a description (docs/mechanisms-as-data.md): the parameters
#: of :class:`~.model.P4S` (same names), the paper's legs (eq. 1 and 5)
DESCRIPTION = {
    "name": "p4s",
    "parameters": {
        "r_a": "length", "r_b": "length", "L": "length", "d": "length", "phi": "angle",
        "m_platform": {"kind": "mass", "default": 0.0}, "m_slider": {"kind": "mass", "default": 0.0},
        "m_rod": {"kind": "mass", "default": 0.0}, "rod_Ixx": {"kind": "inertia", "default": 0.0},
        "rods_per_branch": {"kind": "number", "design": False, "default": 2},
        "g": {"kind": "acceleration", "default": 9.81},
    },
    "pose": {"type": "translation", "home": {"z": 0.57}},
    "platform": {"mass": "m_platform"},
    "gravity": "g",
    "legs": [{
        "kind": "prismatic", "actuator": "l", "pattern": {"angles": [0, 120, 240], "unit": "deg"},
        "base": ["r_b", 0, 0], "direction": ["-cos(phi)", 0, "sin(phi)"],
        "platform": ["sqrt(r_a**2 - d**2 / 4)", 0, 0],
        "rod": {"length": "L", "mass": "m_rod", "count": "rods_per_branch", "inertia": "rod_Ixx"},
        "slider": {"mass": "m_slider"}, "branch": "minus",
    }],
}
_NAMES = ("r_a", "r_b", "L", "d", "phi", "m_platform", "m_slider", "m_rod", "rod_Ixx", "rods_per_branch", "g")

_CLASS = []


def described_class():
    """The described mechanism class of :data:`DESCRIPTION` (built once)."""
    if not _CLASS:
        from ..described import build_class

        _CLASS.append(build_class(DESCRIPTION, "p4s"))
    return _CLASS[0]


def described(mech):
    """The described mechanism with the parameters of the P4S ``mech`` (kept on
    it), its engine constants packed from this model's own geometry (:func:`pack`)."""
    d = mech.__dict__.get("_described")
    if d is None:
        d = described_class()(**{k: mech.params[k] for k in _NAMES})
        d.numpy_reference = mech       # the points the engine leaves to the numpy path: this model's own
        rows = mech.__dict__.get("_rows_of")
        if rows is not None and _flat(mech) and _flat(rows[0]):
            d.rows_of(described(rows[0]), rows[1])       # the population's packing's rows (P4S.rows_of)
        elif _flat(mech):
            d.__dict__["_engine_pack"] = _recent_pack(mech)
        mech.__dict__["_described"] = d
    return d


def _recent_pack(mech):
    """:func:`pack`, kept for the designs packed last (an evaluation packs its
    designs, then the worst-case search the same designs again)."""
    from ..described.memo import PACK_DESIGNS, PACKS, pack_key

    key = ("P4S model",) + pack_key(mech)
    got = PACKS.get(key)
    if got is None:
        got = pack(mech)
        if got[3] <= PACK_DESIGNS:
            PACKS.put(key, got)
    return got


def pack(mech):
    """The engine's arrays for the designs of the P4S ``mech`` (as
    :func:`optdesign.mechanisms.described.compiled.pack` packs its
    description), from the model's own geometry: rail directions ``m_i``
    (:meth:`~.model.P4S.rail_directions`), the rods and bodies of section 2.4,
    and each leg moved by ``-r_b e_i`` (rail start at the origin, platform
    point ``(rho - r_b) e_i``): the platform translates, so the rod ``d = b -
    a``, the strokes and every engine value are the same, and ``w = b - A =
    p + (rho - r_b) e_i`` is the numpy model's own sum (eq. 5), so the
    strokes and the reachable mask are its bits.  Vectorized over the designs;
    no expression is evaluated (the worst-case search builds a mechanism per
    design it visits)."""
    from ...engine import layout as K
    from .geometry import E

    shape = mech.design_shape
    D = int(np.prod(shape)) if shape else 1

    def per(v):
        return np.broadcast_to(np.asarray(v, dtype=float), shape).reshape(D)

    L = np.zeros((D, 3, K.NL))
    L[:, :, K.LP:K.LP + 3] = per(mech.rho - mech.r_b)[:, None, None] * E
    L[:, :, K.LU:K.LU + 3] = np.broadcast_to(mech.rail_directions(), shape + (3, 3)).reshape(D, 3, 3)
    count = per(mech.rods_per_branch)[:, None]
    L[:, :, K.LLR] = per(mech.L)[:, None]
    L[:, :, K.LMACT] = per(mech.m_slider)[:, None]
    L[:, :, K.LMROD] = per(mech.m_rod)[:, None] * count
    L[:, :, K.LIROD] = per(mech.rod_Ixx)[:, None] * count
    L[:, :, K.LFROD] = 0.5
    L[:, :, K.LE1] = 0.0
    L[:, :, K.LE2] = 0.0
    F = np.zeros((D, K.NF))
    F[:, K.FMP] = per(mech.m_platform)
    return SHAPE, L, F, D


#: the engine's shape codes of the 3-P(4S): a translation pose (x, y, z
#: columns), three prismatic legs on the smaller root (eq. 5)
SHAPE = (0, np.array([0, 1, 2], dtype=np.int64), np.zeros(3, dtype=np.int64), np.zeros(3, dtype=np.int64))


def _flat(mech) -> bool:
    """Design parameters of shape (), (D,) or (D, 1): what the engine's pack takes (kept on mech)."""
    flat = mech.__dict__.get("_flat")
    if flat is None:
        shape = mech.design_shape
        flat = mech.__dict__["_flat"] = len(shape) <= 1 or (len(shape) == 2 and shape[1] == 1)
    return flat


def global_statistics(mech, requests, X):
    """The seam's answer from the engine (see ``Mechanism.global_statistics``), or None."""
    if not _flat(mech):
        return None
    return described(mech).global_statistics(requests, np.asarray(X, dtype=float))


def local_values(mech, requests, X):
    """The local-values seam's answer from the engine (``Mechanism.local_values``), or None."""
    if not _flat(mech):
        return None
    from ..described.compiled import local_values as values

    return values(described(mech), requests, np.asarray(X, dtype=float))


def local_values_at(mech, requests, X):
    """The seam ``Mechanism.local_values_at`` from the engine: each design at its
    own points X (D, K, 3), or None."""
    if not _flat(mech):
        return None
    return described(mech).local_values_at(requests, np.asarray(X, dtype=float))
