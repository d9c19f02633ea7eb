"""The description of a mechanism (the ``mechanism:`` mapping of a config) ->
plain, validated data: parameters, pose type, platform, legs (patterns expanded).

Every mistake raises :class:`DescriptionError` with the key path (``mechanism.legs[1].rod.length``)
and a one-line message; the config loader adds the file name.  The keys, their
units and defaults are documented in ``docs/mechanisms-as-data.md``.
"""
from __future__ import annotations

import math
import re
from typing import Any, Mapping

from ...checking import Checker, shorten, suggest, tname
from .. import DescriptionError
from .expr import CONSTANTS, FUNCTIONS, ExprError, parse
from .spec import Description, LegSpec, ParamDecl, PlatformSpec, PoseSpec

__all__ = ["DescriptionError", "ParamDecl", "PoseSpec", "PlatformSpec", "LegSpec", "Description",
           "parse_description", "POSE_TYPES", "LEG_KINDS", "PARAM_KINDS", "ROLES"]

#: the six rigid-body coordinates a pose coordinate can be
ROLES = ("x", "y", "z", "roll", "pitch", "yaw")
POSE_TYPES = {
    "translation": ("x", "y", "z"),
    "planar": ("x", "y", "yaw"),
    "rotation": ("roll", "pitch", "yaw"),
    "spatial": ("x", "y", "z", "roll", "pitch", "yaw"),
}
_DEFAULT_NAMES = {"translation": ("x", "y", "z"), "planar": ("x", "y", "theta"),
                  "rotation": ("roll", "pitch", "yaw"), "spatial": ("x", "y", "z", "roll", "pitch", "yaw")}
LEG_KINDS = ("prismatic", "revolute", "strut", "chain")
#: parameter kinds (the Param table's) and whether they are design dimensions by default
PARAM_KINDS = {"length": True, "angle": True, "number": True, "mass": False, "inertia": False,
               "stiffness": False, "acceleration": False}
BRANCHES = {"prismatic": ("minus", "plus", "outer", "inner"), "revolute": ("outer", "inner", "plus", "minus")}
MAX_LEGS = 12
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,39}$")

_TOP = {"name", "parameters", "pose", "platform", "gravity", "legs"}
_POSE = {"type", "coordinates", "angles", "fixed", "centre", "home", "jacobian", "independent", "map", "units"}
_PLATFORM = {"mass", "inertia", "centre_of_mass"}
_PATTERN = {"angles", "unit", "split"}
_COMMON = {"kind", "actuator", "actuators", "pattern", "base", "platform"}
_KIND_KEYS = {"prismatic": {"direction", "rod", "slider", "branch"},
              "revolute": {"axis", "reference", "crank", "rod", "branch"},
              "strut": {"lower", "upper"}}
_ROD = {"length", "mass", "count", "inertia", "centre", "width", "across"}
_CRANK = {"length", "inertia", "mass", "centre"}
_SLIDER = {"mass"}
_STRUT_PART = {"mass", "centre", "inertia"}




# ---------------------------------------------------------------------- helpers
class _Checker(Checker):
    """The package's one validation toolkit (optdesign.checking), raising DescriptionError."""

    def fail(self, path: str, message: str):
        raise DescriptionError(path, message)


_CHECK = _Checker()
_fail = _CHECK.fail
_mapping = _CHECK.mapping
_only = _CHECK.only
_number = _CHECK.number


def _require(m: Mapping, key: str, path: str, why: str = "") -> Any:
    return _CHECK.require(m, key, path, why, null_is_missing=True)


def _expr(v: Any, path: str, names) -> tuple:
    try:
        return parse(v, names)
    except ExprError as exc:
        _fail(path, str(exc))


def _vec(v: Any, path: str, names) -> tuple:
    if not isinstance(v, (list, tuple)) or len(v) != 3:
        _fail(path, f"expected a list of 3 expressions [x, y, z], got {tname(v)}")
    return tuple(_expr(c, f"{path}[{i}]", names) for i, c in enumerate(v))


_ZERO = ("num", 0.0)


