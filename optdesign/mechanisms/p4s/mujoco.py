"""An independent multibody check of the 3-P(4S) dynamics with MuJoCo.

The model (:func:`mjcf`) is built from the physical parts, not from our
equations:

* the platform is a free body (mass ``m_platform``; it has no rotational
  inertia in the paper, we give it that of a thin disc of radius ``r_a``,
  which never enters because the platform does not rotate);
* each slider is a body on a slide joint along the rail ``m_i`` starting at
  ``u_i = r_b e_i`` (mass ``m_slider``);
* each parallelogram is two rod bodies (mass ``m_rod``, inertia
  ``diag(Ixx, Ixx, Izz)`` about the rod centre, local z along the rod), each on
  a ball joint at the slider at ``c_i +- (d/2) t_i``; the rod's top end is tied
  to the platform point ``d_i +- (d/2) t_i`` by a site-based ``connect``
  equality constraint, which closes both loops of the parallelogram.

Rod spin.  A rod between two spherical joints can spin about its own axis
without moving anything else.  We keep that idle degree of freedom (ball joint
at the bottom, point constraint at the top) because it is the real joint
arrangement: nothing can apply a torque about the rod axis (both joint centres
lie on it, gravity acts at the centre on it) and the rod is axisymmetric
(Ixx = Iyy), so by Euler's equation the spin rate stays exactly what it was,
zero.  In the inverse comparison the six spin rows of the equations of motion
are then an extra check (their residual is reported); in the simulation the
spin stays at round-off level (reported).  A universal joint at the slider
would remove the spin but forces a spin rate ``theta1_dot (a . n)`` whenever a
rod leaves the plane of its hinge, which adds ``Izz`` energy our model does not
have; a damper or armature on the ball joint would also act on the transverse
rotations.  Neither is used.

Two comparisons:

* :func:`inverse_dynamics` -- every joint position, velocity and acceleration
  is set from our kinematics at a pose (X, V, A); MuJoCo's open-tree
  generalized forces ``tau = M(q) qacc + bias(q, qvel)`` (gravity included)
  are split into actuator forces and loop-closure forces ``J_c^T lambda``:
  the non-actuated rows give lambda (least squares, the residual is reported),
  the slider rows then give the actuator forces.
* :func:`simulate` -- our actuator forces drive MuJoCo's time stepping
  (RK4, stiff constraints) from a state on the commanded trajectory; the
  platform's deviation from the commanded path is the tracking error.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from .model import P4S, E, T
from .trajectories import Trajectory, large_trajectory, paper_trajectory  # noqa: F401

__all__ = [
    "mjcf", "P4SModel", "Trajectory", "paper_trajectory", "large_trajectory",
    "inverse_dynamics", "simulate", "actuated_joints", "state_at",
]

#: constraint settings for the simulation: (time constant, damping ratio) and
#: impedance (d0, dwidth, width); see MuJoCo's solref/solimp
SIM_SOLREF = (2e-4, 1.0)
SIM_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
SIM_TIMESTEP = 1e-4


def _vec(v) -> str:
    return " ".join(f"{float(x):.17g}" for x in v)


def _scalar_params(mech: P4S) -> dict[str, float]:
    out = {}
    for k, v in mech.params.items():
        a = np.asarray(v, dtype=float)
        if a.size != 1:
            raise ValueError(f"one design expected, parameter {k} has shape {a.shape}")
        out[k] = float(a.reshape(()))
    return out


def mjcf(mech: P4S, *, timestep: float = SIM_TIMESTEP, integrator: str = "RK4",
         solref=SIM_SOLREF, solimp=SIM_SOLIMP) -> str:
    """The MJCF text of one 3-P(4S) design (SI units)."""
    p = _scalar_params(mech)
    if abs(p["rods_per_branch"] - 2.0) > 0:
        raise ValueError("the MuJoCo model has two rods per branch (rods_per_branch = 2)")
    r_a, r_b, L, d, phi = p["r_a"], p["r_b"], p["L"], p["d"], p["phi"]
    rho = float(np.sqrt(r_a ** 2 - d ** 2 / 4))
    mp, ms, mr = p["m_platform"], p["m_slider"], p["m_rod"]
    Ixx, Izz = p["rod_Ixx"], p["rod_Izz"]
    # the platform's rotational inertia is not given; a thin disc (never enters: no rotation)
    Ip = (mp * r_a ** 2 / 4, mp * r_a ** 2 / 4, mp * r_a ** 2 / 2)
    sref = _vec(solref)
    simp = _vec(solimp)
    lines = [
        '<mujoco model="p4s">',
        '  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>',
        f'  <option timestep="{timestep:.17g}" integrator="{integrator}" gravity="0 0 {-p["g"]:.17g}"'
        ' solver="Newton" iterations="200" tolerance="1e-14" cone="pyramidal">',
        '    <flag contact="disable"/>',
        '  </option>',
        '  <default><geom contype="0" conaffinity="0" group="1"/></default>',
        '  <worldbody>',
        '    <body name="platform" pos="0 0 0">',
        '      <freejoint name="platform"/>',
        f'      <inertial pos="0 0 0" mass="{mp:.17g}" diaginertia="{_vec(Ip)}"/>',
        f'      <geom type="cylinder" size="{r_a:.17g} 0.005" rgba="0.6 0.6 0.8 1"/>',
    ]
    for i in range(3):
        for s, tag in ((1.0, "a"), (-1.0, "b")):
            lines.append(f'      <site name="plat{i}{tag}" pos="{_vec(rho * E[i] + s * 0.5 * d * T[i])}" size="0.005"/>')
    lines.append('    </body>')
    for i in range(3):
        m = -np.cos(phi) * E[i] + np.sin(phi) * np.array([0.0, 0.0, 1.0])
        lines += [
            f'    <body name="slider{i}" pos="{_vec(r_b * E[i])}">',
            f'      <joint name="slide{i}" type="slide" axis="{_vec(m)}"/>',
            f'      <inertial pos="0 0 0" mass="{ms:.17g}" diaginertia="1e-3 1e-3 1e-3"/>',
            '      <geom type="box" size="0.03 0.03 0.02" rgba="0.8 0.5 0.3 1"/>',
        ]
        for s, tag in ((1.0, "a"), (-1.0, "b")):
            lines += [
                f'      <body name="rod{i}{tag}" pos="{_vec(s * 0.5 * d * T[i])}">',
                f'        <joint name="ball{i}{tag}" type="ball"/>',
                f'        <inertial pos="0 0 {L / 2:.17g}" mass="{mr:.17g}" diaginertia="{_vec((Ixx, Ixx, Izz))}"/>',
                f'        <geom type="capsule" fromto="0 0 0 0 0 {L:.17g}" size="0.008" rgba="0.3 0.7 0.3 1"/>',
                f'        <site name="top{i}{tag}" pos="0 0 {L:.17g}" size="0.005"/>',
                '      </body>',
            ]
        lines.append('    </body>')
    lines.append('  </worldbody>')
    lines.append('  <equality>')
    for i in range(3):
        for tag in "ab":
            lines.append(f'    <connect name="loop{i}{tag}" site1="top{i}{tag}" site2="plat{i}{tag}" solref="{sref}" solimp="{simp}"/>')
    lines.append('  </equality>')
    lines.append('  <actuator>')
    for i in range(3):
        lines.append(f'    <motor name="l{i + 1}" joint="slide{i}" gear="1"/>')
    lines.append('  </actuator>')
    lines.append('</mujoco>')
    return "\n".join(lines) + "\n"


def actuated_joints(mech: P4S) -> list[str]:
    """The names of the actuated joints of :func:`mjcf`'s model (the sliders)."""
    return [f"slide{i}" for i in range(3)]


