"""optdesign export RUN --mjcf FILE: the MuJoCo model of a run's design loads,
steps, starts with its loops closed, and its servos, given the inverse
kinematics' actuator values of a pose, bring the platform to that pose (the
project's own kinematics); the command refuses bad designs and unsafe files."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from optdesign.config import load_config
from optdesign.evaluate import build

mujoco = pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[1]
RUN = ROOT / "runs" / "p4s_paper-reproduction"
#: platform pose reached by the servos (m, rad): the loops are stiff equality
#: constraints and the servos critically damped, so at rest without gravity
#: the remaining error is the settling left after the simulated time
POSE_TOL = 1e-6


def _settle(xml: str, q_target, seconds: float):
    """Model from the text, reset to its keyframe, gravity off, ctrl = q_target, stepped."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    m.opt.gravity[:] = 0.0
    d.ctrl[:] = q_target
    for _ in range(int(round(seconds / m.opt.timestep))):
        mujoco.mj_step(m, d)
    return m, d


def _body(m, d, name):
    b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
    return d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()


def test_export_cli_writes_a_model_that_loads_and_steps_with_closed_loops(tmp_path, capsys):
    from optdesign.cli import main

    run = tmp_path / "run"
    shutil.copytree(RUN, run)
    before = {p: p.stat().st_mtime_ns for p in run.rglob("*")}
    out = tmp_path / "model" / "p4s.xml"
    out.parent.mkdir()
    assert main(["export", str(run), "--mjcf", str(out)]) == 0
    assert "3 position servos" in capsys.readouterr().out
    assert {p: p.stat().st_mtime_ns for p in run.rglob("*")} == before   # the run folder is only read
    assert sorted(p.name for p in out.parent.iterdir()) == ["p4s.xml"]
    m = mujoco.MjModel.from_xml_path(str(out))
    assert m.nu == 3 and m.neq == 6 and m.nkey == 1
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    assert np.abs(d.efc_pos[:d.nefc]).max() < 1e-12          # every loop closed at the keyframe
    for _ in range(200):                                       # with gravity, under its servos
        mujoco.mj_step(m, d)
    assert np.all(np.isfinite(d.qpos)) and np.abs(d.efc_pos[:d.nefc]).max() < 1e-6
    # the keyframe's platform position is the centre of W
    cfg = load_config(RUN / "config.yaml")
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    assert np.allclose(_body(m, d, "platform")[0][2], 0.5 * sum(cfg.workspace.axes["z"]), atol=1e-12)


def test_p4s_servos_bring_the_platform_to_the_inverse_kinematics_pose():
    from optdesign.mjcf_export import export_mjcf

    cfg = load_config(RUN / "config.yaml")
    mech = build(cfg, "after")
    home = np.array([0.0, 0.0, 0.59])
    target = np.array([0.03, -0.02, 0.62])
    q = mech.inverse(target[None])[0]
    m, d = _settle(export_mjcf(mech, home), q, 0.4)
    p, R = _body(m, d, "platform")
    assert np.abs(p - target).max() < POSE_TOL
    assert np.abs(R - np.eye(3)).max() < POSE_TOL
    # and the servos hold the IK values (the home pose is far: the test can fail)
    assert np.abs(mech.inverse(home[None])[0] - q).max() > 1e-3


@pytest.mark.slow
@pytest.mark.parametrize("name, target", [
    ("delta.yaml", [0.03, -0.02, -0.6]),
    ("gough_stewart.yaml", [0.03, -0.02, 0.72, 0.05, -0.03, 0.04]),
])
def test_described_servos_bring_the_platform_to_the_inverse_kinematics_pose(name, target, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_FAST", "0")
    from optdesign.mjcf_export import export_mjcf

    mech = build(load_config(ROOT / "configs" / name), "reference")
    target = np.array(target)
    home = np.array(mech.pose_spec.home, float)
    q = mech.inverse(target[None])[0]
    m, d = _settle(export_mjcf(mech, home), q, 0.8)
    assert m.nu == len(q)
    p, R = _body(m, d, "platform")
    fr = mech.leg_state(target[None])["frames"]
    assert np.abs(p - fr.origin[0]).max() < POSE_TOL
    assert np.abs(R - fr.R[0]).max() < POSE_TOL


def test_export_refuses_a_bad_design_and_unsafe_files(tmp_path, capsys):
    from optdesign.cli import main

    out = tmp_path / "m.xml"
    assert main(["export", str(RUN), "--mjcf", str(out), "--design", "aftr"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no design named 'aftr'" in err and "did you mean 'after'" in err
    assert not out.exists()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    link = tmp_path / "link.xml"
    link.symlink_to(victim)
    assert main(["export", str(RUN), "--mjcf", str(link)]) == 2
    assert "symbolic link" in capsys.readouterr().err and victim.read_text() == "keep"
    other = tmp_path / "notes.xml"
    other.write_text("my notes")
    assert main(["export", str(RUN), "--mjcf", str(other)]) == 2
    assert other.read_text() == "my notes"
    assert main(["export", str(RUN), "--mjcf", str(tmp_path / "m.txt")]) == 2
    assert main(["export", str(tmp_path), "--mjcf", str(out)]) == 2      # not a run folder
    capsys.readouterr()
    # a Pareto point by its snippet name
    assert main(["export", str(RUN), "--mjcf", str(out), "--design", "pareto_nsga2_1"]) == 0
    assert mujoco.MjModel.from_xml_path(str(out)).nu == 3


@pytest.mark.parametrize("name, target", [("prs3.yaml", [0.27, 0.04, -0.03]), ("upu3.yaml", [0.02, -0.015, 0.42])])
def test_chain_servos_bring_the_platform_to_the_pose_and_its_parasitic_motion(name, target):
    """Chain mechanisms: the servos, given our inverse kinematics' actuator
    values of a pose of the independent coordinates, bring the platform to
    that pose and to the parasitic coordinates our kinematics solves (3-PRS:
    x, y, yaw; 3-UPU: the rotation, zero), with the loops closed."""
    from optdesign.mjcf_export import export_mjcf

    mech = build(load_config(ROOT / "configs" / name), "reference")
    home = np.array(mech.pose_spec.home, float)[list(mech.pose_spec.independent)]
    target = np.array(target)
    q = mech.inverse(target[None])[0]
    xml = export_mjcf(mech, home)
    m = mujoco.MjModel.from_xml_string(xml)                  # the keyframe: loops closed, servos at our IK
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    assert np.abs(d.efc_pos[:d.nefc]).max() < 1e-12
    np.testing.assert_allclose(d.ctrl, mech.inverse(home[None])[0], rtol=0, atol=1e-12)
    m, d = _settle(xml, q, 1.5)
    assert m.nu == 3 and np.abs(d.efc_pos[:d.nefc]).max() < 1e-8
    p, R = _body(m, d, "platform")
    fr = mech.state(target[None]).core["st"]["frames"]
    if name == "prs3.yaml":
        assert np.abs(fr.origin[0][:2]).max() > 1e-5              # there is parasitic motion to match
    assert np.abs(p - fr.origin[0]).max() < POSE_TOL
    assert np.abs(R - fr.R[0]).max() < POSE_TOL
    assert np.abs(mech.inverse(home[None])[0] - q).max() > 1e-3   # the servos had to move