# ---------------------------------------------------------------------- parameters
def _params(raw: Any, path: str) -> tuple[ParamDecl, ...]:
    if raw is None:
        return ()
    m = _mapping(raw, path)
    out = []
    for name, spec in m.items():
        p = f"{path}.{name}"
        if not _NAME.match(name):
            _fail(p, "expected a parameter name of letters, digits and '_' (not starting with a digit, at most 40 characters)")
        if name in FUNCTIONS or name in CONSTANTS:
            _fail(p, f"{name!r} is a function or constant of the expression language; choose another name")
        if isinstance(spec, str):
            spec = {"kind": spec}
        spec = _mapping(spec, p)
        _only(spec, p, {"kind", "design", "default", "doc"})
        kind = _CHECK.choice(_require(spec, "kind", p), f"{p}.kind", tuple(PARAM_KINDS), "parameter kind")
        design = _CHECK.boolean(spec.get("design", PARAM_KINDS[kind]), f"{p}.design")
        default = spec.get("default")
        if default is not None:
            default = _number(default, f"{p}.default")
            if kind in ("mass", "inertia", "acceleration") and default < 0:
                unit = {"mass": "kg", "inertia": "kg m^2", "acceleration": "m/s^2"}[kind]
                _fail(f"{p}.default", f"expected a {kind} >= 0 {unit}, got {default:g}")
        elif not design:
            _fail(f"{p}.default", "a fixed parameter (design: false) needs a default")
        doc = _CHECK.string(spec.get("doc", ""), f"{p}.doc")
        out.append(ParamDecl(name, kind, design, default, doc))
    return tuple(out)


# ---------------------------------------------------------------------- pose
def _pose(raw: Any, path: str, names) -> PoseSpec:
    m = _mapping(raw, path)
    _only(m, path, _POSE)
    ptype = _CHECK.choice(_require(m, "type", path), f"{path}.type", tuple(POSE_TYPES), "pose type")
    roles = POSE_TYPES[ptype]
    fixed: dict = {}
    if "angles" in m:
        if ptype != "rotation":
            _fail(f"{path}.angles", "only a rotation pose chooses its angles")
        ang = m["angles"]
        if not isinstance(ang, list) or not 1 <= len(ang) <= 3 or any(a not in roles for a in ang) or len(set(ang)) != len(ang):
            _fail(f"{path}.angles", f"expected a list of 1 to 3 different angles among roll, pitch, yaw, got {shorten(ang)}")
        roles = tuple(a for a in POSE_TYPES["rotation"] if a in ang)
    if "fixed" in m:
        if ptype != "rotation":
            _fail(f"{path}.fixed", "only a rotation pose with fewer than three angles has fixed angles")
        fm = _mapping(m["fixed"], f"{path}.fixed")
        for k, v in fm.items():
            if k not in POSE_TYPES["rotation"] or k in roles:
                _fail(f"{path}.fixed.{k}", f"expected one of the angles that are not coordinates ({', '.join(a for a in POSE_TYPES['rotation'] if a not in roles) or 'none'})")
            fixed[k] = _expr(v, f"{path}.fixed.{k}", names)
    for a in POSE_TYPES["rotation"]:
        if ptype == "rotation" and a not in roles:
            fixed.setdefault(a, _ZERO)
    default_names = _DEFAULT_NAMES[ptype]
    if ptype == "rotation":
        default_names = roles
    cn = m.get("coordinates", list(default_names))
    if not isinstance(cn, list) or len(cn) != len(roles):
        _fail(f"{path}.coordinates", f"expected a list of {len(roles)} names ({', '.join(roles)} in this order), got {tname(cn)}")
    for i, c in enumerate(cn):
        if not isinstance(c, str) or not _NAME.match(c):
            _fail(f"{path}.coordinates[{i}]", f"expected a name of letters, digits and '_', got {shorten(c)}")
    if len(set(cn)) != len(cn):
        _fail(f"{path}.coordinates", "the coordinate names must differ")
    centre = _vec(m["centre"], f"{path}.centre", names) if m.get("centre") is not None else (_ZERO,) * 3
    if m.get("centre") is not None and ptype != "rotation":
        _fail(f"{path}.centre", "only a rotation pose has a fixed centre")
    home = [0.0] * len(cn)
    if m.get("home") is not None:
        hm = _mapping(m["home"], f"{path}.home")
        _only(hm, f"{path}.home", set(cn), what="pose coordinate")
        for k, v in hm.items():
            home[cn.index(k)] = _number(v, f"{path}.home.{k}")
    jac = _CHECK.string(m.get("jacobian", "rates"), f"{path}.jacobian", choices={"rates", "angular_velocity"})
    if jac == "angular_velocity" and len(set(roles) & {"roll", "pitch", "yaw"}) not in (0, 3) and ptype != "planar":
        _fail(f"{path}.jacobian", "angular_velocity needs all three angles as coordinates (else J is not square)")
    independent = None
    if m.get("independent") is not None:
        ind = m["independent"]
        p = f"{path}.independent"
        if not isinstance(ind, list) or not 1 <= len(ind) <= len(cn):
            _fail(p, f"expected a list of 1 to {len(cn)} of the pose coordinates ({', '.join(cn)}), got {tname(ind)}")
        if m.get("map") is not None:
            from .chain_schema import mapped_pose

            return mapped_pose(m, path, names, ptype, cn, roles, fixed, centre, home, jac)
        for i, c in enumerate(ind):
            if c not in cn:
                _fail(f"{p}[{i}]", f"unknown pose coordinate {shorten(c)}{suggest(c, cn)}; expected one of {', '.join(cn)}")
        if len(set(ind)) != len(ind):
            _fail(p, "the independent coordinates must differ")
        if jac != "rates":
            _fail(f"{path}.jacobian", "a pose with parasitic coordinates has the Jacobian in the independent coordinates' rates only")
        independent = tuple(cn.index(c) for c in ind)
    for k in ("map", "units"):
        if m.get(k) is not None:
            _fail(f"{path}.{k}", "a coordinate map needs pose.independent (the new coordinates' names)")
    return PoseSpec(ptype, tuple(cn), roles, fixed, centre, tuple(home), jac, independent)


