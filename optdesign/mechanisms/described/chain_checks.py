"""Load-time checks of a chain description with a config's designs (one
line naming the key, as :mod:`.checks`): for each named design and the
initial one,

* every expression is finite; axes are not zero, a U's axes not parallel;
  the shorthand legs' geometry (:func:`.checks.leg_geometry`);
* the chains close at the home pose (Newton from the joints' ``home`` values
  converges), and so do the shorthand legs at the whole home pose;
* the **mobility** (6 - rank of the constraint wrenches reciprocal to the
  legs' twist systems at home) equals the number of independent coordinates;
  otherwise the message names the leg to look at;
* the independent coordinates parametrize the motion: the closures'
  Jacobian in the unknowns (joint values, parasitic coordinates) has full
  column rank at home (else a leg has an idle joint, named, or the parasitic
  coordinates are not determined);
* the Jacobian dq/dx is not singular at home and around it.
"""
from __future__ import annotations

import math

import numpy as np

from .chain_constants import chain_constants
from .checks import _rank, _trees, _why, leg_geometry, ranks_around
from .expr import first_problem

__all__ = ["check_designs", "mobility_problem"]


def _chain_trees(desc):
    out = []
    for c in desc.chains:
        for j in c.joints:
            for key in ("at", "axis", "axis2", "side"):
                vec = getattr(j, key)
                if vec is not None:
                    out += [(f"{j.path}.{key}[{i}]", t) for i, t in enumerate(vec)]
            for key in ("home", "offset"):
                out += [(f"{j.path}.{key}", t) for t in getattr(j, key)]
            if j.body:
                out.append((f"{j.path}.mass", j.body["mass"]))
                out += [(f"{j.path}.centre[{i}]", t) for i, t in enumerate(j.body["centre"])]
                out += [(f"{j.path}.inertia", t) for row in j.body["inertia"] for t in row]
        out += [(f"{c.path}.platform[{i}]", t) for i, t in enumerate(c.platform)]
        out += [(f"{c.path}.pattern", c.turn_base), (f"{c.path}.pattern", c.turn_platform)]
    return out


def check_designs(cls, parameters, designs):
    desc = cls.description
    fixed = dict(cls.fixed_parameters)
    fixed.update({k: v for k, v in parameters.items() if k in fixed})
    trees = _trees(desc) + _chain_trees(desc)
    for dname, design in designs.items():
        env = {**fixed, **{k: v for k, v in design.items() if k in cls.design_parameters}}
        for k in cls.design_parameters:
            env.setdefault(k, cls.design_defaults.get(k, math.nan))
        for path, tree in trees:
            problem = first_problem(tree, env)
            if problem:
                return path, f"{problem} (design {dname!r})"
        problem = _geometry(cls(**env), dname)
        if problem:
            return problem
    return None


def _pose_text(spec, values, which=None):
    idx = range(len(spec.names)) if which is None else which
    return ", ".join(f"{spec.names[i]} = {values[i]:g}" for i in idx)


def _geometry(mech, dname):
    desc, spec = mech.description, mech.pose_spec
    cc = mech.chain_constants
    for ci, (c, leg) in enumerate(zip(desc.chains, cc.legs)):
        for v, j in enumerate(leg.joint_of):
            js = c.joints[j]
            if not np.all(np.isfinite(leg.axis[..., v, :])):
                key = "axis2" if js.type == "U" and v > 0 and leg.joint_of[v - 1] == j else "axis"
                return f"{js.path}.{key}", f"has zero length (design {dname!r})"
        for j, js in enumerate(c.joints):
            if js.type == "U":
                v = leg.joint_of.index(j)
                if np.linalg.norm(np.cross(leg.axis[..., v, :], leg.axis[..., v + 1, :])) < 1e-9:
                    return f"{js.path}.axis2", f"is parallel to axis: a U joint needs two different axes (design {dname!r})"
    problem = leg_geometry(desc, mech.constants, dname)
    if problem:
        return problem
    u, ok = mech.home_solution()
    home = np.asarray(spec.home, dtype=float)
    if not bool(np.all(ok)):
        return _no_home(mech, dname)
    Xf = home.copy()
    Xf[list(spec.parasitic_index)] = u[0, u.shape[1] - len(spec.parasitic_index):]
    if desc.legs:
        st = mech.leg_state(Xf[None])
        bad = ~np.isfinite(st["q"][0])
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            leg = desc.legs[i]
            return leg.path, (f"leg {leg.actuator} cannot close at the home pose ({_pose_text(spec, Xf)}) for design "
                              f"{dname!r}: {_why(mech, i, Xf[None])}; change the dimensions or pose.home")
    problem = mobility_problem(mech, dname)
    if problem:
        return problem
    problem = _parametrization(mech, dname)
    if problem:
        return problem
    return _actuation(mech, dname)


