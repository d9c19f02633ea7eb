"""The compiled path of chain mechanisms (docs/lower-mobility.md): the seams
``global_statistics`` and ``local_values_at`` of :class:`.chain_mechanism.ChainMechanism`
on the engine's chain kernel (:mod:`optdesign.engine.chain_kernels`).

The packing (:func:`pack`) writes a mechanism's shape and per-design
constants as the arrays of :mod:`optdesign.engine.chain_layout`, with every
design's home configuration solved by the numpy path
(``ChainMechanism.home_solution``); the points as their independent
coordinates through the declared map and its derivative (:func:`points`).
The points the kernel leaves to the numpy path (code 2: ill-conditioned, not
finite) are evaluated there (:func:`.fallback.numpy_values`, J and M from
the chain mechanism's own numpy formulas) and merged into the statistics.
What the kernel does not compute goes to the numpy path as a whole: the
``constraint`` index, and the dynamic index of a mechanism whose shorthand
legs have bodies.  ``OPTDESIGN_CHAIN_ENGINE=0`` (or ``OPTDESIGN_FAST=0``)
turns this path off.
"""
from __future__ import annotations

import os

import numpy as np

from ...engine import chain_layout as C
from ...engine import plan
from ...engine.layout import NMAX
from ...fast import enabled
from ...formulas import COL0, DYN, NVAL, SMIN, SMIN2, TWO
from .fallback import numpy_values, point_values_of, summary_of

__all__ = ["pack", "points", "global_statistics", "local_values", "local_values_at", "ENV_VAR", "active"]

#: the environment variable that turns the chain kernel off (``0``)
ENV_VAR = "OPTDESIGN_CHAIN_ENGINE"
_PTYPE = {"translation": 0, "planar": 1, "rotation": 2, "spatial": 3}
_ROLES = ("x", "y", "z", "roll", "pitch", "yaw")
_KIND = {"prismatic": 0, "revolute": 1, "strut": 2}


def active() -> bool:
    """Whether the chain kernel is on (the engine on and ``OPTDESIGN_CHAIN_ENGINE`` not 0)."""
    return enabled() and os.environ.get(ENV_VAR, "1").strip() not in ("0", "off", "false", "no")


def pack(mech):
    """(ints, (VF, LF, SF, BF, GF, UH), D, dynamics supported) for the designs
    of mech, once per mechanism; ValueError where the kernel does not apply."""
    memo = mech.__dict__.get("_chain_pack")
    if memo is None:
        memo = mech.__dict__["_chain_pack"] = _pack(mech)
    return memo


def _flat(a, S, D, tail):
    a = np.asarray(a, dtype=float)
    return np.ascontiguousarray(np.broadcast_to(a, tuple(S) + tail).reshape((D,) + tail))


