"""Chain legs of a description (``kind: chain``): a leg as a serial chain of
joints from the base to the platform, validated into :class:`~.spec.ChainSpec`.

Every vector is written in the base frame at the chain's *reference
configuration*, where every joint value is 0 (``offset`` says what an
actuator reads there) and the platform has orientation I (its frame's axes
along the base's).  Joint types and their variables:

======  =========  ============================================================
type    variables  meaning
======  =========  ============================================================
``R``   1          rotation about ``axis`` through ``at``
``P``   1          translation along ``axis``
``U``   2          rotation about ``axis`` then about ``axis2`` (both through ``at``)
``S``   3          rotations about the base x, y, z through ``at``
``C``   2          translation along ``axis`` then rotation about it through ``at``
``Pa``  1          a parallelogram: ``side`` (proximal pivot -> distal pivot)
                   turns about ``axis``; the distal link translates by
                   ``(Rot(axis, t) - I) side`` and keeps its orientation
======  =========  ============================================================

A chain whose last joint is an ``S`` closes by position (its centre is the
platform point ``platform``); any other chain is fixed to the platform (its
last link *is* the platform: the end frame ``(I, at of the last joint)`` at
the reference configuration carries the platform point).  The keys and their
meaning: docs/lower-mobility.md.
"""
from __future__ import annotations

from typing import Any, Mapping

from ...checking import shorten, suggest
from .expr import names_of
from .schema import _CHECK, _NAME, _ZERO, _expr, _fail, _mapping, _only, _require, _turns, _vec
from .spec import ChainSpec, JointSpec, PoseSpec

__all__ = ["chain_group", "mapped_pose", "JOINT_TYPES", "MAX_JOINTS"]

JOINT_TYPES = ("R", "P", "U", "S", "C", "Pa")
MAX_JOINTS = 12
_GROUP = {"kind", "actuator", "actuators", "pattern", "joints", "platform"}
_JOINT = {"type", "axis", "axis2", "at", "side", "actuated", "home", "offset", "mass", "centre", "inertia"}
_NEEDS = {"R": ("axis", "at"), "P": ("axis", "at"), "U": ("axis", "axis2", "at"), "S": ("at",),
          "C": ("axis", "at"), "Pa": ("axis", "side", "at")}
_NVAR = {"R": 1, "P": 1, "Pa": 1, "U": 2, "C": 2, "S": 3}
_C_VARS = ("slide", "turn")


def _per_var(v: Any, n: int, path: str, names) -> tuple:
    """A number/expression (n == 1) or a list of n of them."""
    if n == 1 and not isinstance(v, (list, tuple)):
        return (_expr(v, path, names),)
    if not isinstance(v, (list, tuple)) or len(v) != n:
        _fail(path, f"expected a list of {n} values (one per variable of the joint)" + (" or one value" if n == 1 else ""))
    return tuple(_expr(x, f"{path}[{i}]", names) for i, x in enumerate(v))


def _inertia(v: Any, p: str, names) -> tuple:
    if isinstance(v, Mapping):
        _only(v, p, {"xx", "yy", "zz", "xy", "xz", "yz"})
        t = {k: _expr(v.get(k, 0), f"{p}.{k}", names) for k in ("xx", "yy", "zz", "xy", "xz", "yz")}
        return ((t["xx"], t["xy"], t["xz"]), (t["xy"], t["yy"], t["yz"]), (t["xz"], t["yz"], t["zz"]))
    if isinstance(v, list) and len(v) == 3:
        d = tuple(_expr(c, f"{p}[{i}]", names) for i, c in enumerate(v))
        return ((d[0], _ZERO, _ZERO), (_ZERO, d[1], _ZERO), (_ZERO, _ZERO, d[2]))
    _fail(p, "expected [Ixx, Iyy, Izz] or a mapping of xx, yy, zz, xy, xz, yz (kg m^2, about the centre, "
             "base axes at the reference configuration)")


def _actuated(v: Any, jtype: str, p: str) -> int | None:
    if v is None or v is False:
        return None
    if jtype == "C":
        if v not in _C_VARS:
            _fail(p, "a C joint has two variables: expected slide or turn (the one that is actuated)")
        return _C_VARS.index(v)
    if jtype in ("U", "S"):
        _fail(p, f"a {jtype} joint cannot be actuated; write the actuated rotation as an R joint and the "
                 "others as further joints")
    if v is not True:
        _fail(p, "expected true (this joint is the leg's actuated joint) or false")
    return 0


def _joint(raw: Any, path: str, names, last: bool, closure_by_s: bool) -> JointSpec:
    m = _mapping(raw, path)
    jtype = _CHECK.choice(_require(m, "type", path), f"{path}.type", JOINT_TYPES, "joint type")
    allowed = {"type", "actuated", "home", "offset", "mass", "centre", "inertia"} | set(_NEEDS[jtype])
    _only(m, path, allowed)
    vecs = {}
    for k in _NEEDS[jtype]:
        vecs[k] = _vec(_require(m, k, path), f"{path}.{k}", names)
    n = _NVAR[jtype]
    act = _actuated(m.get("actuated"), jtype, f"{path}.actuated")
    home = _per_var(m["home"], n, f"{path}.home", names) if m.get("home") is not None else (_ZERO,) * n
    offset = _per_var(m["offset"], n, f"{path}.offset", names) if m.get("offset") is not None else (_ZERO,) * n
    body: dict = {}
    if any(m.get(k) is not None for k in ("mass", "centre", "inertia")):
        if last:
            _fail(f"{path}.mass" if m.get("mass") is not None else path,
                  "the body after the last joint is the platform; give its mass and inertia under platform")
        body["mass"] = _expr(_require(m, "mass", path, "the mass of the link after this joint"), f"{path}.mass", names)
        body["centre"] = _vec(_require(m, "centre", path, "the link's centre of mass, base frame at the reference "
                                       "configuration"), f"{path}.centre", names)
        body["inertia"] = _inertia(m["inertia"], f"{path}.inertia", names) if m.get("inertia") is not None else \
            ((_ZERO,) * 3,) * 3
    if last and closure_by_s and act is not None:
        _fail(f"{path}.actuated", "the last S joint of a chain is its platform joint and cannot be actuated")
    return JointSpec(path, jtype, vecs.get("axis"), vecs.get("axis2"), vecs["at"], vecs.get("side"), act, home,
                     offset, body)