# ---------------------------------------------------------------------- platform
def _platform(raw: Any, path: str, names) -> PlatformSpec:
    if raw is None:
        return PlatformSpec(None, ((_ZERO,) * 3,) * 3, (_ZERO,) * 3)
    m = _mapping(raw, path)
    _only(m, path, _PLATFORM)
    mass = _expr(m["mass"], f"{path}.mass", names) if m.get("mass") is not None else None
    inertia = ((_ZERO,) * 3,) * 3
    if m.get("inertia") is not None:
        v = m["inertia"]
        p = f"{path}.inertia"
        if isinstance(v, Mapping):
            _only(v, p, {"xx", "yy", "zz", "xy", "xz", "yz"})
            t = {k: _expr(v.get(k, 0), f"{p}.{k}", names) for k in ("xx", "yy", "zz", "xy", "xz", "yz")}
            inertia = ((t["xx"], t["xy"], t["xz"]), (t["xy"], t["yy"], t["yz"]), (t["xz"], t["yz"], t["zz"]))
        elif isinstance(v, list) and len(v) == 3:
            d = tuple(_expr(c, f"{p}[{i}]", names) for i, c in enumerate(v))
            inertia = ((d[0], _ZERO, _ZERO), (_ZERO, d[1], _ZERO), (_ZERO, _ZERO, d[2]))
        else:
            _fail(p, f"expected [Ixx, Iyy, Izz] or a mapping of xx, yy, zz, xy, xz, yz (kg m^2), got {tname(v)}")
    com = _vec(m["centre_of_mass"], f"{path}.centre_of_mass", names) if m.get("centre_of_mass") is not None else (_ZERO,) * 3
    return PlatformSpec(mass, inertia, com)


# ---------------------------------------------------------------------- legs
def _turns(pat: Any, path: str, names) -> list[tuple[tuple, tuple]]:
    """[(turn of the base side, turn of the platform side)] as trees, one per leg."""
    if pat is None:
        return [(_ZERO, _ZERO)]
    m = _mapping(pat, path)
    _only(m, path, _PATTERN)
    unit = _CHECK.string(m.get("unit", "rad"), f"{path}.unit", choices={"rad", "deg"})
    ang = _require(m, "angles", path)
    if not isinstance(ang, list) or not 1 <= len(ang) <= MAX_LEGS:
        _fail(f"{path}.angles", f"expected a list of 1 to {MAX_LEGS} angles, got {tname(ang)}")
    scale = ("num", math.pi / 180.0) if unit == "deg" else None
    angles = []
    for i, a in enumerate(ang):
        t = _expr(a, f"{path}.angles[{i}]", names)
        if scale is not None:
            t = ("num", t[1] * scale[1]) if t[0] == "num" else ("bin", "*", t, scale)
        angles.append(t)
    if m.get("split") is None:
        return [(a, a) for a in angles]
    sp = m["split"]
    if isinstance(sp, Mapping):
        _only(sp, f"{path}.split", {"base", "platform"})
        sb = _expr(sp.get("base", 0), f"{path}.split.base", names)
        spl = _expr(sp.get("platform", 0), f"{path}.split.platform", names)
    else:
        sb = spl = _expr(sp, f"{path}.split", names)
    out = []
    for a in angles:
        for s in (-0.5, 0.5):
            out.append((("bin", "+", a, ("bin", "*", ("num", s), sb)), ("bin", "+", a, ("bin", "*", ("num", s), spl))))
    return out