def _pack(mech):
    desc, spec = mech.description, mech.pose_spec
    cc = mech.chain_constants
    base = cc.base
    S = tuple(base.shape)
    if len(S) > 2 or (len(S) == 2 and S[1] != 1):
        raise ValueError(f"design parameters of shape {S}: expected (D,) or (D, 1)")
    D = int(np.prod(S)) if S else 1
    ind, par = list(spec.independent_index), list(spec.parasitic_index)
    n, dof = len(ind), spec.dof
    if len(desc.actuators) != n or not 1 <= n <= NMAX:
        raise ValueError("the chain kernel needs a square Jacobian of at most NMAX columns")
    cidx = np.zeros(dof, dtype=np.int64)
    for k, i in enumerate(ind):
        cidx[i] = k
    for k, i in enumerate(par):
        cidx[i] = -1 - k
    roles = np.array([_ROLES.index(r) for r in spec.roles], dtype=np.int64)
    legs = np.zeros((len(cc.legs), C.NLEG), dtype=np.int64)
    vcode, VF, LF, bod, BF = [], [], [], [], []
    voff = roff = 0
    for li, leg in enumerate(cc.legs):
        legs[li] = (leg.k, 0 if leg.closure == "position" else 1, -1 if leg.act is None else leg.act, voff, roff)
        vcode += list(leg.codes)
        vf = np.zeros((D, leg.k, C.NVF))
        vf[:, :, C.V_AXIS:C.V_AXIS + 3] = _flat(leg.axis, S, D, (leg.k, 3))
        vf[:, :, C.V_POINT:C.V_POINT + 3] = _flat(leg.point, S, D, (leg.k, 3))
        vf[:, :, C.V_SIDE:C.V_SIDE + 3] = _flat(leg.side, S, D, (leg.k, 3))
        vf[:, :, C.V_OFFSET] = _flat(leg.offset, S, D, (leg.k,))
        VF.append(vf)
        lf = np.zeros((D, 1, C.NLF))
        lf[:, 0, C.E_END:C.E_END + 3] = _flat(leg.end, S, D, (3,))
        lf[:, 0, C.E_P:C.E_P + 3] = _flat(leg.P, S, D, (3,))
        LF.append(lf)
        for v, m, cen, inertia in leg.bodies:
            bod.append((li, v))
            bf = np.zeros((D, 1, C.NBF))
            bf[:, 0, C.B_M] = _flat(m, S, D, ())
            bf[:, 0, C.B_C:C.B_C + 3] = _flat(cen, S, D, (3,))
            bf[:, 0, C.B_I:C.B_I + 9] = _flat(inertia, S, D, (3, 3)).reshape(D, 9)
            BF.append(bf)
        voff += leg.k
        roff += leg.rows
    nvar, npar, neq = voff, len(par), roff
    nsh = len(base.kind)
    acts = np.array([(0 if src == "chain" else 1, i) for _, src, i in desc.actuators], dtype=np.int64).reshape(n, 2)
    sh = np.array([(int(base.kind[i]), int(base.branch[i])) for i in range(nsh)], dtype=np.int64).reshape(nsh, 2)
    SF = np.zeros((D, nsh, C.NSF))
    if nsh:
        for off, a in ((C.S_A, base.A), (C.S_P, base.P), (C.S_U, base.U), (C.S_R0, base.R0), (C.S_S0, base.S0)):
            SF[:, :, off:off + 3] = _flat(a, S, D, (nsh, 3))
        SF[:, :, C.S_LA] = _flat(base.La, S, D, (nsh,))
        SF[:, :, C.S_LR] = _flat(base.Lr, S, D, (nsh,))
        SF[:, :, C.S_SIGN] = _flat(base.sign, S, D, (nsh,))
    GF = np.zeros((D, C.NGF))
    GF[:, C.F_L] = _flat(cc.length, S, D, ())
    GF[:, C.F_CEN:C.F_CEN + 3] = _flat(base.centre, S, D, (3,))
    GF[:, C.F_FIX:C.F_FIX + 3] = _flat(base.fixed, S, D, (3,))
    GF[:, C.F_MP] = _flat(base.m_platform, S, D, ())
    GF[:, C.F_COM:C.F_COM + 3] = _flat(base.com, S, D, (3,))
    GF[:, C.F_IP:C.F_IP + 9] = _flat(base.I_platform, S, D, (3, 3)).reshape(D, 9)
    GF[:, C.F_P0:C.F_P0 + n] = np.asarray(spec.home, dtype=float)[ind]
    uh, _ = mech.home_solution()
    UH = np.ascontiguousarray(np.asarray(uh, dtype=float).reshape(D, nvar + npar))
    hdr = np.zeros(C.NH, dtype=np.int64)
    hdr[[C.H_PTYPE, C.H_DOF, C.H_N, C.H_NPAR, C.H_NLEG, C.H_NVAR, C.H_NU, C.H_NEQ, C.H_NSH, C.H_NBODY]] = (
        _PTYPE[spec.type], dof, n, npar, len(cc.legs), nvar, nvar + npar, neq, nsh, len(bod))
    ints = (hdr, roles, cidx, legs, np.array(vcode, dtype=np.int64), acts, sh,
            np.array(bod, dtype=np.int64).reshape(len(bod), 2))
    cat = lambda parts, k: (np.ascontiguousarray(np.concatenate(parts, 1)) if parts  # noqa: E731
                            else np.zeros((D, 0, k)))
    arrays = (cat(VF, C.NVF), cat(LF, C.NLF), SF, cat(BF, C.NBF), GF, UH)
    # the kernel's M_p has the platform and the links: shorthand legs' bodies are the numpy path's
    dyn_ok = bool(desc.has_dynamics) and nsh == 0
    return ints, arrays, D, dyn_ok