def _no_home(mech, dname):
    """The chains do not close at home: name the leg with the largest residual."""
    from .chain_solve import flat_constants, ik_system, newton

    desc, spec = mech.description, mech.pose_spec
    cc = mech.chain_constants
    fc = flat_constants(cc, np.arange(1))
    home = np.asarray(spec.home, dtype=float)
    u0 = np.concatenate([leg["home"] for leg in fc["legs"]] + [home[list(spec.parasitic_index)][None]], 1)
    p = home[list(spec.independent_index)][None]
    fun = lambda x, q: ik_system(desc, fc, x, q)  # noqa: E731
    u, _, (F, _, _) = newton(fun, u0, p, fc["length"], iters=100, damped=True)
    worst, where, r0 = 0.0, 0, 0
    for i, leg in enumerate(cc.legs):
        res = float(np.max(np.abs(F[0, r0:r0 + leg.rows])))
        if not res <= worst:
            worst, where = res, i
        r0 += leg.rows
    c = desc.chains[where]
    who = f"leg {c.actuator}" if c.actuator else "a passive leg"
    return c.path, (f"the chains cannot close at the home pose ({_pose_text(spec, home, spec.independent_index)}) "
                    f"for design {dname!r}: Newton from the joints' home values and pose.home stops with a residual "
                    f"of {worst:.3g} m at {who}; change the dimensions, pose.home or the joints' home values")


def _joints_text(types) -> str:
    return "-".join(types)


def mobility_problem(mech, dname):
    """(key, message) when the mobility at home differs from the number of
    independent coordinates, else None."""
    desc, spec = mech.description, mech.pose_spec
    mob = mech.mobility()
    m = int(np.ravel(mob["mobility"])[0])
    n = len(spec.independent_index)
    if m == n:
        return None
    ind = ", ".join(spec.names[i] for i in spec.independent_index)
    rank = int(np.ravel(mob["rank"])[0])
    ranks = np.ravel(mob["leg_ranks"])
    without = np.ravel(mob["without"])
    legs = mech.chain_constants.legs
    how = (f"the platform's mobility is {m} (6 minus the rank {rank} of the constraint wrenches reciprocal to the "
           f"legs' twist systems at the home pose{', the pose type adding ' + str(mob['pose_constraints']) if mob['pose_constraints'] else ''})"
           f", but the pose has {n} independent coordinate{'s' if n != 1 else ''} ({ind})")
    pick = None
    if m > n:
        free = [i for i in range(len(legs)) if ranks[i] == 6]
        redundant = [i for i in range(len(legs)) if without[i] == m and ranks[i] < 6]
        if free:
            pick, why = free[0], "its twist system has rank 6, so it constrains nothing"
        elif redundant:
            pick, why = redundant[0], f"its {6 - ranks[redundant[0]]} constraint wrench(es) repeat the other legs'"
    else:
        closer = [i for i in range(len(legs)) if without[i] > m]
        if closer:
            pick = max(closer, key=lambda i: (without[i] == n, without[i]))
            why = (f"its twist system has rank {ranks[pick]}, so it removes {6 - ranks[pick]} motion(s); without it "
                   f"the mobility would be {without[pick]}")
    if pick is None:
        return "mechanism.legs", how + "; look at the joints' axes (a missing or an extra joint)"
    c = desc.chains[pick]
    who = f"leg {c.actuator}" if c.actuator else "the passive leg"
    return c.path, f"{how}; look at {who} (joints {_joints_text(legs[pick].types)}): {why}"