def _bodies(m: Mapping, key: str, allowed: set, path: str, names, prefix: str) -> dict:
    if m.get(key) is None:
        return {}
    sub = _mapping(m[key], f"{path}.{key}")
    _only(sub, f"{path}.{key}", allowed)
    return {f"{prefix}_{k}": _expr(v, f"{path}.{key}.{k}", names) for k, v in sub.items() if k not in ("length", "across")}


def _leg_group(raw: Any, path: str, names, counters: dict, start: int) -> list:
    m = _mapping(raw, path)
    kind = _CHECK.choice(_require(m, "kind", path), f"{path}.kind", LEG_KINDS, "leg kind")
    if kind == "chain":
        from .chain_schema import chain_group

        return chain_group(m, path, names, counters)
    _only(m, path, _COMMON | _KIND_KEYS[kind])
    base = _vec(_require(m, "base", path), f"{path}.base", names)
    plat = _vec(_require(m, "platform", path), f"{path}.platform", names)
    direction = reference = crank = rod = across = None
    bodies: dict = {}
    if kind == "prismatic":
        direction = _vec(_require(m, "direction", path, "unit vector of the rail"), f"{path}.direction", names)
        bodies.update(_bodies(m, "slider", _SLIDER, path, names, "slider"))
    elif kind == "revolute":
        direction = _vec(_require(m, "axis", path, "direction of the motor axis"), f"{path}.axis", names)
        reference = _vec(_require(m, "reference", path, "direction of the crank at q = 0"), f"{path}.reference", names)
        cr = _require(m, "crank", path, "crank length, or a mapping with length")
        if isinstance(cr, Mapping):
            crm = _mapping(cr, f"{path}.crank")
            _only(crm, f"{path}.crank", _CRANK)
            crank = _expr(_require(crm, "length", f"{path}.crank"), f"{path}.crank.length", names)
            bodies.update(_bodies(m, "crank", _CRANK, path, names, "crank"))
        else:
            crank = _expr(cr, f"{path}.crank", names)
    else:
        bodies.update(_bodies(m, "lower", _STRUT_PART, path, names, "lower"))
        bodies.update(_bodies(m, "upper", _STRUT_PART, path, names, "upper"))
    if kind in ("prismatic", "revolute"):
        r = _require(m, "rod", path, "rod length, or a mapping with length")
        if isinstance(r, Mapping):
            rm = _mapping(r, f"{path}.rod")
            _only(rm, f"{path}.rod", _ROD)
            rod = _expr(_require(rm, "length", f"{path}.rod"), f"{path}.rod.length", names)
            bodies.update(_bodies(m, "rod", _ROD, path, names, "rod"))
            if rm.get("across") is not None:
                across = _vec(rm["across"], f"{path}.rod.across", names)
        else:
            rod = _expr(r, f"{path}.rod", names)
    branch = None
    if kind in BRANCHES:
        branch = _CHECK.string(m.get("branch", "minus" if kind == "prismatic" else "outer"), f"{path}.branch",
                               choices=set(BRANCHES[kind]))
    turns = _turns(m.get("pattern"), f"{path}.pattern", names)
    if "actuators" in m:
        acts = m["actuators"]
        if not isinstance(acts, list) or len(acts) != len(turns):
            _fail(f"{path}.actuators", f"expected a list of {len(turns)} names (one per leg of the group), got {tname(acts)}")
        for i, a in enumerate(acts):
            if not isinstance(a, str) or not _NAME.match(a):
                _fail(f"{path}.actuators[{i}]", f"expected a name of letters, digits and '_', got {shorten(a)}")
        if "actuator" in m:
            _fail(f"{path}.actuator", "give either actuator (a prefix) or actuators (a list), not both")
        names_out = list(acts)
    else:
        prefix = m.get("actuator", "q")
        if not isinstance(prefix, str) or not _NAME.match(prefix):
            _fail(f"{path}.actuator", f"expected a name prefix of letters, digits and '_', got {shorten(prefix)}")
        names_out = []
        for _ in turns:
            counters[prefix] = counters.get(prefix, 0) + 1
            names_out.append(f"{prefix}{counters[prefix]}")
    return [LegSpec(path, names_out[i], kind, base, plat, direction, reference, crank, rod, tb, tp, branch,
                    dict(bodies), across) for i, (tb, tp) in enumerate(turns)]


