"""The MuJoCo model of a chain mechanism (the independent check of
:mod:`.chain_dynamics`), built from the joints, not from our equations.

* Every chain leg is a kinematic tree from the world: one body per joint
  variable, each body's frame at the world frame at the reference
  configuration (so a body's local coordinates are the description's
  reference coordinates): R -> a hinge about ``axis`` through ``at``, P -> a
  slide, U, S, C -> two or three hinges/slides, Pa -> a side body on a hinge
  at ``at`` and the distal body on a hinge at ``at + side`` tied by a joint
  equality (angle of the second = minus the first);
* a link's mass, centre and inertia go to the body after its joint's last
  variable; bodies without one get 1e-12 kg and 1e-12 kg m^2 (MuJoCo needs
  positive values; their share of the forces is below 1e-11 N);
* the platform: a free body (spatial pose), on a ball joint at the centre
  (rotation), on three slides (translation) or two slides and a hinge
  (planar);
* a chain ending in S is tied to the platform point by a ``connect``
  equality, any other chain by a ``weld`` of a site at the end point
  (orientation of the reference configuration) and a site at the platform
  point (platform frame).

:class:`ChainModel` has the interface of :class:`.mujoco.DescribedModel`
(``state``, ``loop_jacobian``, ``loop_gap``, ``passive``, ``act_v``), so
:func:`.mujoco.inverse_dynamics`, :func:`.mujoco.mass_matrices` and
``optdesign validate-dynamics`` run on it.  Shorthand legs in a chain
description are not modelled yet (a ValueError says so).
"""
from __future__ import annotations

import numpy as np

from .chain_constants import PARA, SLIDE

__all__ = ["mjcf", "ChainModel"]

MIN = 1e-12
#: the placeholder mass (kg) and inertia (kg m^2) of massless bodies in a model meant to be
#: simulated (optdesign export): 1e-12 leaves the constraint solver ill-conditioned (a 3-UPU
#: under its servos drifted, loop residual 1e-2), 1e-6 / 1e-8 settle to 1e-7
SIM_MASS, SIM_INERTIA = 1e-6, 1e-8


def _v(x) -> str:
    return " ".join(f"{float(a):.17g}" for a in np.ravel(x))


def _full(I) -> str:
    I = np.asarray(I, dtype=float) + MIN * np.eye(3)
    return _v([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])


def _platform_joints(spec, C) -> list[str]:
    if spec.type == "spatial":
        return ['<freejoint name="platform"/>']
    if spec.type == "rotation":
        return ['<joint name="platform" type="ball"/>']
    if spec.type == "translation":
        return [f'<joint name="platform_{a}" type="slide" axis="{_v(e)}"/>' for a, e in zip("xyz", np.eye(3))]
    return ['<joint name="platform_x" type="slide" axis="1 0 0"/>', '<joint name="platform_y" type="slide" axis="0 1 0"/>',
            '<joint name="platform_yaw" type="hinge" axis="0 0 1"/>']


