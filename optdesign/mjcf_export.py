"""A MuJoCo model (MJCF) of one design to simulate: the mechanism's own
multibody model (its ``multibody_check`` module's ``mjcf``: closed loops as
``connect`` equality constraints) with position servos on the actuated joints
and a keyframe ``home`` that starts it assembled.

The servos.  Each actuated joint gets a ``position`` actuator (ctrl = the
actuator value in SI: m for a slide, rad for a hinge) with stiffness
``kp = w^2 m_i`` and damping ``kv = 2 zeta w m_i``, ``w = 2 pi f``, where
``m_i`` is the diagonal of the design's actuator-space inertia
``J^-T M_p J^-1`` at the keyframe pose (from the mechanism's dynamic model),
so that each actuator alone would be a critically damped (``zeta = 1``)
oscillator of frequency ``f`` (default 10 Hz).  Under a load the servo sags by
load / kp, as a real position loop of finite stiffness does.

The keyframe ``home`` holds every joint's position (zero velocities) from the
mechanism's kinematics at the given pose and ctrl = the actuator values there:
``mujoco.mj_resetDataKeyframe(model, data, 0)`` starts a simulation with
every loop closed.
"""
from __future__ import annotations

import importlib
import xml.etree.ElementTree as ET

import numpy as np

__all__ = ["export_mjcf", "model_module", "DEFAULT_FREQUENCY", "DEFAULT_DAMPING"]

DEFAULT_FREQUENCY = 10.0    # Hz
DEFAULT_DAMPING = 1.0       # damping ratio of each servo


def model_module(mech):
    """The module building the mechanism's MuJoCo model (``mjcf``, ``state_at``,
    ``actuated_joints``, optionally ``simulation_mjcf``: the model to step where
    it differs from the check's), or None when it has none."""
    name = getattr(mech, "multibody_check", None)
    return importlib.import_module(name) if name else None


def actuator_inertia(mech, X) -> np.ndarray:
    """Diagonal (n_act,) of J^-T M_p J^-1 at the pose X (dof,): kg for a
    prismatic actuator, kg m^2 for a revolute one."""
    X = np.asarray(X, float).reshape(1, -1)
    M = mech.mass_matrix(X)[0]          # J^-T M_p, actuator forces per unit pose acceleration
    J = mech.jacobian(X)[0]             # qdot = J xdot (same convention)
    Mq = M @ np.linalg.inv(J)
    return np.diag(0.5 * (Mq + Mq.T)).copy()


def _f(x: float) -> str:
    return f"{float(x):.17g}"


def export_mjcf(mech, X, *, frequency: float = DEFAULT_FREQUENCY, damping: float = DEFAULT_DAMPING,
                model_name: str | None = None) -> str:
    """The MJCF text (SI units) of one design with servos and the keyframe at pose X (dof,).
    ValueError (one line) when the design has no MuJoCo model or X is out of reach."""
    mod = model_module(mech)
    if mod is None:
        raise ValueError(f"mechanism {getattr(mech, 'name', type(mech).__name__)!r} has no MuJoCo model")
    X = np.asarray(X, float).reshape(-1)
    if not bool(np.all(mech.reachable(X[None]))):
        raise ValueError(f"the keyframe pose {X.tolist()} is not reachable")
    root = ET.fromstring(getattr(mod, "simulation_mjcf", mod.mjcf)(mech))   # the model meant to be stepped
    if model_name:
        root.set("model", model_name)
    for old in root.findall("actuator") + root.findall("keyframe"):
        root.remove(old)
    joints = mod.actuated_joints(mech)
    m = actuator_inertia(mech, X)
    if not np.all(np.isfinite(m) & (m > 0)):
        raise ValueError(f"the actuator-space inertia at the keyframe pose is not positive ({m.tolist()})")
    w = 2.0 * np.pi * float(frequency)
    act = ET.SubElement(root, "actuator")
    for i, j in enumerate(joints):
        ET.SubElement(act, "position", name=f"servo{i + 1}", joint=j, kp=_f(w * w * m[i]),
                      kv=_f(2.0 * damping * w * m[i]), ctrllimited="false")
    qpos, q = mod.state_at(mech, X)
    key = ET.SubElement(root, "keyframe")
    ET.SubElement(key, "key", name="home", qpos=" ".join(_f(v) for v in qpos), ctrl=" ".join(_f(v) for v in q))
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode") + "\n"
