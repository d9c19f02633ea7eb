"""Dynamics of described mechanisms against references we did not write:
the CasADi route (energies written from positions, every derivative by AD),
MuJoCo (inverse dynamics of the Gough-Stewart platform and the Delta robot on
trajectories, and its energies), and the energy balance along a trajectory."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from described_helpers import CASES, mechanism, random_poses

from optdesign.config import load_config
from optdesign.evaluate import build

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("kind,ptype", CASES)
def test_dynamics_equal_the_casadi_route(kind, ptype):
    from optdesign.mechanisms.described.symbolic import symbolic_model

    mech = mechanism(kind, ptype, masses=True)
    rng = np.random.default_rng(11)
    X = random_poses(mech, rng, 15)
    V = rng.normal(0, 0.5, X.shape)
    A = rng.normal(0, 3.0, X.shape)
    sm = symbolic_model(mech)
    Q = mech.inverse(X)
    p = {"unused": 0.0}
    tau_s = sm.actuator_forces(X, Q, V, A, p)
    assert np.max(np.abs(mech.actuator_forces(X, V, A) - tau_s)) <= 1e-12 * np.max(np.abs(tau_s))
    Ms = sm.platform_mass_matrix(X, Q, p)
    M = mech.platform_mass_matrix(X, "rates")
    assert np.max(np.abs(M - Ms)) <= 1e-13 * np.max(np.abs(Ms))
    assert np.all(np.linalg.eigvalsh(M) > 0)
    Ts, Vs = sm.energies(X, Q, V, p)
    T, Vp = mech.energies(X, V)
    assert np.max(np.abs(T - Ts)) <= 1e-13 * np.max(np.abs(Ts))
    assert np.max(np.abs(Vp - Vs)) <= 1e-13 * max(1.0, np.max(np.abs(Vs)))
    # the dynamic index's M = J^-T M_p maps accelerations to forces
    Mi = mech.mass_matrix(X)
    J = mech.jacobian(X)
    assert np.allclose(np.einsum("...ji,...jk->...ik", J, Mi), M if mech.pose_spec.jacobian == "rates" else
                       mech.platform_mass_matrix(X), rtol=1e-12, atol=1e-12 * np.max(np.abs(M)))


def _reference(name):
    cfg = load_config(ROOT / "configs" / name)
    return build(cfg, "reference")


@pytest.mark.parametrize("name", ["gough_stewart.yaml", "delta.yaml"])
def test_inverse_dynamics_against_mujoco(name):
    pytest.importorskip("mujoco")
    from optdesign.mechanisms.described.mujoco import inverse_dynamics, smooth_trajectory

    mech = _reference(name)
    t = np.linspace(0.0, 1.0, 41)
    X, V, A = smooth_trajectory(mech, t, amplitude_length=0.04, amplitude_angle=0.15, seed=2)
    res = inverse_dynamics(mech, X, V, A)
    peak = np.max(np.abs(res["ours"]))
    assert np.max(np.abs(res["forces"] - res["ours"])) <= 1e-8 * peak
    assert res["loop_gap"].max() < 1e-12 and res["velocity_gap"].max() < 1e-12
    assert res["residual"].max() < 1e-9 * peak
    T, Vp = mech.energies(X, V)
    assert np.max(np.abs(T - res["kinetic"])) <= 1e-12 * np.max(T)
    dV = Vp - res["potential"]
    assert np.ptp(dV) <= 1e-12 * np.max(np.abs(Vp)) + 1e-12


@pytest.mark.parametrize("name", ["gough_stewart.yaml", "delta.yaml"])
def test_energy_balance_along_a_trajectory(name):
    """Power of the actuator forces = d/dt (T + V), with MuJoCo's energies at
    t +- h (central differences) and our forces and actuator rates at t."""
    pytest.importorskip("mujoco")
    from optdesign.mechanisms.described.mujoco import DescribedModel, energies, smooth_trajectory

    mech = _reference(name)
    model = DescribedModel(mech)
    t = np.linspace(0.05, 0.95, 19)
    h = 1e-5
    X, V, A = smooth_trajectory(mech, t, amplitude_length=0.04, amplitude_angle=0.15, seed=3)
    power = np.sum(mech.actuator_forces(X, V, A) * np.einsum("nij,nj->ni", mech.jacobian_rates(X), V), axis=-1)
    Ep = sum(energies(mech, *smooth_trajectory(mech, t + h, 0.04, 0.15, 3)[:2], model))
    Em = sum(energies(mech, *smooth_trajectory(mech, t - h, 0.04, 0.15, 3)[:2], model))
    dE = (Ep - Em) / (2 * h)
    assert np.max(np.abs(power - dE)) <= 1e-6 * np.max(np.abs(power))