def mjcf(mech, simulation: bool = False) -> str:
    """The MJCF text of one design of a chain mechanism (SI units). Bodies
    without a mass get MIN for the dynamics check, SIM_MASS / SIM_INERTIA
    with ``simulation`` (a model to step, :func:`optdesign.mjcf_export.export_mjcf`)."""
    pm, pi = (SIM_MASS, SIM_INERTIA) if simulation else (MIN, MIN)
    cc = mech.chain_constants
    C = cc.base
    if C.shape != ():
        raise ValueError("mjcf expects a single design")
    if mech.description.legs:
        raise ValueError("the MuJoCo model of a chain description does not model its shorthand legs yet; write them "
                         "as chain legs")
    spec = mech.pose_spec
    Ip = np.asarray(C.I_platform, dtype=float)
    pos = _v(C.centre) if spec.type == "rotation" else "0 0 0"
    L = ['<mujoco model="chains">', '  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>',
         f'  <option timestep="1e-4" gravity="0 0 {-float(C.g):.17g}" solver="Newton" iterations="200" tolerance="1e-14">',
         '    <flag contact="disable" energy="enable"/>', '  </option>',
         '  <default><geom contype="0" conaffinity="0" group="1"/></default>', '  <worldbody>',
         f'    <body name="platform" pos="{pos}">', *[f"      {j}" for j in _platform_joints(spec, C)],
         f'      <inertial pos="{_v(C.com)}" mass="{max(float(C.m_platform), MIN):.17g}" fullinertia="{_full(Ip)}"/>']
    for i, leg in enumerate(cc.legs):
        L.append(f'      <site name="plat{i}" pos="{_v(leg.P)}" size="0.005"/>')
    L.append('    </body>')
    eqs = []
    for i, leg in enumerate(cc.legs):
        masses = {v: (m, c, I) for v, m, c, I in leg.bodies}
        depth = 0
        for j, code in enumerate(leg.codes):
            a, c = leg.axis[j], leg.point[j]
            # qpos reads the joint's value (MuJoCo's ref: the value at the reference configuration), so
            # that a servo's target is the actuator value of our inverse kinematics
            ref = f' ref="{float(leg.offset[j]):.17g}"' if float(leg.offset[j]) != 0.0 else ""
            ind = "    " + "  " * depth
            if code == PARA:
                L += [f'{ind}<body name="c{i}_{j}s">', f'{ind}  <joint name="c{i}_{j}" type="hinge" axis="{_v(a)}" pos="{_v(c)}"{ref}/>',
                      f'{ind}  <inertial pos="{_v(c)}" mass="{pm}" diaginertia="{pi} {pi} {pi}"/>']
                depth += 1
                ind = "    " + "  " * depth
                L += [f'{ind}<body name="c{i}_{j}">',
                      f'{ind}  <joint name="c{i}_{j}b" type="hinge" axis="{_v(a)}" pos="{_v(c + leg.side[j])}"/>']
                eqs.append(f'    <joint joint1="c{i}_{j}b" joint2="c{i}_{j}" polycoef="0 -1 0 0 0"/>')
            else:
                kind = "slide" if code == SLIDE else "hinge"
                L += [f'{ind}<body name="c{i}_{j}">', f'{ind}  <joint name="c{i}_{j}" type="{kind}" axis="{_v(a)}" pos="{_v(c)}"{ref}/>']
            m = masses.get(j)
            if m is not None and float(m[0]) > 0:
                L.append(f'{ind}  <inertial pos="{_v(m[1])}" mass="{float(m[0]):.17g}" fullinertia="{_full(m[2])}"/>')
            else:
                L.append(f'{ind}  <inertial pos="{_v(c)}" mass="{pm}" diaginertia="{pi} {pi} {pi}"/>')
            depth += 1
        ind = "    " + "  " * depth
        L.append(f'{ind}<site name="end{i}" pos="{_v(leg.end)}" size="0.005"/>')
        for d in range(depth, 0, -1):
            L.append("    " + "  " * (d - 1) + "</body>")
        kind = "connect" if leg.closure == "position" else "weld"
        eqs.insert(0, f'    <{kind} site1="end{i}" site2="plat{i}" solref="2e-4 1" solimp="0.9999 0.9999 0.001 0.5 2"/>')
    L += ['  </worldbody>', '  <equality>', *eqs, '  </equality>', '</mujoco>']
    return "\n".join(L) + "\n"


def actuated_joints(mech) -> list[str]:
    """The names of the actuated joints of :func:`mjcf`'s model (hinges or slides, actuator order)."""
    legs = mech.chain_constants.legs
    return [f"c{i}_{legs[i].act}" for _, _, i in mech.description.actuators]