# ---------------------------------------------------------------------- top level
def parse_description(raw: Any, path: str = "mechanism", label: str | None = None) -> Description:
    """Validate a description mapping; raises DescriptionError naming the key."""
    m = _mapping(raw, path)
    _only(m, path, _TOP)
    name = m.get("name")
    if name is None:
        name = re.sub(r"\W", "_", label or "")[:40].strip("_") or "described"
        name = name if _NAME.match(name) else "described"
    if not isinstance(name, str) or not _NAME.match(name):
        _fail(f"{path}.name", f"expected a name of letters, digits and '_', got {shorten(name)}")
    params = _params(m.get("parameters"), f"{path}.parameters")
    names = [p.name for p in params]
    pose = _pose(_require(m, "pose", path), f"{path}.pose", names)
    clash = set(pose.names) & set(names)
    if clash:
        _fail(f"{path}.pose.coordinates", f"{sorted(clash)[0]!r} is also a parameter name")
    platform = _platform(m.get("platform"), f"{path}.platform", names)
    legs_raw = _require(m, "legs", path)
    if not isinstance(legs_raw, list) or not legs_raw:
        _fail(f"{path}.legs", f"expected a list of leg groups, got {tname(legs_raw)}")
    legs: list[LegSpec] = []
    chains: list = []
    order: list = []
    counters: dict = {}
    for i, g in enumerate(legs_raw):
        for leg in _leg_group(g, f"{path}.legs[{i}]", names, counters, len(legs) + len(chains)):
            if isinstance(leg, LegSpec):
                order.append((leg.actuator, "leg", len(legs)))
                legs.append(leg)
            else:
                if leg.actuator is not None:
                    order.append((leg.actuator, "chain", len(chains)))
                chains.append(leg)
        if len(legs) + len(chains) > MAX_LEGS:
            _fail(f"{path}.legs", f"more than {MAX_LEGS} legs")
    chain_class = bool(chains) or pose.independent is not None
    n_ind = len(pose.independent_index)
    if chain_class and len(order) != n_ind:
        ind = ", ".join(pose.names[i] for i in pose.independent_index)
        _fail(f"{path}.legs", f"{len(order)} actuated legs for {n_ind} independent pose coordinates ({ind}); "
              f"expected {n_ind}: one actuated leg per independent coordinate (passive legs have no actuated joint)")
    if not chain_class and len(legs) != pose.dof:
        _fail(f"{path}.legs", f"{len(legs)} legs for a pose of {pose.dof} coordinates ({', '.join(pose.names)}); "
              f"expected {pose.dof}: one actuated leg per pose coordinate")
    acts = [a for a, _, _ in order]
    dup = sorted({a for a in acts if acts.count(a) > 1})
    if dup:
        _fail(f"{path}.legs", f"actuator name {dup[0]!r} is used twice")
    if set(acts) & set(names):
        _fail(f"{path}.legs", f"actuator name {sorted(set(acts) & set(names))[0]!r} is also a parameter name")
    gravity = _expr(m["gravity"], f"{path}.gravity", names) if m.get("gravity") is not None else ("num", 9.81)
    has_dyn = platform.mass is not None
    if not has_dyn and (any(leg.bodies for leg in legs) or any(j.body for c in chains for j in c.joints)):
        _fail(f"{path}.platform.mass", "legs have masses but the platform has none; give platform.mass (0 is allowed)")
    if chain_class:
        return Description(name, params, pose, platform, gravity, tuple(legs), has_dyn, tuple(chains), tuple(order))
    return Description(name, params, pose, platform, gravity, tuple(legs), has_dyn)
