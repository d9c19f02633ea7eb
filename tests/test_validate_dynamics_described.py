"""validate-dynamics on a described mechanism: MuJoCo's inverse dynamics and
its mass matrix reduced to the pose rates against ours."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from optdesign.config import load_config
from optdesign.evaluate import build

mujoco = pytest.importorskip("mujoco")
ROOT = Path(__file__).resolve().parents[1]


def test_reduced_mass_matrix_equals_ours_and_sees_a_wrong_mass(monkeypatch):
    monkeypatch.setenv("OPTDESIGN_FAST", "0")
    from optdesign.mechanisms.described.mujoco import mass_matrices, smooth_trajectory

    cfg = load_config(ROOT / "configs" / "gough_stewart.yaml")
    mech = build(cfg, "reference")
    X, _, _ = smooth_trajectory(mech, np.linspace(0, 1, 4), 0.03, 0.1)
    theirs, ours = mass_matrices(mech, X)
    assert np.abs(theirs - ours).max() <= 1e-10 * np.abs(ours).max()
    # a heavier platform in MuJoCo's model only: the check sees it
    heavy = build(cfg, "reference")
    name = next(p.name for p in mech.description.params if p.kind == "mass")
    heavy2 = type(mech)(**{**heavy.params, name: float(np.asarray(heavy.params[name])) * 1.01})
    theirs2, _ = mass_matrices(heavy2, X)
    assert np.abs(theirs2 - ours).max() > 1e-5 * np.abs(ours).max()


@pytest.mark.slow
def test_validate_dynamics_command_on_a_described_mechanism(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("OPTDESIGN_FAST", "0")
    from optdesign.cli import main

    monkeypatch.chdir(tmp_path)
    rc = main(["validate-dynamics", str(ROOT / "configs" / "delta.yaml"), "--design", "reference",
               "--points", "5", "--out", "v"])
    assert rc == 0, capsys.readouterr().err
    s = json.loads((tmp_path / "v" / "summary.json").read_text())
    for path in ("small", "large"):
        assert s["paths"][path]["max_relative_difference"] < 1e-8
        assert s["paths"][path]["mass_matrix_max_relative_difference"] < 1e-10
    assert (tmp_path / "v" / "forces.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "v" / "model.xml")).nv > 3
    assert "mass matrix diff" in capsys.readouterr().out
