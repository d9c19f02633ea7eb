"""An independent multibody check of described mechanisms with MuJoCo.

The MJCF model (:func:`mjcf`) is built from the physical parts of one design,
not from the equations of optdesign.mechanisms.described.dynamics:

* the platform: a free body (mass, inertia tensor about its centre of mass;
  a platform without rotations gets a small inertia that never enters);
* strut legs (U-P-S): a cylinder on a ball joint at the base point and a
  piston on a slide joint along the cylinder's axis, the actuator on the
  slide; the piston's end is tied to the platform point by a ``connect``
  equality;
* prismatic legs: a slider on a slide joint along the rail (the actuator),
  revolute legs: a crank on a hinge about the motor axis (the actuator;
  inertia about the axis as described, its mass at its centre); in both,
  ``rod.count`` rods on ball joints at the actuated point (a parallelogram:
  two rods ``rod.width`` apart along ``rod.across``), each tied to its
  platform point by a ``connect`` equality;
* slender bodies get a small axial inertia (MuJoCo needs one); the spin it
  carries stays zero (nothing drives it), so it adds no energy.

:func:`inverse_dynamics` sets every joint position, velocity and acceleration
from our kinematics, computes MuJoCo's open-tree generalized forces
``M(q) qacc + bias`` and splits them into loop-closure forces (the
non-actuated rows) and actuator forces, as optdesign.mechanisms.p4s.mujoco
does for the 3-P(4S).  :func:`energies` reads MuJoCo's kinetic and potential
energy at the same states.
"""
from __future__ import annotations

import numpy as np

__all__ = ["mjcf", "simulation_mjcf", "DescribedModel", "inverse_dynamics", "energies", "smooth_trajectory", "actuated_joints",
           "state_at", "mass_matrices"]

AXIAL = 1e-6     # kg m^2: axial inertia of slender bodies (their spin stays zero)


def _vec(v) -> str:
    return " ".join(f"{float(x):.17g}" for x in np.ravel(v))


def _full(I) -> str:
    I = np.asarray(I, dtype=float)
    return _vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])


def _rods(C, i):
    cnt = int(round(float(C.body["rod_count"][i])))
    w = float(C.body["rod_width"][i])
    if cnt < 1:
        return []
    return [(k - (cnt - 1) / 2.0) * w * C.across[i] for k in range(cnt)]


def _chains(mech) -> bool:
    return bool(getattr(mech.description, "is_chain", False))