def chain_group(m: Mapping, path: str, names, counters: dict) -> list[ChainSpec]:
    """The legs (one per pattern angle) of a ``kind: chain`` group."""
    _only(m, path, _GROUP)
    raw = _require(m, "joints", path, "the joints from the base to the platform")
    if not isinstance(raw, list) or not 1 <= len(raw) <= MAX_JOINTS:
        _fail(f"{path}.joints", f"expected a list of 1 to {MAX_JOINTS} joints (base to platform)")
    by_s = isinstance(raw[-1], Mapping) and raw[-1].get("type") == "S"
    joints = tuple(_joint(j, f"{path}.joints[{i}]", names, i == len(raw) - 1, by_s) for i, j in enumerate(raw))
    acted = [j for j in joints if j.actuated is not None]
    if len(acted) > 1:
        _fail(f"{acted[1].path}.actuated", f"a leg has at most one actuated joint ({acted[0].path} is one already)")
    plat = _vec(_require(m, "platform", path, "the platform point of the last joint, platform frame"),
                f"{path}.platform", names)
    turns = _turns(m.get("pattern"), f"{path}.pattern", names)
    passive = not acted
    if passive:
        for k in ("actuator", "actuators"):
            if k in m:
                _fail(f"{path}.{k}", "a passive leg (no actuated joint) has no actuator name")
        names_out = [None] * len(turns)
    elif "actuators" in m:
        acts = m["actuators"]
        if not isinstance(acts, list) or len(acts) != len(turns):
            _fail(f"{path}.actuators", f"expected a list of {len(turns)} names (one per leg of the group)")
        for i, a in enumerate(acts):
            if not isinstance(a, str) or not _NAME.match(a):
                _fail(f"{path}.actuators[{i}]", "expected a name of letters, digits and '_'")
        if "actuator" in m:
            _fail(f"{path}.actuator", "give either actuator (a prefix) or actuators (a list), not both")
        names_out = list(acts)
    else:
        prefix = m.get("actuator", "q")
        if not isinstance(prefix, str) or not _NAME.match(prefix):
            _fail(f"{path}.actuator", "expected a name prefix of letters, digits and '_'")
        names_out = []
        for _ in turns:
            counters[prefix] = counters.get(prefix, 0) + 1
            names_out.append(f"{prefix}{counters[prefix]}")
    return [ChainSpec(path, names_out[i], joints, plat, tb, tp) for i, (tb, tp) in enumerate(turns)]


def mapped_pose(m, path, names, ptype, cn, roles, fixed, centre, home, jac) -> PoseSpec:
    """A pose whose independent coordinates are new names, each pose coordinate
    of ``map`` an expression of them (and of the parameters)."""
    new = m["independent"]
    p = f"{path}.independent"
    for i, c in enumerate(new):
        if not isinstance(c, str) or not _NAME.match(c):
            _fail(f"{p}[{i}]", f"expected a name of letters, digits and '_', got {shorten(c)}")
        if c in cn or c in names:
            _fail(f"{p}[{i}]", f"{c!r} is a pose coordinate or a parameter; a mapped coordinate needs a new name")
    if len(set(new)) != len(new):
        _fail(p, "the independent coordinates must differ")
    mp = _mapping(m["map"], f"{path}.map")
    for k in mp:
        if k not in cn:
            _fail(f"{path}.map.{k}", f"unknown pose coordinate{suggest(k, cn)}; expected one of {', '.join(cn)}")
    if len(mp) != len(new):
        _fail(f"{path}.map", f"expected {len(new)} pose coordinates (one per independent coordinate), got {len(mp)}")
    trees = tuple(_expr(v, f"{path}.map.{k}", list(names) + list(new)) for k, v in mp.items())
    used = set().union(*(names_of(t) for t in trees))
    for c in new:
        if c not in used:
            _fail(f"{path}.map", f"the independent coordinate {c!r} appears in no expression")
    units = {c: "1" for c in new}
    if m.get("units") is not None:
        um = _mapping(m["units"], f"{path}.units")
        _only(um, f"{path}.units", set(new), what="independent coordinate")
        for k, v in um.items():
            units[k] = _CHECK.string(v, f"{path}.units.{k}", choices={"m", "rad", "1"})
    if jac != "rates":
        _fail(f"{path}.jacobian", "a pose with parasitic coordinates has the Jacobian in the independent coordinates' rates only")
    independent = tuple(cn.index(k) for k in mp)
    return PoseSpec(ptype, tuple(cn), roles, fixed, centre, tuple(home), jac, independent, tuple(new), trees,
                    tuple(units[c] for c in new))

