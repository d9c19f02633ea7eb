"""Load-time checks of a description with a config's designs: every mistake
is one line naming the description's key.

For each named design (and the initial one), with the config's fixed
parameters:

* every expression is finite (the innermost failing operation is named:
  division by zero, square root of a negative number, asin/acos outside
  [-1, 1], overflow);
* directions and axes are not zero, a crank's reference is not parallel to
  its axis, rod and crank lengths are positive;
* a revolute leg's ``outer`` / ``inner`` is defined at the home pose (its two
  crank-tip solutions are not equally far from the base origin);
* every leg closes at the home pose (``pose.home``);
* the Jacobian is not singular at the home pose and at every one of a few
  poses around it (a structurally singular description: coincident legs,
  platform points all on one line through the centre ...).
"""
from __future__ import annotations

import math

import numpy as np

from .expr import first_problem

__all__ = ["check_designs", "leg_geometry"]


def _trees(desc):
    """(key path, tree) of every expression, in the order of the description."""
    out = []
    pose = desc.pose
    for i, t in enumerate(pose.centre):
        out.append((f"mechanism.pose.centre[{i}]", t))
    for k, t in pose.fixed.items():
        out.append((f"mechanism.pose.fixed.{k}", t))
    plat = desc.platform
    if plat.mass is not None:
        out.append(("mechanism.platform.mass", plat.mass))
    for i in range(3):
        for j in range(3):
            out.append(("mechanism.platform.inertia", plat.inertia[i][j]))
        out.append((f"mechanism.platform.centre_of_mass[{i}]", plat.com[i]))
    out.append(("mechanism.gravity", desc.gravity))
    for leg in desc.legs:
        p = leg.path
        for name, vec in (("base", leg.base), ("platform", leg.platform),
                          ("direction" if leg.kind == "prismatic" else "axis", leg.direction),
                          ("reference", leg.reference), ("rod.across", leg.across)):
            if vec is not None:
                for i, t in enumerate(vec):
                    out.append((f"{p}.{name}[{i}]", t))
        if leg.crank is not None:
            out.append((f"{p}.crank", leg.crank))
        if leg.rod is not None:
            out.append((f"{p}.rod", leg.rod))
        out.append((f"{p}.pattern", leg.turn_base))
        out.append((f"{p}.pattern", leg.turn_platform))
        for k, t in leg.bodies.items():
            part, key = k.split("_", 1)
            out.append((f"{p}.{part}.{key}", t))
    return out


def check_designs(cls, parameters, designs):
    desc = cls.description
    fixed = dict(cls.fixed_parameters)
    fixed.update({k: v for k, v in parameters.items() if k in fixed})
    trees = _trees(desc)
    for dname, design in designs.items():
        env = {**fixed, **{k: v for k, v in design.items() if k in cls.design_parameters}}
        for k in cls.design_parameters:
            env.setdefault(k, cls.design_defaults.get(k, math.nan))
        for path, tree in trees:
            problem = first_problem(tree, env)
            if problem:
                return path, f"{problem} (design {dname!r})"
        problem = _geometry(cls, env, dname)
        if problem:
            return problem
    return None


def _geometry(cls, env, dname):
    desc = cls.description
    mech = cls(**env)
    C = mech.constants
    problem = leg_geometry(desc, C, dname)
    if problem:
        return problem
    return _closes_and_moves(mech, desc, dname)


def leg_geometry(desc, C, dname):
    """(key, message) of the first shorthand leg with a zero direction or axis,
    a reference parallel to its axis, a length that is not positive or an
    undefined outer/inner branch, else None."""
    for i, leg in enumerate(desc.legs):
        p = leg.path
        if leg.direction is not None and not np.all(np.isfinite(C.U[i])):
            key = "direction" if leg.kind == "prismatic" else "axis"
            return f"{p}.{key}", f"has zero length (design {dname!r}, leg {leg.actuator})"
        if leg.kind == "revolute":
            if not np.all(np.isfinite(C.R0[i])):
                return f"{p}.reference", f"is parallel to the axis (design {dname!r}, leg {leg.actuator})"
            if not C.La[i] > 0:
                return f"{p}.crank", f"expected a positive crank length, got {float(C.La[i]):g} m (design {dname!r})"
        if leg.kind == "revolute" and leg.branch in ("outer", "inner") and not np.isfinite(C.sign[i]):
            return f"{p}.branch", (f"{leg.branch!r} is not defined for leg {leg.actuator} (design {dname!r}): at the "
                                   "home pose its two crank-tip solutions are equally far from the base origin "
                                   "(k . (w x A) = 0, e.g. a motor axis through the base origin, as a radial "
                                   "one), so round-off would pick the solution per leg and pose; give branch: "
                                   "plus or minus (q = atan2(Q, P) +- delta) for this leg")
        if leg.rod is not None and not C.Lr[i] > 0:
            return f"{p}.rod", f"expected a positive rod length, got {float(C.Lr[i]):g} m (design {dname!r})"
        if leg.across is not None and not np.all(np.isfinite(C.across[i])):
            return f"{p}.rod.across", f"has zero length (design {dname!r})"
    return None


