"""Synthetic mechanism descriptions for the tests: every leg kind on every
pose type, with rod lengths chosen so that each leg closes at the home pose."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

ROLE_NAMES = {"translation": ["x", "y", "z"], "planar": ["x", "y", "yaw"], "rotation": ["roll", "pitch", "yaw"],
              "spatial": ["x", "y", "z", "roll", "pitch", "yaw"]}


def rotation_of(roles, x, fixed=None):
    """R = Rz(yaw) Ry(pitch) Rx(roll) with scipy (independent of the package)."""
    v = dict(fixed or {})
    for r, val in zip(roles, x):
        v[r] = val
    return Rotation.from_euler("ZYX", [v.get("yaw", 0.0), v.get("pitch", 0.0), v.get("roll", 0.0)]).as_matrix()


def Rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def layout(kind, ptype, n, angles=None):
    """Per-leg base/platform points, direction/axis/reference and home pose (numbers)."""
    planar = ptype == "planar"
    if ptype == "translation":
        home = np.array([0.0, 0.0, -0.5 if kind == "revolute" else 0.6])
    elif ptype == "planar":
        home = np.array([0.0, 0.0, 0.0])
    elif ptype == "rotation":
        home = np.zeros(n)
    else:
        home = np.array([0.0, 0.0, -0.5 if kind == "revolute" else 0.6, 0.0, 0.0, 0.0])
    if angles is None:
        if n == 6:
            angles = [(g - s, g + t) for g in np.radians([0, 120, 240]) for s, t in ((0.25, 0.8), (-0.25, -0.8))]
        elif n == 2:
            angles = [(0.0, 0.3), (2.1, 2.4)]
        else:
            angles = [(g, g + 0.3) for g in np.linspace(0, 2 * np.pi, n, endpoint=False)]
    legs = []
    for ab, ap in angles:
        if planar:
            base, plat = Rz(ab) @ [0.5, 0, 0], Rz(ap) @ [0.15, 0, 0]
        elif ptype == "rotation":
            base, plat = Rz(ab) @ [0.5, 0, -0.3], Rz(ap) @ [0.3, 0, 0.1]
        else:
            rb, rp = (0.5, 0.25) if kind != "revolute" else (0.2, 0.05) if ptype == "translation" else (0.3, 0.2)
            base, plat = Rz(ab) @ [rb, 0, 0], Rz(ap) @ [rp, 0, 0]
        leg = {"kind": kind, "base": [float(v) for v in base], "platform": [float(v) for v in plat]}
        if kind == "prismatic":
            d = Rz(ab) @ ([-1, 0.5, 0] if planar else [-0.3, 0.2, 1.0])
            leg["direction"] = [float(v) for v in d]
        elif kind == "revolute":
            leg["axis"] = [0.0, 0.0, 1.0] if planar else [float(v) for v in Rz(ab) @ [0, 1, 0]]
            leg["reference"] = [float(v) for v in Rz(ab) @ ([-1, 0, 0] if planar else [1, 0, 0])]
            leg["crank"] = 0.2
        legs.append(leg)
    return legs, home


def description(kind, ptype, n=None, masses=False, pose_extra=None):
    """A description dict (plain numbers) with legs that close at home."""
    roles = ROLE_NAMES[ptype]
    if pose_extra and "angles" in pose_extra:
        roles = [r for r in roles if r in pose_extra["angles"]]
    n = n or len(roles)
    legs, home = layout(kind, ptype, n)
    home = home[:len(roles)]
    fixed = (pose_extra or {}).get("fixed", {})
    R = rotation_of(roles, home, fixed)
    origin = np.zeros(3)
    for r, v in zip(roles, home):
        if r in ("x", "y", "z"):
            origin["xyz".index(r)] = v
    for i, leg in enumerate(legs):
        b = origin + R @ np.array(leg["platform"])
        A = np.array(leg["base"])
        if kind == "prismatic":
            u = np.array(leg["direction"]) / np.linalg.norm(leg["direction"])
            q0 = 0.12 + 0.01 * i
            a = A + q0 * u
            leg["rod"] = float(np.linalg.norm(b - a))
            w = b - A
            root = np.sqrt((u @ w) ** 2 - w @ w + leg["rod"] ** 2)
            leg["branch"] = "minus" if abs(u @ w - root - q0) < abs(u @ w + root - q0) else "plus"
        elif kind == "revolute":
            k = np.array(leg["axis"]) / np.linalg.norm(leg["axis"])
            r0 = np.array(leg["reference"])
            r0 = r0 - (r0 @ k) * k
            r0 /= np.linalg.norm(r0)
            w = b - A
            phi0 = np.arctan2(w @ np.cross(k, r0), w @ r0)
            q0 = phi0 + 1.2 + 0.02 * i            # well inside the annulus the crank tip can reach
            a = A + 0.2 * (np.cos(q0) * r0 + np.sin(q0) * np.cross(k, r0))
            leg["rod"] = float(np.linalg.norm(b - a))
            leg["branch"] = "plus"
        if masses:
            if kind == "prismatic":
                leg["slider"] = {"mass": 1.3 + 0.1 * i}
            if kind == "revolute":
                leg["crank"] = {"length": 0.2, "inertia": 0.02 + 0.001 * i, "mass": 0.8, "centre": 0.4}
            if kind in ("prismatic", "revolute"):
                leg["rod"] = {"length": leg["rod"], "mass": 0.4 + 0.05 * i, "count": 2 if i % 2 else 1,
                              "inertia": 0.01, "centre": 0.45}
            if kind == "strut":
                leg["lower"] = {"mass": 1.1, "centre": 0.15, "inertia": 0.012}
                leg["upper"] = {"mass": 0.6 + 0.05 * i, "centre": 0.2, "inertia": 0.006}
    names = (pose_extra or {}).get("coordinates", ["x", "y", "theta"] if ptype == "planar" else roles)
    pose = {"type": ptype, "home": dict(zip(names, [float(v) for v in home]))}
    pose.update(pose_extra or {})
    out = {"name": f"{kind}_{ptype}", "pose": pose, "legs": legs}
    if masses:
        out["platform"] = {"mass": 3.2, "inertia": {"xx": 0.05, "yy": 0.06, "zz": 0.09, "xy": 0.004, "xz": -0.003, "yz": 0.002},
                           "centre_of_mass": [0.01, -0.02, 0.03]}
    return out


CASES = [(k, p) for p in ("translation", "planar", "rotation", "spatial") for k in ("prismatic", "revolute", "strut")]


def mechanism(kind, ptype, **kw):
    from optdesign.mechanisms.described import build_class

    return build_class(description(kind, ptype, **kw))()


def random_poses(mech, rng, N, span_length=0.03, span_angle=0.08):
    spec = mech.pose_spec
    span = np.array([span_length if r in ("x", "y", "z") else span_angle for r in spec.roles])
    return np.asarray(spec.home) + span * rng.uniform(-1, 1, (N, spec.dof))