def mjcf(mech, simulation: bool = False) -> str:
    """The MJCF text of one design of a described mechanism (SI units); a chain
    mechanism's is :func:`.mujoco_chains.mjcf` (``simulation``: its massless
    bodies get a placeholder mass a simulation can step with)."""
    if _chains(mech):
        from .mujoco_chains import mjcf as chain_mjcf

        return chain_mjcf(mech, simulation)
    C = mech.constants
    if C.shape != ():
        raise ValueError("mjcf expects a single design")
    B = C.body
    rotates = mech.pose_spec.type != "translation"
    Ip = np.asarray(C.I_platform, float)
    if not rotates:
        Ip = np.eye(3) * 1e-3
    lines = ['<mujoco model="described">',
             '  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>',
             f'  <option timestep="1e-4" gravity="0 0 {-float(C.g):.17g}" solver="Newton" iterations="200" tolerance="1e-14">',
             '    <flag contact="disable" energy="enable"/>', '  </option>',
             '  <default><geom contype="0" conaffinity="0" group="1"/></default>', '  <worldbody>',
             '    <body name="platform" pos="0 0 0">', '      <freejoint name="platform"/>',
             f'      <inertial pos="{_vec(C.com)}" mass="{float(C.m_platform):.17g}" fullinertia="{_full(Ip)}"/>',
             '      <geom type="sphere" size="0.01"/>']
    for i in range(len(C.kind)):
        offs = _rods(C, i) if C.kind[i] != 2 else [np.zeros(3)]
        for k, off in enumerate(offs):
            lines.append(f'      <site name="plat{i}_{k}" pos="{_vec(C.P[i] + off)}" size="0.005"/>')
    lines.append('    </body>')
    for i, kind in enumerate(C.kind):
        A = C.A[i]
        if kind == 2:
            e1, e2 = float(B["lower_centre"][i]), float(B["upper_centre"][i])
            I1, I2 = float(B["lower_inertia"][i]), float(B["upper_inertia"][i])
            lines += [f'    <body name="cyl{i}" pos="{_vec(A)}">', f'      <joint name="ball{i}" type="ball"/>',
                      f'      <inertial pos="0 0 {e1:.17g}" mass="{max(float(B["lower_mass"][i]), 1e-9):.17g}" diaginertia="{_vec([max(I1, AXIAL), max(I1, AXIAL), AXIAL])}"/>',
                      f'      <body name="pis{i}" pos="0 0 0">', f'        <joint name="act{i}" type="slide" axis="0 0 1"/>',
                      f'        <inertial pos="0 0 {-e2:.17g}" mass="{max(float(B["upper_mass"][i]), 1e-9):.17g}" diaginertia="{_vec([max(I2, AXIAL), max(I2, AXIAL), AXIAL])}"/>',
                      f'        <site name="top{i}_0" pos="0 0 0" size="0.005"/>', '      </body>', '    </body>']
            continue
        if kind == 0:
            lines += [f'    <body name="act{i}" pos="{_vec(A)}">', f'      <joint name="act{i}" type="slide" axis="{_vec(C.U[i])}"/>',
                      f'      <inertial pos="0 0 0" mass="{max(float(B["slider_mass"][i]), 1e-9):.17g}" diaginertia="1e-6 1e-6 1e-6"/>']
            tip = np.zeros(3)
        else:
            La, k_ = float(C.La[i]), C.U[i]
            e = float(B["crank_centre"][i]) * La
            m = float(B["crank_mass"][i])
            Iax = float(B["crank_inertia"][i]) - m * e * e
            if Iax <= 0:
                raise ValueError(f"leg {i}: crank inertia about the axis must exceed m e^2 for the MuJoCo model")
            Icom = Iax * np.outer(k_, k_) + Iax * (np.eye(3) - np.outer(k_, k_))
            lines += [f'    <body name="act{i}" pos="{_vec(A)}">', f'      <joint name="act{i}" type="hinge" axis="{_vec(k_)}"/>',
                      f'      <inertial pos="{_vec(e * C.R0[i])}" mass="{max(m, 1e-9):.17g}" fullinertia="{_full(Icom)}"/>']
            tip = La * C.R0[i]
        l, f = float(C.Lr[i]), float(B["rod_centre"][i])
        Ir, mr = float(B["rod_inertia"][i]), float(B["rod_mass"][i])
        for k, off in enumerate(_rods(C, i)):
            lines += [f'      <body name="rod{i}_{k}" pos="{_vec(tip + off)}">', f'        <joint name="rball{i}_{k}" type="ball"/>',
                      f'        <inertial pos="0 0 {f * l:.17g}" mass="{max(mr, 1e-9):.17g}" diaginertia="{_vec([max(Ir, AXIAL), max(Ir, AXIAL), AXIAL])}"/>',
                      f'        <site name="top{i}_{k}" pos="0 0 {l:.17g}" size="0.005"/>', '      </body>']
        lines.append('    </body>')
    lines.append('  </worldbody>')
    lines.append('  <equality>')
    for i in range(len(C.kind)):
        for k in range(len(_rods(C, i)) if C.kind[i] != 2 else 1):
            lines.append(f'    <connect site1="top{i}_{k}" site2="plat{i}_{k}" solref="2e-4 1" solimp="0.9999 0.9999 0.001 0.5 2"/>')
    lines.append('  </equality>')
    lines.append('</mujoco>')
    return "\n".join(lines) + "\n"


def simulation_mjcf(mech) -> str:
    """The MJCF text of the model to step (:func:`optdesign.mjcf_export.export_mjcf`):
    :func:`mjcf` with a chain mechanism's massless bodies at a placeholder mass."""
    return mjcf(mech, simulation=True)


