"""Per-design constants of the chain legs of a description: every joint
expanded into its scalar variables, each an elementary motion of the
reference configuration (vectorized over designs, shapes as in
:mod:`.constants`: ``S + (k, 3)`` for the k variables of a leg).

Variable codes: 0 a rotation about the unit ``axis`` through ``point``
(R, each rotation of U and S, the turn of C), 1 a translation along ``axis``
(P, the slide of C), 2 a parallelogram (Pa: ``side`` turns about ``axis``, the
distal link translates by ``(Rot(axis, t) - I) side``).  A chain that closes
by position leaves out its last S (its three rotations are free).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .constants import Constants, _turn, _unit, constants
from .expr import evaluate
from .spec import Description

__all__ = ["ChainLeg", "ChainConstants", "chain_constants", "ROT", "SLIDE", "PARA"]

ROT, SLIDE, PARA = 0, 1, 2
_E = np.eye(3)


@dataclass
class ChainLeg:
    path: str
    actuator: str | None
    closure: str                 # "position" or "frame"
    codes: tuple                 # per variable: ROT, SLIDE, PARA
    joint_of: tuple              # per variable: the index of its joint in the description
    axis: np.ndarray             # S + (k, 3), unit
    point: np.ndarray            # S + (k, 3)
    side: np.ndarray             # S + (k, 3) (PARA only, else 0)
    offset: np.ndarray           # S + (k,)
    home: np.ndarray             # S + (k,)
    act: int | None              # the actuated variable's index
    end: np.ndarray              # S + (3,): the end point at the reference configuration
    P: np.ndarray                # S + (3,): the platform point, platform frame
    #: the links with mass: (last variable moving it, mass S, centre S + (3,), inertia S + (3, 3))
    bodies: list = field(default_factory=list)
    #: the joint types, base to platform (messages)
    types: tuple = ()

    @property
    def k(self) -> int:
        return len(self.codes)

    @property
    def rows(self) -> int:
        return 3 if self.closure == "position" else 6

    def as_dict(self, expand: int = 0) -> dict:
        """The arrays :func:`.chain_poe.chain_poe` reads; ``expand`` axes are
        inserted before the per-leg axes (the design shape S then broadcasts
        against poses (..., N))."""
        def ex(a, tail):
            a = np.asarray(a)
            lead = a.shape[:a.ndim - tail]
            return a.reshape(lead + (1,) * expand + a.shape[a.ndim - tail:])
        d = {k: ex(getattr(self, k), 2) for k in ("axis", "point", "side")}
        d.update({k: ex(getattr(self, k), 1) for k in ("offset", "home", "end", "P")})
        d.update(codes=self.codes, closure=self.closure, act=self.act)
        return d


@dataclass
class ChainConstants:
    base: Constants              # platform and shorthand legs (optdesign.mechanisms.described.constants)
    legs: list                   # ChainLeg per chain leg
    length: np.ndarray           # S: the length scale (m) of moments and orientation residuals


def _rotz_matrix(angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    z, o = np.zeros_like(c), np.ones_like(c)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def chain_constants(desc: Description, params: dict) -> ChainConstants:
    """Evaluate the chains' expressions with ``params`` (name -> scalar or (D, 1))."""
    base = constants(desc, params)
    env = {k: np.asarray(v, dtype=float) for k, v in params.items()}
    shape = base.shape
    with np.errstate(all="ignore"):
        legs = [_leg(c, env, shape) for c in desc.chains]
        scale = np.zeros(shape)
        for leg in legs:
            scale = np.maximum(scale, np.max(np.linalg.norm(leg.point, axis=-1), axis=-1) if leg.k else 0.0)
            scale = np.maximum(scale, np.linalg.norm(leg.end, axis=-1))
            scale = np.maximum(scale, np.linalg.norm(leg.P, axis=-1))
        scale = np.where(scale > 0, scale, 1.0)
    return ChainConstants(base, legs, scale)


def _leg(spec, env, shape) -> ChainLeg:
    def ev(tree):
        return np.broadcast_to(np.asarray(evaluate(tree, env), dtype=float), shape)

    def vec(trees):
        return np.stack([ev(t) for t in trees], -1)

    tb, tp = ev(spec.turn_base), ev(spec.turn_platform)
    Rz = _rotz_matrix(tb)
    closure = spec.closure
    joints = spec.joints[:-1] if closure == "position" else spec.joints
    codes, jof, axis, point, side, offset, home, bodies = [], [], [], [], [], [], [], []
    act = None
    zero = np.zeros(shape + (3,))
    for ji, j in enumerate(joints):
        at = _turn(vec(j.at), tb)
        if j.type == "S":
            axes = [np.broadcast_to(e, shape + (3,)) for e in _E]
            kinds = [ROT] * 3
        elif j.type == "U":
            axes = [_unit(_turn(vec(j.axis), tb)), _unit(_turn(vec(j.axis2), tb))]
            kinds = [ROT, ROT]
        elif j.type == "C":
            a = _unit(_turn(vec(j.axis), tb))
            axes, kinds = [a, a], [SLIDE, ROT]
        else:
            axes = [_unit(_turn(vec(j.axis), tb))]
            kinds = [{"R": ROT, "P": SLIDE, "Pa": PARA}[j.type]]
        sd = _turn(vec(j.side), tb) if j.side is not None else zero
        for v, (a, kd) in enumerate(zip(axes, kinds)):
            if j.actuated is not None and j.actuated == v:
                act = len(codes)
            codes.append(kd)
            jof.append(ji)
            axis.append(a)
            point.append(at)
            side.append(sd if kd == PARA else zero)
            offset.append(ev(j.offset[v]))
            home.append(ev(j.home[v]))
        if j.body:
            I = np.stack([vec(row) for row in j.body["inertia"]], -2)
            bodies.append((len(codes) - 1, ev(j.body["mass"]), _turn(vec(j.body["centre"]), tb),
                           np.einsum("...ij,...jk,...lk->...il", Rz, I, Rz)))
    k = len(codes)
    stack3 = (lambda v: np.stack(v, -2)) if k else (lambda v: np.zeros(shape + (0, 3)))
    stack1 = (lambda v: np.stack(v, -1)) if k else (lambda v: np.zeros(shape + (0,)))
    end = _turn(vec(spec.joints[-1].at), tb)
    return ChainLeg(spec.path, spec.actuator, closure, tuple(codes), tuple(jof), stack3(axis), stack3(point),
                    stack3(side), stack1(offset), stack1(home), act, end, _turn(vec(spec.platform), tp), bodies,
                    tuple(j.type for j in spec.joints))