def _parametrization(mech, dname):
    """The closures' Jacobian in the unknowns has full column rank at home."""
    core = mech.home_state()
    if np.all(np.isfinite(core["U"])):
        return None
    desc, spec = mech.description, mech.pose_spec
    from .chain_poe import chain_poe, leg_rows
    from .poses import frames

    C = mech.constants
    Xf = core["Xf"].reshape(-1, spec.dof)[:1]
    fr = frames(spec, Xf, C.centre, C.fixed)
    for i, leg in enumerate(mech.chain_constants.legs):
        th = core["theta"][i].reshape(-1, leg.k)[:1]
        _, Ft, _ = leg_rows(leg.as_dict(), chain_poe(leg.as_dict(), th), fr.R, fr.origin, mech.chain_constants.length)
        Ft = Ft[0]
        if leg.k and _rank(Ft) < leg.k:
            _, _, vt = np.linalg.svd(Ft)
            v = int(np.argmax(np.abs(vt[-1])))
            js = desc.chains[i].joints[leg.joint_of[v]]
            who = f"leg {leg.actuator}" if leg.actuator else "a passive leg"
            return js.path, (f"the joint values of {who} are not determined at the home pose (design {dname!r}): its "
                             f"joints' motions of the platform point are dependent (rank {_rank(Ft)} of {leg.k}), "
                             "e.g. an idle spin between two S joints or two parallel P joints; look at this joint")
    par = ", ".join(spec.names[i] for i in spec.parasitic_index)
    ind = ", ".join(spec.names[i] for i in spec.independent_index)
    return "mechanism.pose.independent", (
        f"the independent coordinates ({ind}) cannot parametrize the motion at the home pose (design {dname!r}): "
        f"with them fixed, the closures do not determine the parasitic coordinates ({par}) (their constraint "
        "Jacobian is singular); choose other independent coordinates")


def _actuation(mech, dname):
    spec = mech.pose_spec
    home = np.asarray(mech.home_coordinates(), dtype=float).reshape(1, -1)
    J = mech.jacobian(home)
    J = J.reshape(-1, *J.shape[-2:])[0]
    n = J.shape[-1]
    if _rank(J) == n:
        return None
    roles = [spec.roles[i] for i in spec.independent_index] if spec.cmap is None else ["x"] * n
    ranks = ranks_around(mech, home, roles)
    if not ranks or max(ranks) < n:
        return "mechanism.legs", (f"the Jacobian dq/dx is singular at the home pose and at every pose tried around it "
                                  f"(rank {max(ranks) if ranks else _rank(J)} of {n}, design {dname!r}): the actuated "
                                  "joints cannot control every independent coordinate")
    return None


def physical_problems(desc, cc):
    """[(key path, what is expected, values, bad)] of the chain links' masses and
    inertias (as :func:`.physical.problems`)."""
    out = []
    for c, leg in zip(desc.chains, cc.legs):
        bodies = iter(leg.bodies)
        for js in c.joints:
            if not js.body:
                continue
            _, m, _, I = next(bodies)
            m = np.asarray(m, dtype=float)
            out.append((f"{js.path}.mass", "a mass >= 0 kg", m, ~(m >= 0)))
            with np.errstate(all="ignore"):
                ok = np.all(np.isfinite(I), axis=(-1, -2))
                lam = np.linalg.eigvalsh(np.where(ok[..., None, None], I, 0.0))
                bad = ~ok | (lam[..., 0] < -1e-12 * np.max(np.abs(lam), axis=-1))
            out.append((f"{js.path}.inertia", "a positive semi-definite inertia (kg m^2)", lam[..., 0], bad))
    return out


class ChainChecks:
    """The physical and load-time checks of :class:`.chain_mechanism.ChainMechanism` (a mixin)."""

    def invalid_designs(self) -> np.ndarray:
        """As :meth:`DescribedMechanism.invalid_designs`, the chain links' masses
        and inertias included."""
        bad = np.asarray(super().invalid_designs())
        for _, _, _, b in physical_problems(self.description, self.chain_constants):
            bad = bad | np.asarray(b).reshape(bad.shape)
        return bad

    @classmethod
    def check_physical(cls, parameters, designs):
        problem = super().check_physical(parameters, designs)
        if problem:
            return problem
        fixed = dict(cls.fixed_parameters)
        fixed.update({k: v for k, v in parameters.items() if k in fixed})
        for dname, design in designs.items():
            env = {**cls.design_defaults, **fixed, **{k: v for k, v in design.items() if k in cls.design_parameters}}
            env = {k: v for k, v in env.items() if k in cls.design_parameters or k in cls.fixed_parameters}
            for path, what, v, b in physical_problems(cls.description, chain_constants(cls.description, env)):
                if np.any(b):
                    return path, f"expected {what}, got {float(np.ravel(v)[0]):.6g} ({dname})"
        return None

    # ------------------------------------------------------------------ config checks
    @classmethod
    def check_config(cls, parameters, designs):
        """(key path, message) of the first problem of a chain description with
        the config's designs (:mod:`.chain_checks`), else None."""
        return check_designs(cls, parameters, designs)