def actuated_joints(mech) -> list[str]:
    """The names of the actuated joints of :func:`mjcf`'s model (slides and hinges, leg order)."""
    if _chains(mech):
        from .mujoco_chains import actuated_joints as chain_actuated

        return chain_actuated(mech)
    return [f"act{i}" for i in range(len(mech.constants.kind))]


def state_at(mech, X) -> tuple[np.ndarray, np.ndarray]:
    """qpos of :func:`mjcf`'s model at rest at the pose X (dof,) (our
    kinematics: every loop closed) and the actuator values there (n_act,)."""
    mm = DescribedModel(mech)
    z = np.zeros(np.asarray(X, float).size)      # at rest, in the pose's (independent) coordinates
    qpos, _, _ = mm.state(X, z, z)
    return qpos, qpos[mm.act_q].copy()


def _quat_z_to(n):
    q = np.array([1.0 + n[2], -n[1], n[0], 0.0])
    if np.linalg.norm(q) < 1e-12:        # n = -z
        return np.array([0.0, 1.0, 0.0, 0.0])
    return q / np.linalg.norm(q)


def _mat(mj, quat):
    R = np.empty(9)
    mj.mju_quat2Mat(R, quat)
    return R.reshape(3, 3)


def _axis_angle(k, q):
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(q) * K + (1 - np.cos(q)) * K @ K


