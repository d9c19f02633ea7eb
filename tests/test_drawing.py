"""Mechanism.drawing: the drawn geometry is the kinematics' own (rod lengths,
leg lengths and platform points against the inverse and forward kinematics)."""
from __future__ import annotations

import numpy as np
import pytest

from optdesign.config import load_config
from optdesign.evaluate import build, workspace_of
from optdesign.mechanisms.p4s.model import P4S
from optdesign.mechanisms.sps_s import SpsS


def _poses(cfg, n=12):
    X = workspace_of(cfg).X
    idx = np.linspace(0, len(X) - 1, min(n, len(X))).astype(int)
    return X[idx]


def _check_rods(dr):
    seg = dr["rods"]
    if seg.shape[1]:
        length = np.linalg.norm(seg[:, :, 1] - seg[:, :, 0], axis=-1)
        np.testing.assert_allclose(length, np.broadcast_to(dr["rod_lengths"], length.shape), rtol=0, atol=1e-12)


def test_p4s_drawing_closes_the_parallelograms_at_every_pose():
    cfg = load_config("configs/p4s_paper.yaml")
    mech = build(cfg, "after") if "after" in cfg.designs else build(cfg, "initial")
    X = _poses(cfg)
    dr = mech.drawing(X)
    assert dr["rods"].shape == (len(X), 6, 2, 3)
    _check_rods(dr)
    # each leg's last point is the platform joint d_i: |d_i - c_i| = L and d_i - p = rho e_i
    for i, leg in enumerate(dr["legs"]):
        np.testing.assert_allclose(np.linalg.norm(leg[:, 2] - leg[:, 1], axis=-1), float(mech.L), atol=1e-12)
        # the slider lies on its rail at the stroke the inverse kinematics gives
        q = mech.inverse(X)[:, i]
        np.testing.assert_allclose(np.linalg.norm(leg[:, 1] - leg[:, 0], axis=-1), np.abs(q), atol=1e-12)
    # the platform: its centre is the forward kinematics' answer for the drawn strokes
    P = mech.forward(mech.inverse(X))
    np.testing.assert_allclose(dr["platform"].mean(axis=1), P, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(dr["platform"] - X[:, None], axis=-1), float(mech.r_a), atol=1e-12)


def test_p4s_drawing_is_nan_where_unreachable():
    mech = P4S(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=np.radians(30))
    dr = mech.drawing(np.array([[0.0, 0.0, 0.592], [0.0, 0.0, 5.0]]))
    assert np.all(np.isfinite(dr["platform"][0])) and np.all(np.isnan(dr["platform"][1]))


def test_sps_s_drawing_leg_lengths_are_the_actuator_values():

    cfg = load_config("configs/sps_s.yaml")
    mech = build(cfg, next(iter(cfg.designs)))
    X = _poses(cfg)
    dr = mech.drawing(X)
    Q = mech.inverse(X)
    for i, leg in enumerate(dr["legs"]):
        np.testing.assert_allclose(np.linalg.norm(leg[:, -1] - leg[:, 0], axis=-1), Q[:, i], atol=1e-12)
    # the platform points are the rotated platform-frame points (from the pose, not the drawing)
    np.testing.assert_allclose(np.linalg.norm(dr["platform"], axis=-1),
                               np.linalg.norm(mech.platform_points_local(), axis=-1)[None].repeat(len(X), 0), atol=1e-12)


@pytest.mark.parametrize("config", ["configs/delta.yaml", "configs/gough_stewart.yaml", "configs/p4s_legs.yaml"])
def test_described_drawing_closes_every_leg(config, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_FAST", "0")
    cfg = load_config(config)
    mech = build(cfg, next(iter(cfg.designs)))
    X = _poses(cfg)
    X = X[mech.reachable(X)]
    assert len(X)
    dr = mech.drawing(X)
    _check_rods(dr)
    Q = mech.inverse(X)
    kind = np.asarray(mech.constants.kind)
    for i, leg in enumerate(dr["legs"]):
        if kind[i] == 2:   # a strut: its drawn length is the actuator value
            np.testing.assert_allclose(np.linalg.norm(leg[:, -1] - leg[:, 0], axis=-1), Q[:, i], atol=1e-12)
        elif kind[i] == 0:  # a slider on its rail at the stroke q
            np.testing.assert_allclose(np.linalg.norm(leg[:, 1] - leg[:, 0], axis=-1), np.abs(Q[:, i]), atol=1e-12)
    # the platform points at the forward kinematics' pose for these actuator values are the drawn ones
    Xf = mech.forward(Q, X0=X)
    np.testing.assert_allclose(Xf, X, atol=1e-8)
    np.testing.assert_allclose(mech.drawing(Xf)["platform"], dr["platform"], atol=1e-8)


def test_report_holds_the_mechanism_in_3d_with_a_slider_and_copy_buttons(tmp_path):
    import shutil
    from pathlib import Path

    from optdesign.report_html.report import write_report_html

    src = Path(__file__).resolve().parents[1] / "runs" / "p4s_paper-reproduction"
    dst = tmp_path / "run"
    shutil.copytree(src, dst)
    text = write_report_html(dst).read_text()
    assert '"type":"scatter3d"' in text and '"type":"mesh3d"' in text
    assert '"sliders":[' in text and 'Plotly.addFrames' in text
    assert "button type=button class=copy data-snippet=" in text and "navigator.clipboard" in text
    assert "The best Pareto alternatives" in text