def points(mech, X, per_design: bool, D: int):
    """PX (1 or D, N, n + n n): the independent pose coordinates of the points X
    ((N, n) shared, or (D, N, n) per design) through the declared map, and the
    map's derivative Df row-major (the identity without a map)."""
    spec = mech.pose_spec
    X = np.asarray(X, dtype=float)
    Xb = X if per_design else X[None]
    n = X.shape[-1]
    if spec.cmap is None:
        Df = np.broadcast_to(np.eye(n).reshape(n * n), Xb.shape[:-1] + (n * n,))
        return np.ascontiguousarray(np.concatenate([Xb, Df], -1))
    from .chain_maps import _map_trees
    from .expr import evaluate

    env = {k: (np.asarray(v, dtype=float).reshape(-1)[:, None] if np.ndim(v) else v) for k, v in mech.params.items()}
    env.update({c: Xb[..., i] for i, c in enumerate(spec.coords)})
    shape = np.broadcast_shapes(Xb.shape[:-1], *(np.shape(v) for v in env.values()))
    if shape[0] not in (1, D):
        raise ValueError("the map's parameters do not match the designs")
    ev = lambda t: np.broadcast_to(np.asarray(evaluate(t, env), dtype=float), shape)  # noqa: E731
    d1, _ = _map_trees(mech)
    with np.errstate(all="ignore"):
        Xr = np.stack([ev(t) for t in spec.cmap], -1)
        Df = np.stack([np.stack([ev(t) for t in row], -1) for row in d1], -2)
    return np.ascontiguousarray(np.concatenate([Xr, Df.reshape(shape + (n * n,))], -1))


def _flags(want):
    return np.array([want[DYN], want[SMIN] or want[SMIN2] or want[TWO], want[TWO], want[COL0:].any(), False, False],
                    dtype=np.bool_)


def _prepare(mech, requests, extra=()):
    """(plan, want, flags, packed) or None where the kernel does not apply."""
    if not active():
        return None
    try:
        packed = pack(mech)
    except ValueError:
        return None
    pl = plan(requests, mech.dof, packed[3])
    rows = sorted({v for _, v, _ in pl} | set(extra))
    if not rows:
        return None
    want = np.zeros(NVAL, dtype=np.bool_)
    want[rows] = True
    return pl, want, _flags(want), packed


def global_statistics(mech, requests, X, want_max_cond: bool = False):
    """The seam ``global_statistics`` (see :func:`.compiled.global_statistics`) on the chain kernel, or None."""
    from ...engine.chain import run_chain

    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != mech.dof or X.shape[0] == 0:
        return None
    got = _prepare(mech, requests, (TWO,) if want_max_cond else ())
    if got is None:
        return None
    pl, want, flags, (ints, arrays, D, _) = got
    try:
        PX = points(mech, X, False, D)
    except ValueError:
        return None
    res = run_chain(ints, *arrays, PX, want, flags)
    if res is None:
        return None
    return summary_of(res, requests, pl, want_max_cond,
                      lambda dd, jj, entries: numpy_values(mech, X, dd, jj, entries))


def _point_values(mech, requests, X, per_design: bool):
    """Every point's values of the requests: X (D, K, dof) each design at its
    own points (per_design) or X (K, dof) shared by the designs: ``(values
    {name: (D, K)}, reachable (D, K))``, NaN where not reachable, or None
    when the kernel does not compute every request."""
    from ...engine.chain import run_chain

    X = np.asarray(X, dtype=float)
    if X.ndim != (3 if per_design else 2) or X.shape[-1] != mech.dof or X.shape[-2] == 0:
        return None
    got = _prepare(mech, requests)
    if got is None:
        return None
    pl, want, flags, (ints, arrays, D, _) = got
    if len(pl) != len(requests) or (per_design and X.shape[0] != D):
        return None
    try:
        PX = points(mech, X, per_design, D)
    except ValueError:
        return None
    K = X.shape[-2]
    keep = np.zeros((D, NVAL, K))
    res = run_chain(ints, *arrays, PX, want, flags, keep, stats=False)
    if res is None:
        return None
    return point_values_of(keep, res[2], requests, pl, X, per_design,
                           lambda Xp, dd, jj, entries: numpy_values(mech, Xp, dd, jj, entries))


def local_values_at(mech, requests, X):
    """The seam ``local_values_at``: each of the D designs at its own K points
    X (D, K, dof): ``(values {name: (D, K)}, reachable (D, K))``, NaN where not
    reachable, or None when the kernel does not compute every request."""
    return _point_values(mech, requests, X, True)


def local_values(mech, requests, X):
    """The seam ``local_values``: the D designs at the points X (N, dof), as :func:`local_values_at`."""
    return _point_values(mech, requests, X, False)
