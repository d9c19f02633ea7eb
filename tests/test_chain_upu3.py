"""The translational 3-UPU of configs/upu3.yaml (chain legs with frame closures)
against independent implementations: plain geometry (the platform only
translates, each leg's length is |o + P_i - A_i|), the same legs written as
strut shorthands on a translation pose (every body with the same mass: the
kinematics, M, c, g and the actuator forces of the two models must agree),
and the constraint-singularity value from the legs' couples written by hand."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from optdesign.config import load_config
from optdesign.evaluate import build
from optdesign.mechanisms import describe

ROOT = Path(__file__).resolve().parents[1]
ANGLES = np.radians([0.0, 120.0, 240.0])


@pytest.fixture(scope="module")
def cfg():
    return load_config(ROOT / "configs" / "upu3.yaml")


@pytest.fixture(scope="module")
def mech(cfg):
    return build(cfg, "reference")


@pytest.fixture(scope="module")
def poses():
    rng = np.random.default_rng(11)
    return np.column_stack([rng.uniform(-0.1, 0.1, 30), rng.uniform(-0.1, 0.1, 30), rng.uniform(0.3, 0.5, 30)])


def _points(R_b=0.3, r_p=0.1):
    A = np.stack([R_b * np.array([np.cos(a), np.sin(a), 0.0]) for a in ANGLES])
    P = np.stack([r_p * np.array([np.cos(a), np.sin(a), 0.0]) for a in ANGLES])
    return A, P


def test_plain_geometry(mech, poses):
    A, P = _points()
    d = poses[:, None, :] + P - A
    q = np.linalg.norm(d, axis=-1)
    assert np.max(np.abs(mech.inverse(poses) - q)) < 1e-14
    assert np.max(np.abs(mech.parasitic(poses))) < 1e-14
    assert np.max(np.abs(mech.jacobian(poses) - d / q[..., None])) < 1e-13
    assert np.max(np.abs(mech.forward(q) - poses)) < 1e-12


@pytest.fixture(scope="module")
def struts(cfg):
    raw = yaml.safe_load((ROOT / "configs" / "upu3.yaml").read_text())["mechanism"]
    raw["name"] = "upu3_struts"
    raw["pose"] = {"type": "translation", "home": {"z": 0.4}}
    raw["legs"] = [{"kind": "strut", "actuator": "l", "pattern": {"angles": [0, 120, 240], "unit": "deg"},
                    "base": ["R_b", 0, 0], "platform": ["r_p", 0, 0],
                    "lower": {"mass": "m_cyl", "centre": "e1", "inertia": "I_cyl"},
                    "upper": {"mass": "m_pis", "centre": "e2", "inertia": "I_pis"}}]
    cls = describe(raw, "upu3_struts")
    return cls(**{**cfg.parameters, **cfg.design("reference")})


def test_same_as_strut_legs_on_a_translation_pose(mech, struts, poses):
    rng = np.random.default_rng(5)
    V, Acc = rng.normal(size=poses.shape) * 0.3, rng.normal(size=poses.shape)
    assert np.max(np.abs(mech.inverse(poses) - struts.inverse(poses))) < 1e-14
    assert np.max(np.abs(mech.jacobian(poses) - struts.jacobian(poses))) < 1e-13
    M, Ms = mech.platform_mass_matrix(poses), struts.platform_mass_matrix(poses)
    assert np.max(np.abs(M - Ms)) <= 1e-13 * np.max(np.abs(Ms))
    F, Fs = mech.actuator_forces(poses, V, Acc), struts.actuator_forces(poses, V, Acc)
    assert np.max(np.abs(F - Fs)) <= 1e-12 * np.max(np.abs(Fs))
    for a, b in zip(mech.energies(poses, V), struts.energies(poses, V)):
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(b))
    assert np.max(np.abs(mech.accelerations(poses, V, Acc) - struts.accelerations(poses, V, Acc))) < 1e-12


def test_mobility_and_constraint_singularity(mech, poses):
    mob = mech.mobility()
    assert int(mob["mobility"]) == 3 and np.array_equal(mob["leg_ranks"], [5, 5, 5])
    # each leg's constraint is a couple along s1 x s2, i.e. the leg direction's part across s1
    A, P = _points()
    d = poses[:, None, :] + P - A
    s1 = np.stack([[-np.sin(a), np.cos(a), 0.0] for a in ANGLES])
    n = d - np.sum(d * s1, -1, keepdims=True) * s1
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    sigma = np.linalg.svd(n, compute_uv=False)[:, -1]
    assert np.max(np.abs(mech.constraint_singularity(poses) - sigma)) < 1e-12
    sj = mech.screw_jacobians(poses)
    assert np.max(np.abs(sj["Ja"] @ sj["Xi"] - mech.jacobian(poses))) < 1e-12
    assert np.max(np.abs(sj["Jc"] @ sj["Xi"])) < 1e-12
    # rows of Jc are pure couples (no force)
    assert np.max(np.abs(sj["Jc"][..., :3])) < 1e-12


def test_flat_platform_is_a_constraint_singularity(cfg):
    # legs that lie in one plane (platform in the base plane, H = 0 at home) leave the couples
    # in one plane: the platform gains a rotation there; at height the value is away from 0
    m = build(cfg, "reference")
    z = np.array([[0.0, 0.0, 0.4], [0.0, 0.0, 0.01], [0.0, 0.0, 0.001]])
    v = m.constraint_singularity(z)
    # sigma_min of the three unit couples (radial, and z / l up): sqrt(3) z / l near the plane
    assert v[0] > 0.5 and v[2] < v[1] < v[0]
    assert abs(v[2] / (np.sqrt(3.0) * 0.001 / np.hypot(0.2, 0.001)) - 1) < 1e-5
