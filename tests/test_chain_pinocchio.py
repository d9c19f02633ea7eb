"""Chain mechanisms against Pinocchio (``pip install pin``; skipped without it):
the open tree's RNEA and CRBA with the loops closed by the frames' Jacobians
(tests/pin_chains.py) against our actuator forces and mass matrix."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from chain_helpers import trajectory

from optdesign.config import load_config
from optdesign.evaluate import build

pytest.importorskip("pinocchio")
from pin_chains import PinChains  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CASES = {"prs3.yaml": [0.03, 0.15, 0.15], "upu3.yaml": [0.08, 0.08, 0.08]}


@pytest.mark.parametrize("name", sorted(CASES))
def test_inverse_dynamics_and_mass_matrix(name):
    mech = build(load_config(ROOT / "configs" / name), "reference")
    home = np.asarray(mech.pose_spec.home)[list(mech.pose_spec.independent_index)]
    X, V, A = trajectory(home, CASES[name], seed=4)(np.linspace(0.0, 1.0, 21))
    pm = PinChains(mech)
    F, gap = pm.inverse_dynamics(X, V, A)
    ours = mech.actuator_forces(X, V, A)
    peak = np.abs(ours).max()
    assert peak > 1.0 and gap < 1e-12
    assert np.abs(F - ours).max() <= 1e-12 * peak
    for x in X[::5]:
        Mp, Mo = pm.mass_matrix(x), mech.platform_mass_matrix(x[None])[0]
        assert np.abs(Mp - Mo).max() <= 1e-12 * np.abs(Mo).max()