class DescribedModel:
    """A compiled MuJoCo model of one design plus its joint addresses (a chain
    mechanism gets a :class:`.mujoco_chains.ChainModel`, the same interface)."""

    def __new__(cls, mech):
        if cls is DescribedModel and _chains(mech):
            from .mujoco_chains import ChainModel

            return ChainModel(mech)
        return super().__new__(cls)

    def __init__(self, mech):
        import mujoco

        self.mj, self.mech = mujoco, mech
        self.xml = mjcf(mech)
        m = self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(m)

        def jid(name):
            return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)

        def sid(name):
            return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)

        C = mech.constants
        self.n = len(C.kind)
        j = jid("platform")
        self.plat_q, self.plat_v = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        self.act_q = np.array([m.jnt_qposadr[jid(f"act{i}")] for i in range(self.n)])
        self.act_v = np.array([m.jnt_dofadr[jid(f"act{i}")] for i in range(self.n)])
        self.balls = {}       # (leg, k) -> (qpos adr, dof adr)
        self.pairs = []
        for i in range(self.n):
            ks = range(len(_rods(C, i))) if C.kind[i] != 2 else [0]
            for k in ks:
                name = f"ball{i}" if C.kind[i] == 2 else f"rball{i}_{k}"
                jj = jid(name)
                self.balls[(i, k)] = (int(m.jnt_qposadr[jj]), int(m.jnt_dofadr[jj]))
                self.pairs.append((sid(f"top{i}_{k}"), sid(f"plat{i}_{k}")))
        self.passive = np.setdiff1d(np.arange(m.nv), self.act_v)

    def state(self, X, V, A):
        """qpos, qvel, qacc from our kinematics at one pose (rates V, accelerations A)."""
        mj, mech, C = self.mj, self.mech, self.mech.constants
        X, V, A = (np.asarray(v, float).reshape(1, -1) for v in (X, V, A))
        st = mech.leg_state(X)
        if not bool(st["reachable"][0]):
            raise ValueError(f"pose {X[0].tolist()} is not reachable")
        d = mech._pose_dyn(st, V, "rates")
        xi = d["xi"][0]
        sig = d["sigma"][0] if d["sigma"] is not None else np.zeros(6)
        from .poses import rate_map, twist_columns

        Sm = rate_map(mech.pose_spec, st["frames"])
        if Sm is None:
            xid = np.zeros(6)
            xid[list(twist_columns(mech.pose_spec))] = A[0]
        else:
            xid = Sm[0] @ A[0] + sig
        v, w = xi[:3], xi[3:]
        vd, wd = xid[:3], xid[3:]
        q = st["q"][0]
        qd = mech.jacobian_rates(X)[0] @ V[0]
        qdd = mech.accelerations(X, V, A)[0]
        R = st["frames"].R[0]
        o = st["frames"].origin[0]
        m = self.model
        qpos, qvel, qacc = m.qpos0.copy(), np.zeros(m.nv), np.zeros(m.nv)
        qpos[self.plat_q:self.plat_q + 3] = o
        quat = np.empty(4)
        mj.mju_mat2Quat(quat, R.ravel())
        qpos[self.plat_q + 3:self.plat_q + 7] = quat
        qvel[self.plat_v:self.plat_v + 3] = v
        qvel[self.plat_v + 3:self.plat_v + 6] = R.T @ w
        qacc[self.plat_v:self.plat_v + 3] = vd
        qacc[self.plat_v + 3:self.plat_v + 6] = R.T @ wd
        qpos[self.act_q] = q
        qvel[self.act_v] = qd
        qacc[self.act_v] = qdd
        for i in range(self.n):
            r = st["r"][0, i]
            b = st["b"][0, i]
            bd = v + np.cross(w, r)
            bdd = vd + np.cross(wd, r) + np.cross(w, np.cross(w, r))
            kind = C.kind[i]
            if kind == 2:
                A_ = C.A[i]
                wv = b - A_
                nn = wv / q[i]
                nd = (bd - qd[i] * nn) / q[i]
                ndd = (bdd - qdd[i] * nn - 2 * qd[i] * nd) / q[i]
                par_w, par_a, Rpar = np.zeros(3), np.zeros(3), np.eye(3)
                rods = [(nn, nd, ndd)]
            else:
                if kind == 0:
                    ad, add = C.U[i] * qd[i], C.U[i] * qdd[i]
                    par_w, par_a, Rpar = np.zeros(3), np.zeros(3), np.eye(3)
                else:
                    ch = st["chat"][0, i]
                    t = st["t"][0, i]
                    ad = t * qd[i]
                    add = t * qdd[i] - C.La[i] * ch * qd[i] ** 2
                    par_w, par_a = C.U[i] * qd[i], C.U[i] * qdd[i]
                    Rpar = _axis_angle(C.U[i], q[i])
                dv = st["d"][0, i]
                l = float(C.Lr[i])
                nn, nd, ndd = dv / l, (bd - ad) / l, (bdd - add) / l
                rods = [(nn, nd, ndd)] * len(_rods(C, i))
            for k, (nn, nd, ndd) in enumerate(rods):
                qa, va = self.balls[(i, k)]
                Rrod = _mat(mj, _quat_z_to(nn))
                rel = Rpar.T @ Rrod
                rq = np.empty(4)
                mj.mju_mat2Quat(rq, rel.ravel())
                qpos[qa:qa + 4] = rq
                om = np.cross(nn, nd)
                al = np.cross(nn, ndd)
                qvel[va:va + 3] = Rrod.T @ (om - par_w)
                qacc[va:va + 3] = Rrod.T @ (al - par_a - np.cross(om, om - par_w))
        return qpos, qvel, qacc

    def loop_jacobian(self):
        mj, m, d = self.mj, self.model, self.data
        j1, j2 = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        rows = []
        for s1, s2 in self.pairs:
            mj.mj_jacSite(m, d, j1, None, s1)
            mj.mj_jacSite(m, d, j2, None, s2)
            rows.append(j1 - j2)
        return np.vstack(rows)

    def loop_gap(self):
        d = self.data
        return max(np.linalg.norm(d.site_xpos[a] - d.site_xpos[b]) for a, b in self.pairs)