class ChainModel:
    """A compiled MuJoCo model of one design of a chain mechanism and its joint addresses."""

    def __init__(self, mech):
        import mujoco

        self.mj, self.mech = mujoco, mech
        self.xml = mjcf(mech)
        m = self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(m)
        jid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)  # noqa: E731
        sid = lambda n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, n)  # noqa: E731
        cc = mech.chain_constants
        self.legs = cc.legs
        self.joints = [[(int(m.jnt_qposadr[jid(f"c{i}_{j}")]), int(m.jnt_dofadr[jid(f"c{i}_{j}")]),
                         (int(m.jnt_qposadr[jid(f"c{i}_{j}b")]), int(m.jnt_dofadr[jid(f"c{i}_{j}b")]))
                         if code == PARA else None) for j, code in enumerate(leg.codes)] for i, leg in enumerate(cc.legs)]
        spec = mech.pose_spec
        names = {"spatial": ["platform"], "rotation": ["platform"], "translation": ["platform_x", "platform_y", "platform_z"],
                 "planar": ["platform_x", "platform_y", "platform_yaw"]}[spec.type]
        self.plat = [(int(m.jnt_qposadr[jid(n)]), int(m.jnt_dofadr[jid(n)])) for n in names]
        self.n = len(mech.actuator_names)
        acts = []
        for _, src, i in mech.description.actuators:
            acts.append(self.joints[i][cc.legs[i].act][1])
        self.act_v = np.array(acts, dtype=int)
        self.act_q = np.array([self.joints[i][cc.legs[i].act][0] for _, _, i in mech.description.actuators], dtype=int)
        self.pairs = [(sid(f"end{i}"), sid(f"plat{i}"), leg.closure) for i, leg in enumerate(cc.legs)]
        self.passive = np.setdiff1d(np.arange(m.nv), self.act_v)

    def state(self, X, V, A):
        """qpos, qvel, qacc from our kinematics at one pose (independent coordinates, rates, accelerations)."""
        from .chain_dynamics import chain_dynamics
        from .chain_solve import full_rate_map
        from .poses import rate_bias

        mj, mech = self.mj, self.mech
        spec = mech.pose_spec
        X, V, A = (np.asarray(v, float).reshape(1, -1) for v in (X, V, A))
        core = mech.state(X).core
        if not bool(core["reachable"][0]):
            raise ValueError(f"pose {X[0].tolist()} is not reachable")
        dyn = chain_dynamics(mech, core, V)
        ub = dyn["ub"][0]
        U = core["U"][0]
        ud, udd = U @ V[0], U @ A[0] + ub
        fr = core["st"]["frames"]
        S = full_rate_map(spec, fr)[0]
        P = core["P"][0]
        xd = P @ V[0]
        xdd = P @ A[0] + dyn["xf_bias"][0]
        xi = S @ xd
        xid = S @ xdd + rate_bias(spec, fr, xd[None])[0]
        m = self.model
        qpos, qvel, qacc = m.qpos0.copy(), np.zeros(m.nv), np.zeros(m.nv)
        R, o = fr.R[0], fr.origin[0]
        Xf = core["Xf"][0]
        if spec.type in ("spatial", "rotation"):
            qa, va = self.plat[0]
            quat = np.empty(4)
            mj.mju_mat2Quat(quat, R.ravel())
            off = 0
            if spec.type == "spatial":
                qpos[qa:qa + 3], qvel[va:va + 3], qacc[va:va + 3] = o, xi[:3], xid[:3]
                off = 3
            qpos[qa + off:qa + off + 4] = quat
            qvel[va + off:va + off + 3] = R.T @ xi[3:]
            qacc[va + off:va + off + 3] = R.T @ xid[3:]
        else:
            roles = ("x", "y", "z") if spec.type == "translation" else ("x", "y", "yaw")
            for (qa, va), r in zip(self.plat, roles):
                k = spec.roles.index(r)
                qpos[qa], qvel[va], qacc[va] = Xf[k], xd[k], xdd[k]
        off = 0
        for i, (leg, adr) in enumerate(zip(self.legs, self.joints)):
            for j, (qa, va, second) in enumerate(adr):
                th = core["theta"][i][0, j]
                qpos[qa], qvel[va], qacc[va] = th + float(leg.offset[j]), ud[off + j], udd[off + j]
                if second is not None:       # no ref: the joint equality ties the deviations from qpos0
                    qpos[second[0]], qvel[second[1]], qacc[second[1]] = -th, -ud[off + j], -udd[off + j]
            off += leg.k
        return qpos, qvel, qacc

    def loop_jacobian(self):
        mj, m, d = self.mj, self.model, self.data
        rows = []
        for s1, s2, closure in self.pairs:
            jp1, jr1, jp2, jr2 = (np.zeros((3, m.nv)) for _ in range(4))
            mj.mj_jacSite(m, d, jp1, jr1, s1)
            mj.mj_jacSite(m, d, jp2, jr2, s2)
            rows.append(jp1 - jp2)
            if closure == "frame":
                rows.append(jr1 - jr2)
        for e in range(m.neq):
            if m.eq_type[e] == mj.mjtEq.mjEQ_JOINT:
                row = np.zeros(m.nv)
                row[m.jnt_dofadr[m.eq_obj1id[e]]] = 1.0
                row[m.jnt_dofadr[m.eq_obj2id[e]]] = 1.0
                rows.append(row[None])
        return np.vstack(rows)

    def loop_gap(self):
        d = self.data
        gap = [np.linalg.norm(d.site_xpos[a] - d.site_xpos[b]) for a, b, _ in self.pairs]
        for a, b, closure in self.pairs:
            if closure == "frame":
                gap.append(np.linalg.norm(d.site_xmat[a] - d.site_xmat[b]))
        return max(gap) if gap else 0.0
