"""Chain mechanisms against MuJoCo (optdesign/mechanisms/described/mujoco_chains.py):
a model built from the joints (one body per joint variable, connect/weld
equalities to the platform), our kinematic states set in it, MuJoCo's inverse
dynamics split into loop-closure and actuator forces."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from optdesign.config import load_config
from optdesign.evaluate import build

pytest.importorskip("mujoco")
from optdesign.mechanisms.described import mujoco as mv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CASES = {"prs3.yaml": ("reference", 0.03, 0.15), "upu3.yaml": ("reference", 0.05, 0.0)}


@pytest.mark.parametrize("name", sorted(CASES))
def test_inverse_dynamics_energies_and_mass_matrix(name):
    design, al, aa = CASES[name]
    mech = build(load_config(ROOT / "configs" / name), design)
    X, V, A = mv.smooth_trajectory(mech, np.linspace(0.0, 1.0, 41), amplitude_length=al, amplitude_angle=aa)
    inv = mv.inverse_dynamics(mech, X, V, A)
    peak = np.abs(inv["ours"]).max()
    assert peak > 1.0
    assert np.abs(inv["forces"] - inv["ours"]).max() <= 1e-10 * peak
    assert inv["loop_gap"].max() < 1e-12 and inv["residual"].max() < 1e-10 * peak
    T, U = mech.energies(X, V)
    assert np.abs(inv["kinetic"] - T).max() <= 1e-10 * max(T.max(), 1e-3)
    assert np.abs(inv["potential"] - U).max() <= 1e-10 * np.abs(U).max()
    Mj, Mo = mv.mass_matrices(mech, X[::8])
    assert np.abs(Mj - Mo).max() <= 1e-10 * np.abs(Mo).max()
