"""Mechanism.drawing: the drawn geometry is the kinematics' own (rod lengths,
leg lengths and platform points against the inverse and forward kinematics)."""
from __future__ import annotations

from pathlib import Path

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

    from optdesign.report.html.report import write_report_html

    src = Path(__file__).resolve().parents[1] / "runs" / "p4s_paper-reproduction"
    dst = tmp_path / "run"
    shutil.copytree(src, dst)
    text = write_report_html(dst).read_text()
    assert '"type":"scatter3d"' in text and '"type":"mesh3d"' in text
    assert '"sliders":[' in text and 'Plotly.addFrames' in text
    assert "button type=button class=copy data-snippet=" in text and "navigator.clipboard" in text
    assert "The best Pareto alternatives" in text
    assert "Plotly.animate" not in text          # the slider's figures open on their first pose, no auto-play
    _check_report_mechanism(text, dst)


def _figures(text):
    import json
    import re

    dec = json.JSONDecoder()
    for m in re.finditer(r'Plotly\.newPlot\(\s*"[^"]+",\s*', text):
        data, end = dec.raw_decode(text, m.end())
        layout, _ = dec.raw_decode(text[end:].lstrip()[1:].lstrip())
        yield data, layout


def _arr(v):
    import base64

    if isinstance(v, dict) and "bdata" in v:
        return np.frombuffer(base64.b64decode(v["bdata"]), dtype=np.dtype(v["dtype"])).astype(float)
    return np.array([np.nan if x is None else x for x in v], dtype=float)


def _segments(trace):
    """The polylines (k, 3) of a lines trace whose chains are split by NaN (null)."""
    P = np.stack([_arr(trace[a]) for a in "xyz"], axis=1)
    cut = np.flatnonzero(~np.all(np.isfinite(P), axis=1))
    chunks = [c[np.all(np.isfinite(c), axis=1)] for c in np.split(P, cut)]
    return [c for c in chunks if len(c) >= 2]


def _check_report_mechanism(text, run_dir):
    """The optimum's drawing in report.html: 3 actuated links (rail start to
    slider, of length |q_i|, the inverse kinematics' stroke at the first pose,
    the centre of W) and 6 rods of length L, one frame and one slider step per pose."""
    from optdesign.report.html.rundata import load_run

    figs = [(d, lay) for d, lay in _figures(text) if any(str(t.get("name", "")).startswith("legs: ") for t in d)]
    assert figs, "no drawing of the mechanism"
    data, layout = figs[0]
    legs = next(t for t in data if t["name"].startswith("legs: "))
    rods = next(t for t in data if t["name"].startswith("rods"))
    assert legs["type"] == "scatter3d" and any(t["type"] == "mesh3d" for t in data)
    run = load_run(run_dir)
    mech = run.model.build({k: float(v) for k, v in run.results["optimum"].items()})
    ws = run.workspace
    centre = np.array([ws.center[0], ws.center[1], 0.5 * sum(ws.axes["z"])] if ws.type == "cylinder"
                      else [0.5 * sum(ws.axes[a]) for a in ("x", "y", "z")])
    q = mech.inverse(centre[None])[0]
    seg = _segments(legs)
    assert len(seg) == 3
    np.testing.assert_allclose(sorted(np.linalg.norm(c[-1] - c[0]) for c in seg), sorted(np.abs(q)), atol=1e-9)
    rod_seg = _segments(rods)
    assert len(rod_seg) == 6
    np.testing.assert_allclose([np.linalg.norm(c[1] - c[0]) for c in rod_seg], float(mech.L), atol=1e-9)
    steps = layout["sliders"][0]["steps"]
    assert steps[0]["label"].startswith("1 of ") and "centre of W" in steps[0]["label"]


def test_a_high_dimensional_workspace_is_sampled_within_bounds():
    from pathlib import Path

    from optdesign.report.html.rundata import RunData
    from optdesign.report.html.views import MAX_SAMPLE, _sample, _surface_grid

    cfg = load_config("configs/gough_stewart.yaml")
    run = RunData.of(Path("."), {}, {"optimum": cfg.design("reference")}, cfg)
    X = _sample(run)
    assert 2 ** 6 <= len(X) <= MAX_SAMPLE and X.shape[1] == 6
    assert np.all(np.ptp(X, axis=0) > 0)
    S = _sample(run, slice_extra=True)
    assert np.all(np.ptp(S[:, :3], axis=0) > 0) and np.all(np.ptp(S[:, 3:], axis=0) == 0)
    assert _surface_grid(run) is None            # six free axes: no surface


