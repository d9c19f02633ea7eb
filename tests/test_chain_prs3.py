"""The 3-PRS of configs/prs3.yaml (chain legs, docs/lower-mobility.md) against an
independent implementation written here: plain geometry, not the chain code.

Each leg's rod moves in the vertical plane through its rail that is
perpendicular to its revolute axis k_i (tangential), so the platform point b_i
satisfies (b_i - A_i).k_i = 0; the parasitic x, y, yaw solve these three
equations (scipy.optimize.least_squares) at given z, roll, pitch; the slider
below its platform joint sits at q_i = b_iz - sqrt(L^2 - ((b_i - A_i).e_i)^2).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli_in
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from optdesign.config import load_config
from optdesign.evaluate import build

ROOT = Path(__file__).resolve().parents[1]
ANGLES = np.radians([90.0, 210.0, 330.0])


def reference(x, R_b=0.20, r_p=0.10, L=0.30):
    """(q (3,), parasitic (x, y, yaw)) at (z, roll, pitch) by plain geometry."""
    z, roll, pitch = x

    def points(v):
        R = Rotation.from_euler("ZYX", [v[2], pitch, roll]).as_matrix()
        o = np.array([v[0], v[1], z])
        return [o + R @ (r_p * np.array([np.cos(a), np.sin(a), 0.0])) for a in ANGLES]

    def planes(v):
        return [b @ np.array([-np.sin(a), np.cos(a), 0.0]) for b, a in zip(points(v), ANGLES)]

    sol = least_squares(planes, [0.0, 0.0, 0.0], xtol=1e-15, ftol=1e-15, gtol=1e-15)
    assert np.max(np.abs(planes(sol.x))) < 1e-15
    q = []
    for b, a in zip(points(sol.x), ANGLES):
        rad = b @ np.array([np.cos(a), np.sin(a), 0.0]) - R_b
        q.append(b[2] - np.sqrt(L * L - rad * rad))
    return np.array(q), sol.x


@pytest.fixture(scope="module")
def mech():
    return build(load_config(ROOT / "configs" / "prs3.yaml"), "reference")


@pytest.fixture(scope="module")
def poses():
    rng = np.random.default_rng(7)
    return np.column_stack([rng.uniform(0.18, 0.32, 25), rng.uniform(-0.3, 0.3, 25), rng.uniform(-0.3, 0.3, 25)])


def test_names(mech):
    assert mech.pose_names == ("z", "roll", "pitch")
    assert mech.parasitic_names == ("x", "y", "yaw")
    assert mech.actuator_names == ("q1", "q2", "q3")


def test_inverse_and_parasitic_against_plain_geometry(mech, poses):
    q, par = mech.inverse(poses), mech.parasitic(poses)
    for i, x in enumerate(poses):
        qr, pr = reference(x)
        assert np.max(np.abs(q[i] - qr)) < 1e-13
        assert np.max(np.abs(par[i] - pr)) < 1e-13


def test_jacobian_against_differences_of_the_reference_and_of_ours(mech, poses):
    J = mech.jacobian(poses)
    Jp = mech.parasitic_jacobian(poses)
    h = 1e-6
    for i, x in enumerate(poses[:10]):
        cols = [(reference(x + h * e), reference(x - h * e)) for e in np.eye(3)]
        Jn = np.column_stack([(p[0] - m[0]) / (2 * h) for p, m in cols])
        Pn = np.column_stack([(p[1] - m[1]) / (2 * h) for p, m in cols])
        assert np.max(np.abs(J[i] - Jn)) < 1e-8
        assert np.max(np.abs(Jp[i] - Pn)) < 1e-8
    # and our own inverse kinematics' differences
    E = np.eye(3) * h
    Jo = np.stack([(mech.inverse(poses + e) - mech.inverse(poses - e)) / (2 * h) for e in E], -1)
    assert np.max(np.abs(J - Jo)) < 1e-8


def test_forward_returns_the_pose(mech, poses):
    q = mech.inverse(poses)
    X = mech.forward(q)
    assert np.max(np.abs(X - poses)) < 1e-11


def test_population_broadcasts(mech, poses):
    cfg = load_config(ROOT / "configs" / "prs3.yaml")
    cls = type(mech)
    R_b = np.array([[0.18], [0.2], [0.22]])
    pop = cls(**{**cfg.parameters, "R_b": R_b, "r_p": 0.1, "L": 0.3})
    q = pop.inverse(poses)
    assert q.shape == (3, len(poses), 3)
    for d in range(3):
        for i in (0, 5, 11):
            assert np.max(np.abs(q[d, i] - reference(poses[i], R_b=float(R_b[d, 0]))[0])) < 1e-13


def test_unreachable_is_nan(mech):
    # short rods (L = 0.12 m, R_b - r_p = 0.1 m): a roll of 1 rad moves a platform joint
    # 0.146 m from its rail, beyond the rod
    cfg = load_config(ROOT / "configs" / "prs3.yaml")
    short = type(mech)(**{**cfg.parameters, "R_b": 0.2, "r_p": 0.1, "L": 0.12})
    X = np.array([[0.25, 0.0, 0.0], [0.25, 1.0, 0.0], [0.25, 0.3, 0.0]])
    q = short.inverse(X)
    assert np.all(np.isfinite(q[0])) and np.all(np.isfinite(q[2]))
    assert np.all(np.isnan(q[1])) and np.all(np.isnan(short.parasitic(X)[1]))
    assert np.array_equal(short.reachable(X), [True, False, True])
    assert np.max(np.abs(q[2] - reference(X[2], L=0.12)[0])) < 1e-13


def test_ik_json_reports_parasitic():
    rc, out, err = run_cli_in(ROOT, ["ik", "configs/prs3.yaml", "--design", "reference", "--json", "0.27", "0.1",
                                     "-0.05"])
    assert rc == 0, err
    rec = json.loads(out)
    qr, pr = reference([0.27, 0.1, -0.05])
    assert np.allclose([rec["output"][f"q{i}"] for i in (1, 2, 3)], qr, rtol=0, atol=1e-13)
    assert np.allclose([rec["parasitic"][k] for k in ("x", "y", "yaw")], pr, rtol=0, atol=1e-13)
    assert np.array(rec["jacobian"]).shape == (3, 3)
