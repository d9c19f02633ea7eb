"""A parallelogram joint (Pa) in a chain: a 3-RPaS (docs/lower-mobility.md),
written here.  Each leg: a crank on an actuated R about the tangential axis
through the rail point A (length c, vertical at the reference configuration),
a parallelogram whose pivots' axis is parallel to the crank's (side d,
vertical at the reference configuration: the distal link keeps the crank's
orientation), and an S at the distal pivot on the platform point.  The S centre
moves in the vertical plane through A perpendicular to the axis, as the
3-PRS's does, so the parasitic x, y, yaw are the 3-PRS's (the plane equations
of tests/test_chain_prs3.py), and the crank angle is that of a planar 2R arm
(c, d) reaching the S centre, in the elbow the home configuration has.  The
dynamics (link masses on the crank and the parallelogram's distal link: the
parallelogram's own acceleration term) against the energy balance, MuJoCo
(two hinges tied by a joint equality) and Pinocchio."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from chain_helpers import christoffel_c, energy_balance, kinetic_by_differences, trajectory
from test_chain_prs3 import reference

from optdesign.mechanisms import describe

ROOT = Path(__file__).resolve().parents[1]
ANGLES = np.radians([90.0, 210.0, 330.0])
C_LEN, D_LEN = 0.18, 0.2


@pytest.fixture(scope="module")
def mech():
    raw = copy.deepcopy(yaml.safe_load((ROOT / "configs" / "prs3.yaml").read_text())["mechanism"])
    raw["name"] = "rpas3"
    raw["parameters"]["c"] = {"kind": "length", "design": False, "default": C_LEN}
    raw["parameters"]["d"] = {"kind": "length", "design": False, "default": D_LEN}
    raw["legs"][0]["actuator"] = "theta"
    raw["legs"][0]["joints"] = [
        {"type": "R", "axis": [0, 1, 0], "at": ["R_b", 0, 0], "actuated": True, "home": -0.6,
         "mass": "m_slider", "centre": ["R_b", 0, "c / 2"], "inertia": [0.002, 0.002, 0.0002]},
        {"type": "Pa", "axis": [0, 1, 0], "at": ["R_b", 0, "c"], "side": [0, 0, "d"], "home": 1.2,
         "mass": "m_rod", "centre": ["R_b", 0.01, "c + d / 2"], "inertia": [0.0012, 0.0015, 0.0004]},
        {"type": "S", "at": ["R_b", 0, "c + d"]}]
    return describe(raw, "rpas3")(R_b=0.2, r_p=0.1, L=0.3)


def _crank(b, elbow):
    """The crank angle of the 2R arm (c, d) from A reaching b, in the plane (radial e, up z)."""
    out = []
    for bi, a in zip(b, ANGLES):
        e = np.array([np.cos(a), np.sin(a), 0.0])
        A = 0.2 * e
        x, z = (bi - A) @ e, bi[2]                 # the plane coordinates (radial, up)
        r2 = x * x + z * z
        g = np.arccos((r2 - C_LEN ** 2 - D_LEN ** 2) / (2 * C_LEN * D_LEN)) * elbow   # the Pa angle
        # a rotation t about the tangential axis turns up (0, 1) to (sin t, cos t) in (radial, up)
        phi = np.arctan2(x, z)                     # direction of b from A, from up towards radial
        out.append(phi - np.arctan2(D_LEN * np.sin(g), C_LEN + D_LEN * np.cos(g)))
    return np.array(out)


def test_kinematics_against_the_plane_and_the_2r_arm(mech):
    rng = np.random.default_rng(2)
    X = np.column_stack([rng.uniform(0.2, 0.3, 15), rng.uniform(-0.25, 0.25, 15), rng.uniform(-0.25, 0.25, 15)])
    th = mech.joint_values(X)[0]                   # the first leg's (N, 2): crank, parallelogram
    elbow = np.sign(mech.joint_values(np.array([[0.25, 0.0, 0.0]]))[0][0, 1])
    q, par = mech.inverse(X), mech.parasitic(X)
    for i, x in enumerate(X):
        _, pr = reference(x)
        assert np.max(np.abs(par[i] - pr)) < 1e-13
        from scipy.spatial.transform import Rotation

        R = Rotation.from_euler("ZYX", [pr[2], x[2], x[1]]).as_matrix()
        o = np.array([pr[0], pr[1], x[0]])
        b = [o + R @ (0.1 * np.array([np.cos(a), np.sin(a), 0.0])) for a in ANGLES]
        assert np.max(np.abs(q[i] - _crank(b, elbow))) < 1e-12
    assert th.shape == (15, 2)
    h = 1e-6
    Jn = np.stack([(mech.inverse(X + e) - mech.inverse(X - e)) / (2 * h) for e in np.eye(3) * h], -1)
    assert np.max(np.abs(mech.jacobian(X) - Jn)) < 1e-7


def test_dynamics(mech):
    traj = trajectory([0.25, 0.0, 0.0], [0.03, 0.2, 0.2], seed=6)
    err, peak = energy_balance(mech, traj, np.linspace(0.0, 1.0, 61))
    assert peak > 0.1 and err <= 1e-8 * peak
    X, V, _ = traj(np.linspace(0.0, 1.0, 9))
    T = 0.5 * np.einsum("ni,nij,nj->n", V, mech.platform_mass_matrix(X), V)
    assert np.max(np.abs(T - kinetic_by_differences(mech, X, V))) <= 1e-7 * np.max(T)
    cc = christoffel_c(mech, X, V)
    assert np.max(np.abs(mech._dyn(X, V)["c"] - cc)) <= 1e-6 * np.max(np.abs(cc))


def test_against_mujoco_and_pinocchio(mech):
    mujoco = pytest.importorskip("mujoco")  # noqa: F841
    from optdesign.mechanisms.described import mujoco as mv

    X, V, A = trajectory([0.25, 0.0, 0.0], [0.03, 0.2, 0.2], seed=6)(np.linspace(0.0, 1.0, 21))
    inv = mv.inverse_dynamics(mech, X, V, A)
    peak = np.abs(inv["ours"]).max()
    assert np.abs(inv["forces"] - inv["ours"]).max() <= 1e-10 * peak
    assert inv["loop_gap"].max() < 1e-12
    try:
        from pin_chains import PinChains
    except ImportError:
        pytest.skip("pinocchio is not installed")
    F, gap = PinChains(mech).inverse_dynamics(X, V, A)
    assert gap < 1e-12 and np.abs(F - inv["ours"]).max() <= 1e-12 * peak
