"""optdesign ik --json includes the inverse Jacobian (rows: actuators, columns:
pose coordinates, SI) for every mechanism, hand-written or described: checked
against central differences of the command's own actuator values."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli_in

from optdesign.config import load_config
from optdesign.evaluate import workspace_of

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ["p4s_paper.yaml", "ups_upr_s.yaml", "cpr_rrr.yaml", "sps_s.yaml", "p4s_legs.yaml", "sps_s_legs.yaml",
           "gough_stewart.yaml", "delta.yaml", "prs3.yaml", "upu3.yaml", "cpr_rrr_legs.yaml", "ups_upr_s_legs.yaml"]


def _ik(path, design, x):
    rc, out, err = run_cli_in(ROOT, ["ik", str(path), "--design", design, "--json", *map(repr, map(float, x))])
    assert rc == 0, err
    return json.loads(out)


@pytest.mark.parametrize("name", CONFIGS)
def test_ik_json_jacobian_against_central_differences(name):
    path = ROOT / "configs" / name
    cfg = load_config(path)
    design = next(iter(cfg.designs))
    X = workspace_of(cfg).X
    x = X[len(X) // 3]
    rec = _ik(path, design, x)
    acts = list(rec["output"])
    J = np.array(rec["jacobian"], dtype=float)
    assert J.shape == (len(acts), len(x))
    h = 1e-6
    num = np.empty_like(J)
    for j in range(len(x)):
        e = np.zeros(len(x))
        e[j] = h
        qp = _ik(path, design, x + e)["output"]
        qm = _ik(path, design, x - e)["output"]
        num[:, j] = [(qp[a] - qm[a]) / (2 * h) for a in acts]
    assert np.max(np.abs(J - num)) <= 1e-7 * np.max(np.abs(num))
    if name.startswith("sps_s"):
        # the index Jacobian of the 3-SPS-S (eq. 10) is on the angular velocity: given beside
        assert np.array(rec["jacobian_angular_velocity"]).shape == J.shape


def test_ik_json_described_equals_hand_written():
    a = _ik(ROOT / "configs" / "p4s_paper.yaml", "before", [0.02, -0.01, 0.57])
    b = _ik(ROOT / "configs" / "p4s_legs.yaml", "before", [0.02, -0.01, 0.57])
    assert np.allclose(a["jacobian"], b["jacobian"], rtol=1e-13, atol=0)
    a = _ik(ROOT / "configs" / "sps_s.yaml", "paper", [0.05, -0.03, 0.02])
    b = _ik(ROOT / "configs" / "sps_s_legs.yaml", "paper", [0.05, -0.03, 0.02])
    assert np.allclose(a["jacobian"], b["jacobian"], rtol=1e-13, atol=1e-15)
    assert np.allclose(a["jacobian_angular_velocity"], b["jacobian_angular_velocity"], rtol=1e-13, atol=1e-15)
