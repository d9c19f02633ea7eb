"""Our 3-P(4S) dynamics against MuJoCo, an independent multibody engine.

(a) rigid inverse dynamics: MuJoCo's open-tree forces projected through the
loop-closure Jacobian equal our actuator forces to 1e-8 of the peak force;
(b) MuJoCo's simulation driven by our forces follows the commanded path to
a fraction of a micrometre.  Both checks are shown to catch a 1% error in
one mass property.
"""
import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

mujoco = pytest.importorskip("mujoco")

from optdesign.mechanisms.p4s import P4S  # noqa: E402
from optdesign.mechanisms.p4s.mujoco import (  # noqa: E402
    P4SModel, inverse_dynamics, large_trajectory, paper_trajectory, simulate,
)

from conftest import load_paper_config  # noqa: E402

REL_TOL = 1e-8          # inverse dynamics: of the peak force
TRACK_PAPER_UM = 0.5    # simulation, paper path, 0.1 s (measured 0.13 um)
TRACK_LARGE_UM = 1.0    # simulation, large path, 0.3 s (measured below 0.8 um over 1 s)


def _mech(cfg, name, **change):
    kw = {**cfg.parameters, **cfg.design(name)}
    kw.update(change)
    return P4S(**kw)


@pytest.mark.parametrize("design", ["before", "after"])
@pytest.mark.parametrize("traj,t_end", [(paper_trajectory(), 0.05), (large_trajectory(), 0.5)])
def test_inverse_dynamics_matches_mujoco(paper_config, design, traj, t_end):
    mech = _mech(paper_config, design)
    X, V, A = traj(np.linspace(0.0, t_end, 17))
    r = inverse_dynamics(mech, X, V, A)
    peak = np.abs(r["ours"]).max()
    assert peak > 50.0                                   # a real load, not zeros
    assert np.abs(r["forces"] - r["ours"]).max() <= REL_TOL * peak
    # our kinematic state closes MuJoCo's loops at position, velocity and acceleration level
    assert r["loop_gap"].max() < 1e-12
    assert r["velocity_gap"].max() < 1e-12
    assert r["acceleration_gap"].max() < 1e-9
    # lambda balances every non-actuated row, including the six idle rod spins
    assert r["residual"].max() < 1e-9 * peak
    assert np.all(r["constraint_rank"] == 18)
    assert r["inverse_check"].max() < 1e-10 * peak


@settings(max_examples=15, deadline=None)
@given(r_a=st.floats(0.21, 0.29), r_b=st.floats(0.63, 0.71), phi=st.floats(25.0, 35.0),
       xy=st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05)), z=st.floats(0.52, 0.62),
       v=st.tuples(*[st.floats(-1.0, 1.0)] * 3), a=st.tuples(*[st.floats(-50.0, 50.0)] * 3))
def test_inverse_dynamics_random_states(r_a, r_b, phi, xy, z, v, a):
    mech = _mech(load_paper_config(), "before", r_a=r_a, r_b=r_b, phi=np.radians(phi))
    X = np.array([[xy[0], xy[1], z]])
    assume(bool(mech.reachable(X)[0]))
    r = inverse_dynamics(mech, X, np.array([v]), np.array([a]))
    peak = np.abs(r["ours"]).max()
    assert np.abs(r["forces"] - r["ours"]).max() <= REL_TOL * max(peak, 1.0)


def test_inverse_comparison_detects_model_errors(paper_config):
    """The 1e-8 agreement is not automatic: a model with one rod per branch, or
    a rod inertia off by 1%, misses MuJoCo by far more."""
    mech = _mech(paper_config, "before")
    X, V, A = paper_trajectory()(np.linspace(0.0, 0.05, 9))
    ref = inverse_dynamics(mech, X, V, A)["forces"]
    peak = np.abs(ref).max()
    one_rod = _mech(paper_config, "before", rods_per_branch=1.0).actuator_forces(X, V, A)
    assert np.abs(one_rod - ref).max() > 0.1 * peak
    ixx = _mech(paper_config, "before", rod_Ixx=0.0223 * 1.01).actuator_forces(X, V, A)
    assert np.abs(ixx - ref).max() > 1e4 * REL_TOL * peak
    no_velocity = mech.actuator_forces(X, np.zeros_like(V), A)
    assert np.abs(no_velocity - ref).max() > 1e-4 * peak


def test_model_counts_every_body(paper_config):
    mech = _mech(paper_config, "after")
    mm = P4SModel(mech)
    m = mm.model
    assert m.nv == 6 + 3 + 6 * 3 and m.neq == 6 and m.nu == 3
    total = 4.16 + 3 * 2.57 + 6 * 1.59
    assert abs(m.body_mass.sum() - total) < 1e-12
    # the rod spin inertia cannot matter (zero spin): changing it changes nothing
    X, V, A = large_trajectory()(np.linspace(0.0, 0.3, 5))
    f1 = inverse_dynamics(mech, X, V, A)["forces"]
    f2 = inverse_dynamics(_mech(paper_config, "after", rod_Izz=5e-3), X, V, A)["forces"]
    assert np.abs(f1 - f2).max() < 1e-9 * np.abs(f1).max()


@pytest.mark.parametrize("design", ["before", "after"])
def test_simulation_tracks_paper_path(paper_config, design):
    r = simulate(_mech(paper_config, design), paper_trajectory(), 0.1)
    assert r["t"][-1] == pytest.approx(0.1)
    assert 1e6 * r["error"].max() < TRACK_PAPER_UM
    assert r["max_loop_gap"] < 1e-7
    assert r["max_rod_spin"] < 1e-9


def test_simulation_tracks_large_path(paper_config):
    r = simulate(_mech(paper_config, "after"), large_trajectory(), 0.3)
    assert 1e6 * r["error"].max() < TRACK_LARGE_UM
    # the path really moves the platform by centimetres
    assert np.ptp(r["X_ref"], axis=0).min() > 0.02


def test_simulation_detects_a_one_percent_inertia_error(paper_config):
    mech = _mech(paper_config, "before")
    wrong = _mech(paper_config, "before", rod_Ixx=0.0223 * 1.01)
    r = simulate(mech, paper_trajectory(), 0.1, force_model=wrong)
    assert 1e6 * r["error"].max() > 10 * TRACK_PAPER_UM


def test_validate_dynamics_command(tmp_path, monkeypatch, capsys):
    import json

    from optdesign.cli import main

    cfg = str(load_paper_config().source)
    monkeypatch.chdir(tmp_path)
    rc = main(["validate-dynamics", cfg, "--design", "after", "--duration", "0.02",
               "--large-duration", "0.05", "--points", "5", "--out", "v"])
    assert rc == 0
    s = json.loads((tmp_path / "v" / "summary.json").read_text())
    for path in ("paper", "large"):
        assert s["paths"][path]["max_relative_difference"] < REL_TOL
        assert s["paths"][path]["max_tracking_error_um"] < TRACK_LARGE_UM
    for f in ("forces.png", "tracking.png"):
        assert (tmp_path / "v" / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "v" / "p4s.xml"))
    assert model.neq == 6 and model.nu == 3
    assert "max diff / peak [–]" in capsys.readouterr().out
    rc = main(["validate-dynamics", cfg, "--design", "nope"])
    assert rc == 2
    assert capsys.readouterr().err.count("\n") == 1
