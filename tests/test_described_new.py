"""The Gough-Stewart platform and the Delta robot as descriptions
(configs/gough_stewart.yaml, configs/delta.yaml): inverse kinematics against
hand computations of the geometry the configs state, the Jacobian against
central differences, forward kinematics round trips over the workspace."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from optdesign.config import load_config
from optdesign.evaluate import build, workspace_of

ROOT = Path(__file__).resolve().parents[1]


def _load(name):
    cfg = load_config(ROOT / "configs" / name)
    return cfg, build(cfg, "reference"), workspace_of(cfg).X


# ---------------------------------------------------------------------- Gough-Stewart
GS_BASE = np.radians([-15, 15, 105, 135, 225, 255])
GS_PLAT = np.radians([-50, 50, 70, 170, 190, 290])


def _gs_lengths(X, R_b=0.5, R_p=0.3):
    """l_i = |p + R P_i - B_i| from the numbers of the issue, R by scipy (Z-Y-X = yaw, pitch, roll)."""
    B = np.stack([R_b * np.cos(GS_BASE), R_b * np.sin(GS_BASE), np.zeros(6)], -1)
    P = np.stack([R_p * np.cos(GS_PLAT), R_p * np.sin(GS_PLAT), np.zeros(6)], -1)
    R = Rotation.from_euler("ZYX", X[:, [5, 4, 3]]).as_matrix()
    b = X[:, None, :3] + np.einsum("nij,kj->nki", R, P)
    return np.linalg.norm(b - B, axis=-1)


def test_gough_stewart_home_lengths_by_hand():
    _, mech, _ = _load("gough_stewart.yaml")
    # every base joint is 35 deg from its platform joint: l^2 = R_b^2 + R_p^2 - 2 R_b R_p cos 35 + z^2
    l = np.sqrt(0.5 ** 2 + 0.3 ** 2 - 2 * 0.5 * 0.3 * np.cos(np.radians(35)) + 0.7 ** 2)
    q = mech.inverse(np.array([[0, 0, 0.7, 0, 0, 0]]))
    assert np.allclose(q, l, rtol=0, atol=1e-15)
    assert mech.actuator_names == tuple(f"l{i}" for i in range(1, 7))
    assert mech.pose_names == ("x", "y", "z", "roll", "pitch", "yaw")


def test_gough_stewart_inverse_over_the_workspace():
    _, mech, X = _load("gough_stewart.yaml")
    assert np.max(np.abs(mech.inverse(X) - _gs_lengths(X))) < 1e-15 * 10


def test_gough_stewart_jacobian_against_central_differences():
    _, mech, X = _load("gough_stewart.yaml")
    X = X[:300]
    h = 1e-6
    num = np.stack([(_gs_lengths(X + h * e) - _gs_lengths(X - h * e)) / (2 * h) for e in np.eye(6)], -1)
    J = mech.jacobian(X)
    rel = np.linalg.norm(J - num, axis=(-1, -2)) / np.linalg.norm(num, axis=(-1, -2))
    assert np.max(rel) < 1e-7


def test_gough_stewart_forward_of_inverse_over_the_workspace():
    _, mech, X = _load("gough_stewart.yaml")
    Xf = mech.forward(mech.inverse(X))
    assert np.max(np.abs(Xf[:, :3] - X[:, :3])) < 1e-12          # m
    assert np.max(np.abs(Xf[:, 3:] - X[:, 3:])) < 1e-12          # rad


def test_gough_stewart_other_assembly_modes():
    """Newton from other starts finds other platform poses with the same leg
    lengths; each one closes every leg, and the reference pose is among them."""
    _, mech, _ = _load("gough_stewart.yaml")
    X = np.array([[0.01, -0.02, 0.72, 0.05, -0.03, 0.08]])
    sols = mech.forward_all(mech.inverse(X), starts=64, span_length=0.6, span_angle=1.5)[0]
    assert np.min(np.max(np.abs(sols - X), axis=-1)) < 1e-12
    assert np.max(np.abs(mech.inverse(sols) - mech.inverse(X))) < 1e-10


# ---------------------------------------------------------------------- Delta
def _delta_angles(X, R=0.20, r=0.05, La=0.25, Lb=0.60):
    """The elbow-out crank angles by the tangent half-angle form, per leg in its own frame:
    with B = Rz(-psi) p + (r, 0, 0), E = B_x - R, F = B_z the closure is
    a cos(theta) + b sin(theta) = c, a = -2 E La, b = 2 F La, c = Lb^2 - E^2 - B_y^2 - F^2 - La^2;
    t = tan(theta / 2) solves (c + a) t^2 - 2 b t + (c - a) = 0; elbow-out is the larger cos(theta)."""
    out = np.empty(X.shape)
    for i, psi in enumerate(np.radians([0, 120, 240])):
        c, s = np.cos(psi), np.sin(psi)
        bx = c * X[:, 0] + s * X[:, 1] + r
        by = -s * X[:, 0] + c * X[:, 1]
        bz = X[:, 2]
        E, F = bx - R, bz
        a, b = -2 * E * La, 2 * F * La
        cc = Lb ** 2 - E ** 2 - by ** 2 - F ** 2 - La ** 2
        disc = np.sqrt(b * b + a * a - cc * cc)
        t1 = (b + disc) / (cc + a)
        t2 = (b - disc) / (cc + a)
        th = np.stack([2 * np.arctan(t1), 2 * np.arctan(t2)])
        out[:, i] = np.where(np.cos(th[0]) >= np.cos(th[1]), th[0], th[1])
    return out


def test_delta_inverse_by_hand():
    _, mech, X = _load("delta.yaml")
    assert mech.actuator_names == ("theta1", "theta2", "theta3")
    assert np.max(np.abs(mech.inverse(X) - _delta_angles(X))) < 1e-12
    # the crank tip of the formula is L_b from the platform point
    Q = mech.inverse(X)
    for i, psi in enumerate(np.radians([0, 120, 240])):
        Rz = np.array([[np.cos(psi), -np.sin(psi), 0], [np.sin(psi), np.cos(psi), 0], [0, 0, 1]])
        tip = np.stack([0.2 + 0.25 * np.cos(Q[:, i]), 0 * Q[:, i], -0.25 * np.sin(Q[:, i])], -1) @ Rz.T
        plat = X + Rz @ [0.05, 0, 0]
        assert np.max(np.abs(np.linalg.norm(plat - tip, axis=-1) - 0.6)) < 1e-14
        # elbow-out: the tip is farther from the base centre than the other closing angle's
        assert np.all(np.cos(Q[:, i]) > 0)


def test_delta_jacobian_against_central_differences():
    _, mech, X = _load("delta.yaml")
    X = X[:500]
    h = 1e-6
    num = np.stack([(_delta_angles(X + h * e) - _delta_angles(X - h * e)) / (2 * h) for e in np.eye(3)], -1)
    J = mech.jacobian(X)
    rel = np.linalg.norm(J - num, axis=(-1, -2)) / np.linalg.norm(num, axis=(-1, -2))
    assert np.max(rel) < 1e-7


def test_delta_forward_of_inverse_over_the_workspace():
    _, mech, X = _load("delta.yaml")
    Q = mech.inverse(X)
    assert np.max(np.abs(mech.forward(Q) - X)) < 1e-12
    # both sphere solutions: the other one is the mirror image above the crank tips
    sols = mech.forward_all(Q[:50])
    assert all(len(s) >= 1 and np.min(np.max(np.abs(s - x), axis=-1)) < 1e-12 for s, x in zip(sols, X[:50]))


@pytest.mark.parametrize("name", ["gough_stewart.yaml", "delta.yaml"])
def test_reference_design_reaches_the_whole_workspace(name):
    from optdesign.evaluate import evaluate_named

    cfg, _, _ = _load(name)
    res = evaluate_named(cfg, ["reference"])["reference"]
    assert res["reachable_fraction"] == 1.0
    assert all(np.isfinite(res[k]["mean"]) for k in cfg.indices)
