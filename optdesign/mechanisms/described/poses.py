"""Pose types: the platform frame from the pose coordinates, and the maps
between pose-coordinate rates and the platform twist.

The platform's twist is ``xi = (v, omega)`` (6,), in the base frame: ``v`` the
velocity of the platform frame's origin, ``omega`` its angular velocity.  A
pose coordinate plays one of the roles x, y, z (the origin's position) or
roll, pitch, yaw with ``R = Rz(yaw) Ry(pitch) Rx(roll)``; then

    xi = S(x) xdot,   xi_dot = S(x) xddot + sigma(x, xdot),

with ``S`` (6, dof): unit columns for x, y, z and for the angles the columns
of ``E`` (``omega = E (roll_dot, pitch_dot, yaw_dot)``: ``Rz Ry e_x``,
``Rz e_y``, ``e_z``), and ``sigma = Edot xdot`` (angles only).

* ``translation`` (x, y, z): ``R = I``;
* ``planar`` (x, y, theta): origin ``(x, y, 0)``, ``R = Rz(theta)``;
* ``rotation`` (any of roll, pitch, yaw; the others fixed): origin at the
  fixed centre;
* ``spatial`` (x, y, z, roll, pitch, yaw).
"""
from __future__ import annotations

import numpy as np

from .schema import ROLES, PoseSpec

__all__ = ["Frames", "frames", "rate_map", "rate_bias", "twist_columns"]


class Frames:
    """Platform frames at poses X (..., N, dof): ``origin`` (..., N, 3),
    ``R`` (..., N, 3, 3), the angles ``roll, pitch, yaw`` (..., N)."""

    def __init__(self, origin, R, angles):
        self.origin = origin
        self.R = R
        self.angles = angles


def _role_values(spec: PoseSpec, X: np.ndarray, fixed: np.ndarray) -> dict:
    out = {}
    for i, role in enumerate(spec.roles):
        out[role] = X[..., i]
    for j, a in enumerate(("roll", "pitch", "yaw")):
        if a not in out:
            out[a] = fixed[..., j]   # design shape S, broadcasts against (..., N)
    return out


def rpy_matrix(roll, pitch, yaw) -> np.ndarray:
    """Rz(yaw) Ry(pitch) Rx(roll) (..., 3, 3)."""
    roll, pitch, yaw = np.broadcast_arrays(roll, pitch, yaw)
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sr * sy], -1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], -1),
        np.stack([-sp, cp * sr, cp * cr], -1),
    ], -2)


def frames(spec: PoseSpec, X: np.ndarray, centre: np.ndarray, fixed: np.ndarray) -> Frames:
    """Platform frames; ``centre`` S + (3,) and ``fixed`` S + (3,) from the constants."""
    X = np.asarray(X, dtype=float)
    v = _role_values(spec, X, fixed)
    shape = np.broadcast_shapes(X.shape[:-1], *(np.shape(a) for a in v.values()))
    if spec.type == "translation":
        R = np.broadcast_to(np.eye(3), shape + (3, 3))
    elif spec.type == "planar":
        c, s = np.cos(v["yaw"]), np.sin(v["yaw"])
        z, o = np.zeros_like(c), np.ones_like(c)
        R = np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)
    else:
        R = rpy_matrix(v["roll"], v["pitch"], v["yaw"])
    if spec.type == "rotation":
        origin = np.broadcast_to(centre, np.broadcast_shapes(shape, np.shape(centre)[:-1]) + (3,))
    else:
        zero = np.zeros(shape)
        origin = np.stack([v["x"] + zero if "x" in v else zero, v["y"] + zero if "y" in v else zero,
                           v["z"] + zero if "z" in v else zero], -1)
    return Frames(origin, R, {a: v[a] for a in ("roll", "pitch", "yaw")})


def _euler_columns(angles: dict, shape) -> dict:
    """omega per unit rate of each angle: Rz Ry e_x, Rz e_y, e_z (..., 3)."""
    cp, sp = np.cos(angles["pitch"]), np.sin(angles["pitch"])
    cy, sy = np.cos(angles["yaw"]), np.sin(angles["yaw"])
    z = np.zeros(shape)
    return {"roll": np.stack([cy * cp + z, sy * cp + z, -sp + z], -1),
            "pitch": np.stack([-sy + z, cy + z, z], -1),
            "yaw": np.stack([z, z, z + 1.0], -1)}


def rate_map(spec: PoseSpec, fr: Frames) -> np.ndarray | None:
    """S (..., N, 6, dof); None when S is a selection of twist components
    (translation, planar: then :func:`twist_columns` gives them)."""
    if spec.type in ("translation", "planar"):
        return None
    shape = fr.origin.shape[:-1]
    cols = _euler_columns(fr.angles, shape)
    out = np.zeros(shape + (6, spec.dof))
    for j, role in enumerate(spec.roles):
        if role in ("x", "y", "z"):
            out[..., ROLES.index(role), j] = 1.0
        else:
            out[..., 3:, j] = cols[role]
    return out


def rate_bias(spec: PoseSpec, fr: Frames, Xd: np.ndarray) -> np.ndarray:
    """sigma = Sdot xdot (..., N, 6) (nonzero for roll and pitch only)."""
    Xd = np.asarray(Xd, dtype=float)
    shape = np.broadcast_shapes(fr.origin.shape[:-1], Xd.shape[:-1])
    out = np.zeros(shape + (6,))
    if spec.type in ("translation", "planar"):
        return out
    rate = {a: (Xd[..., spec.roles.index(a)] if a in spec.roles else np.zeros(Xd.shape[:-1])) for a in ("roll", "pitch", "yaw")}
    cp, sp = np.cos(fr.angles["pitch"]), np.sin(fr.angles["pitch"])
    cy, sy = np.cos(fr.angles["yaw"]), np.sin(fr.angles["yaw"])
    dr, dp, dy = rate["roll"], rate["pitch"], rate["yaw"]
    # d/dt (Rz Ry e_x) roll_dot + d/dt (Rz e_y) pitch_dot
    e1 = np.stack([-sy * cp * dy - cy * sp * dp, cy * cp * dy - sy * sp * dp, -cp * dp], -1)
    e2 = np.stack([-cy * dy, -sy * dy, np.zeros(np.shape(dy))], -1)
    out[..., 3:] = e1 * dr[..., None] + e2 * dp[..., None]
    return out


def twist_columns(spec: PoseSpec) -> tuple[int, ...]:
    """The twist components (indices into (v, omega)) that are the pose's own
    velocity coordinates in the ``angular_velocity`` convention (and, for
    translation and planar poses, exactly the pose rates)."""
    if spec.type == "translation":
        return (0, 1, 2)
    if spec.type == "planar":
        return (0, 1, 5)
    if spec.type == "rotation":
        return (3, 4, 5)
    return (0, 1, 2, 3, 4, 5)