def test_a_two_dimensional_workspace_is_a_surface_of_the_local_index():
    from pathlib import Path

    from optdesign.evaluate import workspace_of, evaluate
    from optdesign.report.html.rundata import RunData
    from optdesign.report.html.views import workspace_figure

    cfg = load_config("tests/data/p4s_tiny.yaml")
    d = cfg.design(next(iter(cfg.designs)))
    run = RunData.of(Path("."), {}, {"optimum": d}, cfg)
    fig = workspace_figure(run, d)
    surf = fig.data[0]
    assert surf["type"] == "surface" and len(fig.data) == len(cfg.indices)
    gx, gy, Z = np.asarray(surf["x"], float), np.asarray(surf["y"], float), np.asarray(surf["z"], float)
    # at the optimization's own sample points (on the surface's grid) the height is the local index there
    ws = workspace_of(cfg)
    ev = evaluate(cfg, [d], ws, keep_local=True)
    k = next(iter(cfg.indices))
    v = np.asarray(ev.local[k][0], float)
    for x, val in zip(ws.X, v):
        i, j = int(np.argmin(np.abs(gy - x[1]))), int(np.argmin(np.abs(gx - x[0])))
        assert abs(gx[j] - x[0]) < 1e-12 and abs(gy[i] - x[1]) < 1e-12
        assert Z[i, j] == pytest.approx(val, rel=1e-9)


def test_a_copied_designs_snippet_is_the_front_design_in_a_config(tmp_path):
    """The copy button's snippet, pasted under ``designs:`` of the run's config,
    loads and gives the front's design (SI) to the printed 12 digits."""
    import html as html_mod
    import re
    import shutil

    import yaml

    from optdesign.report.html.rundata import load_run
    from optdesign.report.html.report import write_report_html

    src = Path(__file__).resolve().parents[1] / "runs" / "p4s_paper-reproduction"
    dst = tmp_path / "run"
    shutil.copytree(src, dst)
    text = write_report_html(dst).read_text()
    snippets = [html_mod.unescape(m) for m in re.findall(r'data-snippet="([^"]*)"', text)]
    assert snippets
    run = load_run(dst)
    raw = yaml.safe_load((dst / "config.yaml").read_text())
    raw["designs"] = {}
    for snip in snippets:
        raw["designs"].update(yaml.safe_load(snip))
    cfg_file = tmp_path / "pasted.yaml"
    cfg_file.write_text(yaml.safe_dump(raw))
    cfg = load_config(cfg_file)
    for name, front in run.fronts.items():
        for i in range(front.size):
            got = cfg.design(f"{name}_{i + 1}")
            for k, a in front.designs.items():
                assert got[k] == pytest.approx(float(a[i]), rel=1e-11), (name, i, k)


def test_chain_drawing_is_the_chains_own_geometry():
    """3-PRS: each leg is drawn rail zero -> revolute on the slider -> platform
    joint; the slider sits on its vertical rail at the actuator value of the
    inverse kinematics, the rod keeps its length L, the platform joint is
    o + R r_p of our pose (parasitic x, y, yaw included), and an unreachable
    pose is NaN."""
    cfg = load_config("configs/prs3.yaml")
    mech = build(cfg, "reference")
    X = _poses(cfg, 20)
    dr = mech.drawing(X)
    fr = mech.state(X).core["st"]["frames"]
    q = mech.inverse(X)
    L = float(mech.params["L"])
    assert dr["rods"].shape == (len(X), 3, 2, 3)
    np.testing.assert_allclose(dr["rod_lengths"], L, rtol=0, atol=1e-12)
    _check_rods(dr)
    for i, leg in enumerate(dr["legs"]):
        assert leg.shape == (len(X), 3, 3)
        np.testing.assert_allclose(leg[:, 1, 2] - leg[:, 0, 2], q[:, i], rtol=0, atol=1e-12)    # on the rail
        np.testing.assert_allclose(leg[:, 1, :2], leg[:, 0, :2], rtol=0, atol=1e-12)             # vertical rail
        np.testing.assert_allclose(np.linalg.norm(leg[:, 2] - leg[:, 1], axis=-1), L, rtol=0, atol=1e-12)
        P = np.asarray(mech.chain_constants.legs[i].P, float)
        np.testing.assert_allclose(leg[:, 2], fr.origin.reshape(-1, 3) + np.einsum("nij,j->ni", fr.R.reshape(-1, 3, 3), P),
                                   rtol=0, atol=1e-12)
    assert np.abs(fr.origin.reshape(-1, 3)[:, :2]).max() > 1e-5     # the parasitic motion is drawn
    wild = np.array([[0.25, r, p] for r in (-3.0, -1.5, 0.0, 1.5, 3.0) for p in (-3.0, -1.5, 0.0, 1.5, 3.0)])
    reach = mech.reachable(wild)
    assert reach.any() and not reach.all()
    nan = np.isnan(mech.drawing(wild)["platform"]).all(axis=(1, 2))
    assert np.array_equal(nan, ~reach)