def _closes_and_moves(mech, desc, dname):
    home = np.asarray(desc.pose.home, dtype=float)[None]
    raw = _leg_closes(mech, home)
    if not np.all(raw):
        i = int(np.flatnonzero(~raw)[0])
        leg = desc.legs[i]
        pose = ", ".join(f"{n} = {v:g}" for n, v in zip(desc.pose.names, home[0]))
        return leg.path, (f"leg {leg.actuator} cannot close at the home pose ({pose}) for design {dname!r}: "
                          f"{_why(mech, i, home)}; change the dimensions or pose.home")
    J = mech.jacobian(home)[0]
    n = J.shape[-1]
    if _rank(J) < n:
        ranks = ranks_around(mech, home, desc.pose.roles)
        if not ranks or max(ranks) < n:
            return "mechanism.legs", (f"the Jacobian is singular at the home pose and at every pose tried around it "
                                      f"(rank {max(ranks) if ranks else _rank(J)} of {n}, design {dname!r}): the legs "
                                      "cannot control every pose coordinate")
    return None


def ranks_around(mech, home, roles) -> list[int]:
    """The ranks of the Jacobian at 8 poses drawn (seed 12345) around the home
    pose (1, k) within 0.01 of a length coordinate and 0.02 of an angle (the
    coordinates' ``roles``), where it is finite: a singular home pose may be a
    special one, the rank near it says whether the legs control the motion."""
    rng = np.random.default_rng(12345)
    span = np.array([0.01 if r in ("x", "y", "z") else 0.02 for r in roles])
    X = home + span * rng.uniform(-1, 1, (8, len(span)))
    with np.errstate(all="ignore"):
        Js = mech.jacobian(X)
    Js = Js.reshape((-1,) + Js.shape[-3:])[0]
    return [_rank(Jk) for Jk, ok in zip(Js, np.all(np.isfinite(Js), axis=(-1, -2))) if ok]


def _leg_closes(mech, X):
    """Per leg (n,): whether the leg alone closes at pose X (1, dof)."""
    C = mech.constants
    st = mech.leg_state(X)
    w = st["w"][0]
    ww = np.sum(w * w, axis=-1)
    out = np.ones(len(C.kind), dtype=bool)
    for i, k in enumerate(C.kind):
        if k == 0:
            uw = w[i] @ C.U[i]
            out[i] = uw * uw - ww[i] + C.Lr[i] ** 2 >= 0
        elif k == 1:
            Pc, Qc = w[i] @ C.R0[i], w[i] @ C.S0[i]
            Cc = (ww[i] + C.La[i] ** 2 - C.Lr[i] ** 2) / (2 * C.La[i])
            out[i] = Pc * Pc + Qc * Qc - Cc * Cc >= 0
        else:
            out[i] = ww[i] > 0
    return out


def _why(mech, i, X):
    C = mech.constants
    w = mech.leg_state(X)["w"][0, i]
    k = C.kind[i]
    if k == 0:
        dist = float(np.linalg.norm(w - (w @ C.U[i]) * C.U[i]))
        return f"the platform point is {dist:.6g} m from the rail line, the rod is {float(C.Lr[i]):.6g} m long"
    if k == 1:
        # distance from the platform point to the crank circle
        Pc, Qc = w @ C.R0[i], w @ C.S0[i]
        ax = w @ C.U[i]
        rad = math.hypot(Pc, Qc)
        near = math.hypot(rad - float(C.La[i]), ax)
        far = math.hypot(rad + float(C.La[i]), ax)
        return (f"the platform point is {near:.6g} to {far:.6g} m from the crank tip circle, "
                f"the rod is {float(C.Lr[i]):.6g} m long")
    return "the platform point coincides with the base point"


def _rank(J: np.ndarray) -> int:
    if not np.all(np.isfinite(J)):
        return 0
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > s[0] * 1e-9)) if s[0] > 0 else 0