def state_at(mech: P4S, X) -> tuple[np.ndarray, np.ndarray]:
    """qpos of :func:`mjcf`'s model at rest at the platform position X (3,)
    (our kinematics: every loop closed) and the actuator values there (3,)."""
    mm = P4SModel(mech)
    qpos, _ = mm.kinematic_state(X, np.zeros(3))
    return qpos, qpos[mm.slide_q].copy()


def _quat_z_to(n: np.ndarray) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of the shortest rotation taking z to n."""
    q = np.array([1.0 + n[2], -n[1], n[0], 0.0])   # (1 + z.n, z x n)
    return q / np.linalg.norm(q)


class P4SModel:
    """A compiled MuJoCo model of one design plus the addresses of its joints."""

    def __init__(self, mech: P4S, **mjcf_kw):
        import mujoco

        self.mj = mujoco
        self.mech = mech
        self.xml = mjcf(mech, **mjcf_kw)
        self.model = mujoco.MjModel.from_xml_string(self.xml)
        self.data = mujoco.MjData(self.model)
        m = self.model

        def jid(name):
            return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)

        def sid(name):
            return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)

        def bid(name):
            return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)

        j = jid("platform")
        self.plat_q = int(m.jnt_qposadr[j])
        self.plat_v = int(m.jnt_dofadr[j])
        self.slide_q = np.array([m.jnt_qposadr[jid(f"slide{i}")] for i in range(3)])
        self.slide_v = np.array([m.jnt_dofadr[jid(f"slide{i}")] for i in range(3)])
        self.ball_q = np.array([[m.jnt_qposadr[jid(f"ball{i}{t}")] for t in "ab"] for i in range(3)])
        self.ball_v = np.array([[m.jnt_dofadr[jid(f"ball{i}{t}")] for t in "ab"] for i in range(3)])
        self.rod_body = np.array([[bid(f"rod{i}{t}") for t in "ab"] for i in range(3)])
        self.site_pairs = [(sid(f"top{i}{t}"), sid(f"plat{i}{t}")) for i in range(3) for t in "ab"]
        self.nv = m.nv
        self.actuated = self.slide_v
        self.passive = np.setdiff1d(np.arange(m.nv), self.slide_v)

    # ------------------------------------------------------------------ state

    def _set_ball_rates(self, out, w, R):
        """Write the rods' world angular rates w (3 branches, 3) into the ball
        joints' slots of ``out`` (MuJoCo wants them in the rod's local frame)."""
        for i in range(3):
            for k in range(2):
                a = self.ball_v[i, k]
                out[a:a + 3] = R[i].T @ w[i]
    def kinematic_state(self, X, V, A=None):
        """qpos, qvel (and qacc if A is given) from our kinematics at one pose.

        Rods: orientation z -> n_i with zero spin, angular velocity n x ndot,
        angular acceleration n x nddot (both perpendicular to n), expressed in
        the rod frame as MuJoCo's ball-joint velocities are.
        """
        mj, m = self.mj, self.model
        mech = self.mech
        X = np.asarray(X, float).reshape(1, 3)
        V = np.asarray(V, float).reshape(1, 3)
        st = mech.branch_state(X)
        if not bool(st["reachable"][0]):
            raise ValueError(f"pose {X[0].tolist()} is not reachable")
        q = st["q"][0]
        n = st["n"][0]
        mrail = st["m"][0]
        L = float(np.asarray(mech.L))
        J = mech.jacobian(X)[0]
        qd = J @ V[0]
        ndot = (V[0][None, :] - qd[:, None] * mrail) / L
        qpos = m.qpos0.copy()
        qpos[self.plat_q:self.plat_q + 3] = X[0]
        qpos[self.plat_q + 3:self.plat_q + 7] = (1.0, 0.0, 0.0, 0.0)
        qpos[self.slide_q] = q
        for i in range(3):
            for k in range(2):
                a = self.ball_q[i, k]
                qpos[a:a + 4] = _quat_z_to(n[i])
        R = np.empty((3, 3, 3))
        for i in range(3):
            Rm = np.empty(9)
            mj.mju_quat2Mat(Rm, qpos[self.ball_q[i, 0]:self.ball_q[i, 0] + 4])
            R[i] = Rm.reshape(3, 3)
        qvel = np.zeros(m.nv)
        qvel[self.plat_v:self.plat_v + 3] = V[0]
        qvel[self.slide_v] = qd
        self._set_ball_rates(qvel, np.cross(n, ndot), R)
        if A is None:
            return qpos, qvel
        A = np.asarray(A, float).reshape(1, 3)
        qdd = mech.accelerations(X, V, A)[0]
        nddot = (A[0][None, :] - qdd[:, None] * mrail) / L
        qacc = np.zeros(m.nv)
        qacc[self.plat_v:self.plat_v + 3] = A[0]
        qacc[self.slide_v] = qdd
        self._set_ball_rates(qacc, np.cross(n, nddot), R)
        return qpos, qvel, qacc

    def loop_jacobian(self) -> np.ndarray:
        """J_c (18, nv): the six connect constraints, top-of-rod site minus
        platform site (MuJoCo's site Jacobians at the current state)."""
        mj, m, d = self.mj, self.model, self.data
        rows = []
        jp1 = np.zeros((3, m.nv))
        jp2 = np.zeros((3, m.nv))
        for s1, s2 in self.site_pairs:
            mj.mj_jacSite(m, d, jp1, None, s1)
            mj.mj_jacSite(m, d, jp2, None, s2)
            rows.append(jp1 - jp2)
        return np.vstack(rows)

    def loop_gap(self) -> np.ndarray:
        """Distances (6,) between each rod top and its platform point."""
        d = self.data
        return np.array([np.linalg.norm(d.site_xpos[a] - d.site_xpos[b]) for a, b in self.site_pairs])

    def site_acceleration_gap(self) -> np.ndarray:
        """Linear acceleration mismatch (6,) of rod top and platform point for
        the current qpos, qvel, qacc (MuJoCo's own acceleration propagation)."""
        mj, m, d = self.mj, self.model, self.data
        mj.mj_rnePostConstraint(m, d)
        out = []
        a1 = np.zeros(6)
        a2 = np.zeros(6)
        for s1, s2 in self.site_pairs:
            mj.mj_objectAcceleration(m, d, mj.mjtObj.mjOBJ_SITE, s1, a1, 0)
            mj.mj_objectAcceleration(m, d, mj.mjtObj.mjOBJ_SITE, s2, a2, 0)
            out.append(np.linalg.norm(a1[3:] - a2[3:]))
        return np.array(out)


# ---------------------------------------------------------------------- comparisons
def inverse_dynamics(mech: P4S, X, V, A, model: P4SModel | None = None) -> dict[str, np.ndarray]:
    """MuJoCo's actuator forces for poses X, V, A (N, 3), with diagnostics.

    Returns ``forces`` (N, 3), ``ours`` (N, 3) (``mech.actuator_forces``),
    ``loop_gap`` (N,) max distance of the closed loops at our kinematic state
    (m), ``velocity_gap`` (N,) max |J_c qvel| (m/s), ``acceleration_gap`` (N,)
    max loop acceleration mismatch (m/s^2), ``residual`` (N,) the largest
    unbalanced generalized force of the non-actuated rows after the
    least-squares lambda (N or N m), ``inverse_check`` (N,) the largest
    difference of M qacc + bias from ``mj_inverse`` with constraints disabled,
    ``constraint_rank`` (N,).
    """
    mm = model if model is not None else P4SModel(mech)
    mj, m, d = mm.mj, mm.model, mm.data
    X = np.atleast_2d(np.asarray(X, float))
    V = np.atleast_2d(np.asarray(V, float))
    A = np.atleast_2d(np.asarray(A, float))
    N = X.shape[0]
    out = {k: np.empty(N) for k in ("loop_gap", "velocity_gap", "acceleration_gap", "residual",
                                     "inverse_check")}
    out["constraint_rank"] = np.empty(N, dtype=int)
    forces = np.empty((N, 3))
    M = np.zeros((m.nv, m.nv))
    disable = int(mj.mjtDisableBit.mjDSBL_CONSTRAINT)
    for k in range(N):
        qpos, qvel, qacc = mm.kinematic_state(X[k], V[k], A[k])
        m.opt.disableflags &= ~disable
        d.qpos[:] = qpos
        d.qvel[:] = qvel
        d.ctrl[:] = 0.0
        d.qfrc_applied[:] = 0.0
        mj.mj_forward(m, d)                         # positions, velocities, bias forces
        mj.mj_fullM(m, d, M)
        tau = M @ qacc + d.qfrc_bias                # open-tree generalized forces
        Jc = mm.loop_jacobian()
        out["loop_gap"][k] = mm.loop_gap().max()
        out["velocity_gap"][k] = np.abs(Jc @ qvel).max()
        d.qacc[:] = qacc
        out["acceleration_gap"][k] = mm.site_acceleration_gap().max()
        # the same open-tree forces from MuJoCo's inverse dynamics (constraints off)
        m.opt.disableflags |= disable
        d.qacc[:] = qacc
        mj.mj_inverse(m, d)
        out["inverse_check"][k] = np.abs(d.qfrc_inverse - tau).max()
        m.opt.disableflags &= ~disable
        # tau = B u + Jc^T lambda: non-actuated rows give lambda, slider rows give u
        P, S = mm.passive, mm.actuated
        lam, _, rank, _ = np.linalg.lstsq(Jc[:, P].T, tau[P], rcond=None)
        out["residual"][k] = np.abs(Jc[:, P].T @ lam - tau[P]).max()
        out["constraint_rank"][k] = rank
        forces[k] = tau[S] - Jc[:, S].T @ lam
    out["forces"] = forces
    out["ours"] = mech.actuator_forces(X, V, A)
    return out


def simulate(mech: P4S, traj: Callable, t_end: float, *, timestep: float = SIM_TIMESTEP,
             integrator: str = "RK4", solref=SIM_SOLREF, solimp=SIM_SOLIMP,
             record_every: int = 10, force_model: P4S | None = None) -> dict[str, np.ndarray]:
    """Drive MuJoCo's simulation with our actuator forces along ``traj``.

    The state starts on the trajectory (our kinematics at t = 0).  In each
    step the actuator forces are held at their value at the middle of the
    step.  Returns times ``t``, commanded ``X_ref`` and simulated ``X_sim``
    platform positions, the tracking ``error`` (|X_sim - X_ref|, m), the
    forces applied, the largest loop gap (m), platform rotation (rad) and rod
    spin rate (rad/s) seen.  ``force_model`` computes the forces instead of
    ``mech`` (to show what a wrong dynamic model does to the tracking).
    """
    mm = P4SModel(mech, timestep=timestep, integrator=integrator, solref=solref, solimp=solimp)
    mj, m, d = mm.mj, mm.model, mm.data
    X0, V0, _ = traj(0.0)
    qpos, qvel = mm.kinematic_state(X0[0], V0[0])
    d.qpos[:] = qpos
    d.qvel[:] = qvel
    d.time = 0.0
    mj.mj_forward(m, d)
    n_steps = int(round(t_end / timestep))
    tm = (np.arange(n_steps) + 0.5) * timestep
    Xm, Vm, Am = traj(tm)
    F = (force_model if force_model is not None else mech).actuator_forces(Xm, Vm, Am)
    if not np.all(np.isfinite(F)):
        raise ValueError("the trajectory leaves the reachable workspace or meets a singularity")
    rec_t, rec_x, rec_f = [0.0], [d.qpos[mm.plat_q:mm.plat_q + 3].copy()], [F[0].copy()]
    gap = mm.loop_gap().max()
    rot = 0.0
    spin = 0.0
    for s in range(n_steps):
        d.ctrl[:] = F[s]
        mj.mj_step(m, d)
        if (s + 1) % record_every == 0 or s == n_steps - 1:
            rec_t.append(d.time)
            rec_x.append(d.qpos[mm.plat_q:mm.plat_q + 3].copy())
            rec_f.append(F[s].copy())
            gap = max(gap, mm.loop_gap().max())
            qw = d.qpos[mm.plat_q + 3:mm.plat_q + 7]
            rot = max(rot, 2 * np.arcsin(min(1.0, np.linalg.norm(qw[1:]))))
            for i in range(3):
                for k in range(2):
                    b = mm.rod_body[i, k]
                    axis = d.xmat[b].reshape(3, 3)[:, 2]
                    a = mm.ball_v[i, k]
                    w_world = d.xmat[b].reshape(3, 3) @ d.qvel[a:a + 3]
                    spin = max(spin, abs(w_world @ axis))
    t = np.array(rec_t)
    X_sim = np.array(rec_x)
    X_ref = traj(t)[0]
    err = np.linalg.norm(X_sim - X_ref, axis=-1)
    return {"t": t, "X_sim": X_sim, "X_ref": X_ref, "error": err, "forces": np.array(rec_f),
            "max_loop_gap": gap, "max_platform_rotation": rot, "max_rod_spin": spin}
