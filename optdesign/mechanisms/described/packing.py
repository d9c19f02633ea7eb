"""The packing of a described mechanism for the engine (:mod:`optdesign.engine`):
its shape as codes (pose type, pose-column kinds, leg kinds and branches),
its per-design constants as the arrays ``L`` (D, n, NL) and ``F`` (D, NF)
from :class:`~.constants.Constants`, and the per-point frame data of the
poses (from the numpy path's own frames, :mod:`.poses`)."""
from __future__ import annotations

import numpy as np

from ...engine import layout as K

__all__ = ["pack", "shape_codes", "description_codes", "kernel_spec", "kernel_source", "frame_rows"]

_PTYPE = {"translation": 0, "planar": 1, "rotation": 2, "spatial": 3}
#: pose-column kinds of the kernel in the rates convention: a twist component, or roll's / pitch's Euler column
_RATE_COLUMN = {"x": 0, "y": 1, "z": 2, "roll": 6, "pitch": 7, "yaw": 5}


def pack(mech):
    """(codes: ptype, ct, kind, branch; L (D, n, NL); F (D, NF), D) for the designs
    of mech, computed once per mechanism (its parameters do not change: the
    worst-case search calls the kernel thousands of times for one design)."""
    memo = mech.__dict__.get("_engine_pack")
    if memo is None and "_rows_of" in mech.__dict__:
        # the designs of another mechanism (DescribedMechanism.rows_of): its packing's rows, the same
        # bits (each design's constants are computed elementwise over the designs)
        population, index = mech.__dict__["_rows_of"]
        codes, L, F, _ = pack(population)
        memo = mech.__dict__["_engine_pack"] = (codes, L[index], F[index], len(index))
    if memo is None:
        from .mechanism import DescribedMechanism
        from .memo import PACK_DESIGNS, PACKS, pack_key

        key = pack_key(mech) if isinstance(mech, DescribedMechanism) else None
        memo = PACKS.get(key) if key is not None else None
        if memo is None:
            memo = _pack(mech)
            if key is not None and memo[3] <= PACK_DESIGNS:
                PACKS.put(key, memo)
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
        a = np.asarray(a, dtype=float)
        if a.shape != shape + tail:       # most have it already (np.broadcast_to: 5 us, 28 calls a pack)
            a = np.broadcast_to(a, shape + tail)
        return a.reshape((D,) + tail)

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
    kinds and branches of mech (the same for all its designs: its description's)."""
    return description_codes(mech.description)


def description_codes(desc):
    """:func:`shape_codes` of a description (no design needed)."""
    from .constants import BRANCH_CODES, KIND_CODES
    from .poses import twist_columns

    spec = desc.pose
    ptype = _PTYPE[spec.type]
    if spec.jacobian == "angular_velocity" or ptype < 2:
        ct = np.array(twist_columns(spec), dtype=np.int64)
    else:
        ct = np.array([_RATE_COLUMN[r] for r in spec.roles], dtype=np.int64)
    if getattr(desc, "is_chain", False):
        raise ValueError("chain legs: the chain kernel packs them (chain_compiled.py), not this packing")
    kind = np.array([KIND_CODES[leg.kind] for leg in desc.legs], dtype=np.int64)
    branch = np.array([BRANCH_CODES[leg.branch] for leg in desc.legs], dtype=np.int64)
    return ptype, ct, kind, branch


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
