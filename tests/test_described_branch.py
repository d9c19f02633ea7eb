"""The crank branch of revolute legs is settled per design at the home pose
(the sign of sigma = k . (w x A)), so it is continuous over the workspace and
never left to round-off; a description whose `outer`/`inner` is not defined
at home (a 6-RUS with radial motor axes and tangential cranks: both crank tips
equally far from the base origin) is refused at load, naming the leg's `branch`."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from optdesign.config import load_config, parse_config

from cli_helpers import run_main
from conftest import ROOT
from described_helpers import Rz, layout


def _rus6(branch: str, radial: bool = True) -> dict:
    """A 6-RUS (spatial pose): motor axes radial (through the base origin) and
    cranks tangential at q = 0, rods chosen so that every leg closes at home."""
    legs, home = layout("revolute", "spatial", 6)
    for i, leg in enumerate(legs):
        A = np.array(leg["base"])
        ab = np.arctan2(A[1], A[0])
        k = Rz(ab) @ ([1.0, 0, 0] if radial else [0, 1.0, 0])
        r0 = Rz(ab) @ ([0, 1.0, 0] if radial else [1.0, 0, 0])
        leg["axis"], leg["reference"] = [float(v) for v in k], [float(v) for v in r0]
        b = home[:3] + np.array(leg["platform"])
        w = b - A
        phi0 = np.arctan2(w @ np.cross(k, r0), w @ r0)
        q0 = phi0 + 1.2 + 0.02 * i
        a = A + 0.2 * (np.cos(q0) * r0 + np.sin(q0) * np.cross(k, r0))
        leg["rod"] = float(np.linalg.norm(b - a))
        leg["branch"] = branch
    desc = {"name": "rus6", "parameters": {"unused": {"kind": "number", "default": 1.0}},
            "pose": {"type": "spatial", "home": dict(zip(["x", "y", "z", "roll", "pitch", "yaw"],
                                                          [float(v) for v in home]))},
            "legs": legs}
    axes = {n: [float(h) - 0.02, float(h) + 0.02] for n, h in zip(["x", "y", "z", "roll", "pitch", "yaw"], home)}
    return {"mechanism": desc, "design_variables": {"unused": 1.0},
            "workspace": {"type": "box", "axes": axes, "sampling": "sobol", "points": 16},
            "indices": {"iso": {"kind": "isotropy"}}}


@pytest.mark.parametrize("branch", ["outer", "inner"])
def test_the_ambiguous_6rus_is_refused_naming_the_branch(tmp_path, capsys, branch):
    f = tmp_path / "rus6.yaml"
    f.write_text(yaml.safe_dump(_rus6(branch), sort_keys=False))
    rc, out, err = run_main(capsys, ["validate-config", str(f)])
    assert rc == 2 and out == ""
    (line,) = err.strip().splitlines()
    assert line.startswith(f"optdesign: error: {f}: mechanism.legs[0].branch: {branch!r} is not defined for leg q1 "
                           "(design 'initial')"), line
    assert "equally far from the base origin" in line and "give branch: plus or minus" in line


def test_the_same_6rus_with_plus_or_tangential_axes_loads():
    for cfg in (_rus6("plus"), _rus6("minus"), _rus6("outer", radial=False)):
        parse_config(yaml.safe_dump(cfg, sort_keys=False), source="rus6.yaml")


def test_a_pose_where_round_off_could_flip_the_branch_keeps_it():
    """A Delta (tangential motor axes) with short rods reaches the plane of the
    motor axes, z = 0, where the two crank tips are equally far from the base
    origin: comparing them per pose let a perturbation of 1e-15 pick the other
    root (a jump of the crank angle).  Settled at home, the elbow-out root is
    kept on both sides, continuous (the numpy path; the compiled one takes the
    same settled root, tests/test_described_compiled.py)."""
    cfg = load_config(ROOT / "configs" / "delta.yaml")
    mech = cfg.mechanism_class(R=0.2, r=0.05, L_a=0.25, L_b=0.35)
    X = np.array([[0.01, 0.02, z] for z in (-1e-15, 0.0, 1e-15, -1e-3, 1e-3)] + [[0.0, 0.0, -0.55]])
    Q = mech.inverse(X)
    assert np.all(np.isfinite(Q))
    np.testing.assert_allclose(Q[0], Q[2], atol=1e-12)
    np.testing.assert_allclose(Q[1], Q[2], atol=1e-12)
    assert np.max(np.abs(Q[3] - Q[4])) < 0.05              # continuous across z = 0
    # the root is the home pose's elbow-out one: the tip farther from the origin at home
    st = mech.leg_state(X[-1:])
    tips = st["a"][0]
    C = mech.constants
    for i in range(3):
        k, r0, s0, A = C.U[i], C.R0[i], C.S0[i], C.A[i]
        w = X[-1] + C.P[i] - A
        phi0 = np.arctan2(w @ s0, w @ r0)
        other = [A + 0.25 * (np.cos(q) * r0 + np.sin(q) * s0) for q in (Q[-1, i], 2 * phi0 - Q[-1, i])][1]
        assert tips[i] @ tips[i] > other @ other
    # a perturbation of the design by 1e-15 keeps the branch too
    Q2 = cfg.mechanism_class(R=0.2 + 1e-15, r=0.05, L_a=0.25, L_b=0.35).inverse(X)
    np.testing.assert_allclose(Q2, Q, atol=1e-12)
