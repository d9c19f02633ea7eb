"""Per-design constant arrays of a described mechanism, evaluated from its
expressions (vectorized over designs).

With parameters of the design shape ``S`` (``()`` for one design, ``(D, 1)``
for a population, as for the hand-written mechanisms) every array here has
shape ``S + (n_legs, 3)`` (vectors), ``S + (n_legs,)`` (per-leg scalars) or
``S + (3,)`` / ``S + (3, 3)`` / ``S`` (platform), so that they broadcast
against the pose axis of ``X (..., N, dof)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .expr import evaluate
from .schema import Description

__all__ = ["Constants", "constants", "KIND_CODES", "BRANCH_CODES", "BODY_KEYS", "SIGMA_TOL", "home_sigma"]

KIND_CODES = {"prismatic": 0, "revolute": 1, "strut": 2}
BRANCH_CODES = {None: 0, "minus": 0, "plus": 1, "outer": 2, "inner": 3}
#: per-leg body quantities (missing ones are 0; rod_count 1, centres 1/2,
#: rod_inertia m l^2 / 12)
BODY_KEYS = ("slider_mass", "crank_inertia", "crank_mass", "crank_centre", "rod_mass", "rod_count", "rod_inertia",
             "rod_centre", "rod_width", "lower_mass", "lower_centre", "lower_inertia", "upper_mass", "upper_centre",
             "upper_inertia")


@dataclass
class Constants:
    shape: tuple                 # design shape
    kind: np.ndarray             # (n,) int codes
    branch: np.ndarray           # (n,) int codes
    A: np.ndarray                # base points, S + (n, 3)
    P: np.ndarray                # platform points (platform frame), S + (n, 3)
    U: np.ndarray                # prismatic: unit rail direction; revolute: unit axis
    R0: np.ndarray               # revolute: unit crank direction at q = 0 (perpendicular to U)
    S0: np.ndarray               # revolute: U x R0
    La: np.ndarray               # crank length, S + (n,) (0 where none)
    Lr: np.ndarray               # rod length, S + (n,) (0 for struts)
    across: np.ndarray           # rod.across unit vectors (0 where none), S + (n, 3)
    centre: np.ndarray           # S + (3,): rotation centre (0 for other pose types)
    fixed: np.ndarray            # S + (3,): roll, pitch, yaw where they are not coordinates (else 0)
    m_platform: np.ndarray       # S
    I_platform: np.ndarray       # S + (3, 3)
    com: np.ndarray              # S + (3,)
    g: np.ndarray                # S
    body: dict                   # BODY_KEYS -> S + (n,)
    #: revolute legs: the root taken, +1 (q = atan2(Q, P) + delta) or -1 (- delta),
    #: settled per design (``outer`` / ``inner`` at the home pose, see :func:`home_sigma`);
    #: NaN where ``outer`` / ``inner`` is not defined (the design reaches no pose); 0 for other legs
    sign: np.ndarray = None      # S + (n,)


#: |sigma| at most this times |w| |A| at the home pose: outer and inner are not defined
SIGMA_TOL = 1e-9


def home_sigma(desc: Description, C: "Constants") -> tuple[np.ndarray, np.ndarray]:
    """(sigma, scale), each S + (n,): ``sigma = k . (w x A)`` at the home pose
    (k the motor axis, A the base point, w = b - A), whose sign tells which
    crank-tip root lies farther from the base origin (the ``+ delta`` root
    where sigma > 0: |tip+|^2 - |tip-|^2 = 4 L_a sin(delta) sigma / |w_perp|),
    and ``scale = |w| |A|``."""
    from .poses import frames

    home = np.asarray(desc.pose.home, dtype=float)[None]
    fr = frames(desc.pose, home, C.centre, C.fixed)
    r = np.einsum("...jk,...ik->...ij", fr.R, C.P)
    w = fr.origin[..., None, :] + r - C.A
    w = np.broadcast_to(w, np.broadcast_shapes(w.shape, C.A.shape))
    sigma = np.sum(C.U * _cross(w, np.broadcast_to(C.A, w.shape)), axis=-1)
    scale = np.sqrt(np.sum(w * w, axis=-1) * np.sum(C.A * C.A, axis=-1))
    n = len(C.kind)
    return sigma.reshape(C.shape + (n,)), np.broadcast_to(scale, sigma.shape).reshape(C.shape + (n,))


def _signs(desc: Description, C: "Constants") -> np.ndarray:
    """The root each revolute leg takes, per design (see ``Constants.sign``):
    ``plus``/``minus`` as written; ``outer``/``inner`` settled once per design at
    the home pose by the sign of sigma, so that the solution is continuous over
    the workspace and independent of round-off."""
    n = len(C.kind)
    out = np.zeros(C.shape + (n,))
    if not np.any(C.kind == 1):
        return out
    sigma, scale = home_sigma(desc, C)
    settled = np.where(np.abs(sigma) > SIGMA_TOL * scale, np.sign(sigma), np.nan)
    for i in range(n):
        if C.kind[i] != 1:
            continue
        br = C.branch[i]
        out[..., i] = {0: -1.0, 1: 1.0}.get(int(br), 0.0) if br in (0, 1) else (
            settled[..., i] if br == 2 else -settled[..., i])
    return out


def _bc(v, shape) -> np.ndarray:
    return np.broadcast_to(np.asarray(v, dtype=float), shape)


def _turn(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rz(angle) v for v S + (3,), angle S."""
    c, s = np.cos(angle), np.sin(angle)
    x = c * v[..., 0] - s * v[..., 1]
    out = np.empty(x.shape + (3,))
    out[..., 0] = x
    out[..., 1] = s * v[..., 0] + c * v[..., 1]
    out[..., 2] = v[..., 2]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of two (..., 3) arrays: numpy's own operations (a1 b2 - a2 b1,
    a2 b0 - a0 b2, a0 b1 - a1 b0), so its bits, without its overhead (its
    axis moves cost more than the arithmetic on a few designs)."""
    x = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out = np.empty(x.shape + (3,))
    out[..., 0] = x
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def _unit(v: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        return v / np.sqrt(np.sum(v * v, axis=-1, keepdims=True))


def constants(desc: Description, params: dict) -> Constants:
    """Evaluate every expression of ``desc`` with the parameters ``params``
    (name -> array of the design shape or scalar)."""
    env = {k: np.asarray(v, dtype=float) for k, v in params.items()}
    shape = np.broadcast_shapes(*(v.shape for v in env.values())) if env else ()
    with np.errstate(all="ignore"):
        return _constants(desc, env, shape)


def _constants(desc: Description, env: dict, shape: tuple) -> Constants:
    n = len(desc.legs)

    memo = {}

    def ev(tree):
        # a float or an array that broadcasts to shape; a pattern's legs share
        # their trees (one expression, several angles): each is evaluated once
        key = id(tree)
        got = memo.get(key)
        if got is None:
            got = memo[key] = (tree, evaluate(tree, env))
        return got[1]

    def vec(trees):
        out = np.empty(shape + (len(trees),))
        for k, t in enumerate(trees):
            out[..., k] = ev(t)
        return out

    def per_leg(values):
        out = np.empty(shape + (n,))
        for i, v in enumerate(values):
            out[..., i] = v
        return out

    kind = np.array([KIND_CODES[leg.kind] for leg in desc.legs], dtype=np.int64)
    branch = np.array([BRANCH_CODES[leg.branch] for leg in desc.legs], dtype=np.int64)
    legs = desc.legs

    def leg_vecs(trees):
        """S + (n, 3) from each leg's three trees (0 where a leg has none)."""
        out = np.zeros(shape + (n, 3))
        for i, t in enumerate(trees):
            if t is not None:
                for k in range(3):
                    out[..., i, k] = ev(t[k])
        return out

    def has(trees):
        return np.array([t is not None for t in trees], dtype=bool)[:, None]

    # every leg at once (the same elementwise operations as leg by leg, so the same bits)
    tb = per_leg([ev(leg.turn_base) for leg in legs])
    tp = per_leg([ev(leg.turn_platform) for leg in legs])
    A = _turn(leg_vecs([leg.base for leg in legs]), tb)
    P = _turn(leg_vecs([leg.platform for leg in legs]), tp)
    trees = [leg.direction for leg in legs]
    U = np.where(has(trees), _unit(_turn(leg_vecs(trees), tb)), 0.0)
    trees = [leg.reference for leg in legs]
    r = _turn(leg_vecs(trees), tb)
    r = r - np.sum(r * U, axis=-1, keepdims=True) * U
    R0 = np.where(has(trees), _unit(r), 0.0)
    trees = [leg.across for leg in legs]
    AC = np.where(has(trees), _unit(_turn(leg_vecs(trees), tb)), 0.0)
    La = [ev(leg.crank) if leg.crank is not None else 0.0 for leg in legs]
    Lr = [ev(leg.rod) if leg.rod is not None else 0.0 for leg in legs]
    S0 = _cross(U, R0)
    La, Lr = per_leg(La), per_leg(Lr)
    pose = desc.pose
    centre = vec(pose.centre)
    fixed = vec([pose.fixed.get(a, ("num", 0.0)) for a in ("roll", "pitch", "yaw")])
    plat = desc.platform
    mp = _bc(ev(plat.mass), shape) if plat.mass is not None else np.zeros(shape)
    Ip = np.stack([vec(row) for row in plat.inertia], -2)
    com = vec(plat.com)
    body = {}
    for key in BODY_KEYS:
        vals = []
        for i, leg in enumerate(desc.legs):
            if key in leg.bodies:
                vals.append(ev(leg.bodies[key]))
            elif key == "rod_count":
                vals.append(1.0)
            elif key in ("rod_centre", "crank_centre"):
                vals.append(0.5)
            elif key == "rod_inertia":
                m = ev(leg.bodies["rod_mass"]) if "rod_mass" in leg.bodies else np.zeros(shape)
                vals.append(m * Lr[..., i] ** 2 / 12.0)
            else:
                vals.append(0.0)
        body[key] = per_leg(vals)
    g = _bc(ev(desc.gravity), shape)
    C = Constants(shape, kind, branch, A, P, U, R0, S0, La, Lr, AC, centre, fixed, mp, Ip, com, g, body)
    C.sign = _signs(desc, C)
    return C
