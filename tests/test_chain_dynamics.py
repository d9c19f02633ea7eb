"""Dynamics of chain mechanisms with every link's mass (docs/lower-mobility.md):
the energy balance tau.qdot = d/dt (T + V) along a trajectory, and a second
route from positions only: the kinetic energy from the bodies' positions at
x -+ h v, c from the Christoffel symbols of M's differences, g from the
potential's gradient, qddot from differences of q."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from chain_helpers import christoffel_c, energy_balance, gravity_by_differences, kinetic_by_differences, trajectory

from optdesign.config import load_config
from optdesign.evaluate import build

ROOT = Path(__file__).resolve().parents[1]
CASES = {"prs3.yaml": ("reference", [0.03, 0.15, 0.15]), "upu3.yaml": ("reference", [0.08, 0.08, 0.08])}


def _mapped_prs3():
    """The 3-PRS with a declared coordinate map (z = h, roll = asin(a), pitch = asin(b)):
    the map's second derivatives enter c."""
    import yaml

    from optdesign.mechanisms import describe

    raw = yaml.safe_load((ROOT / "configs" / "prs3.yaml").read_text())["mechanism"]
    raw["name"] = "prs3_mapped"
    raw["pose"] = {"type": "spatial", "independent": ["h", "a", "b"], "home": {"z": 0.25},
                   "map": {"z": "h", "roll": "asin(a)", "pitch": "asin(b)"}, "units": {"h": "m"}}
    return describe(raw, "prs3_mapped")(R_b=0.2, r_p=0.1, L=0.3)


@pytest.fixture(scope="module", params=sorted(CASES) + ["prs3 mapped"])
def case(request):
    name = request.param
    if name == "prs3 mapped":
        return _mapped_prs3(), trajectory([0.25, 0.0, 0.0], [0.03, 0.3, 0.3], seed=3)
    design, amp = CASES[name]
    cfg = load_config(ROOT / "configs" / name)
    mech = build(cfg, design)
    home = np.asarray(mech.pose_spec.home)[list(mech.pose_spec.independent_index)]
    return mech, trajectory(home, amp, seed=3)


def test_mapped_coordinates_equal_the_pose_coordinates():
    m, ref = _mapped_prs3(), build(load_config(ROOT / "configs" / "prs3.yaml"), "reference")
    X = np.array([[0.26, 0.1, -0.2], [0.22, -0.15, 0.05]])
    Xr = np.column_stack([X[:, 0], np.arcsin(X[:, 1]), np.arcsin(X[:, 2])])
    assert np.max(np.abs(m.inverse(X) - ref.inverse(Xr))) < 1e-14
    D = np.stack([np.ones(2), 1 / np.sqrt(1 - X[:, 1] ** 2), 1 / np.sqrt(1 - X[:, 2] ** 2)], -1)
    assert np.max(np.abs(m.jacobian(X) - ref.jacobian(Xr) * D[:, None, :])) < 1e-13
    assert np.max(np.abs(m.forward(m.inverse(X)) - X)) < 1e-11


def test_energy_balance(case):
    mech, traj = case
    err, peak = energy_balance(mech, traj, np.linspace(0.0, 1.0, 101))
    assert peak > 1.0
    assert err <= 1e-8 * peak, (err, peak)


def test_mass_matrix_from_positions(case):
    mech, traj = case
    X, V, _ = traj(np.linspace(0.0, 1.0, 13))
    T = 0.5 * np.einsum("ni,nij,nj->n", V, mech.platform_mass_matrix(X), V)
    Tfd = kinetic_by_differences(mech, X, V)
    assert np.max(np.abs(T - Tfd)) <= 1e-7 * np.max(T)


def test_velocity_term_against_christoffel(case):
    mech, traj = case
    X, V, _ = traj(np.linspace(0.0, 1.0, 9))
    d = mech._dyn(X, V)
    cc = christoffel_c(mech, X, V)
    assert np.max(np.abs(d["c"] - cc)) <= 1e-6 * np.max(np.abs(cc))


def test_gravity_against_potential(case):
    mech, traj = case
    X, _, _ = traj(np.linspace(0.0, 1.0, 9))
    g = mech._dyn(X)["g"]
    assert np.max(np.abs(g - gravity_by_differences(mech, X))) <= 1e-7 * np.max(np.abs(g))


def test_accelerations_against_differences(case):
    mech, traj = case
    t = np.linspace(0.0, 1.0, 11)
    h = 1e-3
    X, V, A = traj(t)
    qdd = mech.accelerations(X, V, A)

    def q(tt):
        return mech.inverse(traj(tt)[0])
    num = (-q(t + 2 * h) + 16 * q(t + h) - 30 * q(t) + 16 * q(t - h) - q(t - 2 * h)) / (12 * h * h)
    assert np.max(np.abs(qdd - num)) <= 1e-7 * np.max(np.abs(qdd))


def test_dynamic_index_matrix(case):
    mech, traj = case
    X, _, _ = traj(np.linspace(0.0, 1.0, 5))
    M = mech.mass_matrix(X)
    assert np.allclose(np.einsum("nji,njk->nik", mech.jacobian(X), M), mech.platform_mass_matrix(X), rtol=1e-12,
                       atol=1e-12)