def inverse_dynamics(mech, X, V, A, model: DescribedModel | None = None) -> dict:
    """MuJoCo's actuator forces (N, n) at poses X with rates V and accelerations A,
    beside ours, with the loop gaps (m), velocity gaps (m/s), the residual of
    the non-actuated rows (N or N m) and MuJoCo's energies T, V (J)."""
    mm = model or DescribedModel(mech)
    mj, m, d = mm.mj, mm.model, mm.data
    X, V, A = (np.atleast_2d(np.asarray(v, float)) for v in (X, V, A))
    N = X.shape[0]
    out = {k: np.empty(N) for k in ("loop_gap", "velocity_gap", "residual", "kinetic", "potential")}
    forces = np.empty((N, mm.n))
    M = np.zeros((m.nv, m.nv))
    for k in range(N):
        qpos, qvel, qacc = mm.state(X[k], V[k], A[k])
        d.qpos[:], d.qvel[:] = qpos, qvel
        d.qfrc_applied[:] = 0.0
        mj.mj_forward(m, d)
        mj.mj_fullM(m, d, M)
        tau = M @ qacc + d.qfrc_bias
        Jc = mm.loop_jacobian()
        out["loop_gap"][k] = mm.loop_gap()
        out["velocity_gap"][k] = np.abs(Jc @ qvel).max()
        out["kinetic"][k], out["potential"][k] = d.energy[1], d.energy[0]
        P, S = mm.passive, mm.act_v
        lam, *_ = np.linalg.lstsq(Jc[:, P].T, tau[P], rcond=None)
        out["residual"][k] = np.abs(Jc[:, P].T @ lam - tau[P]).max()
        forces[k] = tau[S] - Jc[:, S].T @ lam
    out["forces"] = forces
    out["ours"] = mech.actuator_forces(X, V, A)
    return out


def mass_matrices(mech, X, model: DescribedModel | None = None) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's mass matrix reduced to the pose rates, ``Phi^T M(q) Phi`` (N, dof, dof),
    beside ours (``platform_mass_matrix`` in rates), where ``Phi`` (nv, dof) maps
    the pose rates to every joint's velocity (columns: our kinematic state at
    a unit rate of one coordinate; the map is linear in the rates)."""
    mm = model or DescribedModel(mech)
    mj, m, d = mm.mj, mm.model, mm.data
    X = np.atleast_2d(np.asarray(X, float))
    dof = X.shape[1]
    out = np.empty((len(X), dof, dof))
    M = np.zeros((m.nv, m.nv))
    z = np.zeros(dof)
    for k in range(len(X)):
        Phi = np.stack([mm.state(X[k], np.eye(dof)[j], z)[1] for j in range(dof)], axis=1)
        d.qpos[:] = mm.state(X[k], z, z)[0]
        mj.mj_forward(m, d)
        mj.mj_fullM(m, d, M)
        out[k] = Phi.T @ M @ Phi
    return out, mech.platform_mass_matrix(X, "rates")


def energies(mech, X, V, model: DescribedModel | None = None) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's kinetic and potential energy (N,) at our kinematic states."""
    res = inverse_dynamics(mech, X, V, np.zeros_like(np.atleast_2d(X)), model)
    return res["kinetic"], res["potential"]


def smooth_trajectory(mech, t, amplitude_length=0.02, amplitude_angle=0.08, seed=0):
    """X, V, A (N, dof): sums of two sines per coordinate around the home pose."""
    rng = np.random.default_rng(seed)
    spec = mech.pose_spec
    ind = spec.independent_index                 # every coordinate, but a chain mechanism's parasitic ones
    dof = len(ind)
    amp = np.array([amplitude_length if spec.roles[i] in ("x", "y", "z") else amplitude_angle for i in ind])
    f = rng.uniform(0.5, 2.5, (2, dof))
    ph = rng.uniform(0, 2 * np.pi, (2, dof))
    t = np.asarray(t, float)[:, None]
    X, V, A = np.asarray(spec.home, float)[list(ind)] + 0 * t, 0 * t, 0 * t
    for j in range(2):
        w = 2 * np.pi * f[j]
        X = X + 0.5 * amp * np.sin(w * t + ph[j])
        V = V + 0.5 * amp * w * np.cos(w * t + ph[j])
        A = A - 0.5 * amp * w * w * np.sin(w * t + ph[j])
    return X, V, A
