"""The ``constraint`` index (a chain mechanism's constraint-singularity value,
docs/lower-mobility.md) and the optimizer's ``constraint_singularity`` limit.

The reference is plain line geometry written here: a P-R-S leg constrains the
platform by a force along its revolute axis k_i through its spherical joint
b_i; the value is sigma_3 of the three wrenches (k_i, (b_i - o) x k_i / L),
each made unit (L the length scale: the farthest joint point of the reference
configuration, here the S at (R_b, 0, L)).  Three such force lines lose rank
exactly when they are coplanar and concurrent: with the S joints at
(r_p, r_p, -2 r_p) along the legs' radial directions the three lines of a
horizontal platform meet in one point, a constraint singularity that poses
approach as the platform levels out.
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from cli_helpers import run_cli_in
from scipy.spatial.transform import Rotation
from test_chain_prs3 import ANGLES, reference

from optdesign.config import load_config
from optdesign.evaluate import Evaluator, evaluate
from optdesign.mechanisms import describe

ROOT = Path(__file__).resolve().parents[1]
PRS3 = yaml.safe_load((ROOT / "configs" / "prs3.yaml").read_text())


def _value(whole, points, axes, scale):
    """sigma_3 of the unit wrenches (k_i, (b_i - o) x k_i / scale) at a whole pose (x, y, z, roll, pitch, yaw)."""
    R = Rotation.from_euler("ZYX", [whole[5], whole[4], whole[3]]).as_matrix()
    W = []
    for p, k in zip(points, axes):
        w = np.concatenate([k, np.cross(R @ p, k) / scale])
        W.append(w / np.linalg.norm(w))
    return np.linalg.svd(np.array(W), compute_uv=False)[2]


def _tangent(a):
    return np.array([-np.sin(a), np.cos(a), 0.0])


def _radial(a, r):
    return r * np.array([np.cos(a), np.sin(a), 0.0])


def test_values_against_line_geometry_at_random_poses(tmp_path):
    cfg = copy.deepcopy(PRS3)
    cfg["indices"] = {"constraint": {}, "isotropy": {"kind": "isotropy", "convention": "two_norm"}}
    f = tmp_path / "c.yaml"
    f.write_text(yaml.safe_dump(cfg))
    config = load_config(f)
    assert config.indices["constraint"].sense == "max"
    rng = np.random.default_rng(3)
    X = np.column_stack([rng.uniform(0.18, 0.32, 25), rng.uniform(-0.3, 0.3, 25), rng.uniform(-0.3, 0.3, 25)])
    mech = config.mechanism_class(**{**config.parameters, **config.design("reference")})
    scale = np.hypot(0.20, 0.30)
    assert mech.chain_constants.length == pytest.approx(scale, rel=1e-15)
    ref = []
    for x in X:
        _, (px, py, yaw) = reference(x)
        ref.append(_value([px, py, x[0], x[1], x[2], yaw], [_radial(a, 0.10) for a in ANGLES],
                          [_tangent(a) for a in ANGLES], scale))
    got = mech.state(X).matrices({"C"})["C"]
    assert np.max(np.abs(got - ref)) < 1e-14
    assert np.max(np.abs(mech.constraint_singularity(X) - ref)) < 1e-14
    # the config's index: its mean and minimum over the grid are those of the local values
    ev = evaluate(config, [config.design("reference")], keep_local=True)
    loc = ev.local["constraint"][0]
    assert np.all(np.isfinite(loc)) and np.isclose(ev.summary["constraint"]["min"][0], loc.min(), rtol=0, atol=0)
    grid = ev.workspace.X
    mine = mech.constraint_singularity(grid)
    assert np.max(np.abs(loc - mine)) == 0.0
    assert 0.45 < loc.min() < loc.max() < 0.47


@pytest.fixture(scope="module")
def concurrent():
    """The 3-PRS with its third leg at 150 deg (rail and S joint at R_b = 2 r_p: its rod vertical at the
    reference): at a horizontal platform the three constraint lines meet in one point.  Home is tilted
    (pitch 0.3 rad) so the home configuration is regular."""
    raw = copy.deepcopy(PRS3["mechanism"])
    raw["name"] = "prs3_concurrent"
    raw["pose"]["home"] = {"z": 0.25, "pitch": 0.3}
    leg = raw["legs"][0]
    leg["pattern"] = {"angles": [90, 210], "unit": "deg"}
    raw["legs"].append({**copy.deepcopy(leg), "pattern": {"angles": [150], "unit": "deg"},
                        "platform": ["2 * r_p", 0, 0], "actuator": "s"})
    return describe(raw, label="prs3_concurrent")(R_b=0.2, r_p=0.1, L=0.3)


def test_a_constraint_singularity_gives_zero(concurrent):
    m = concurrent
    assert m.mobility()["mobility"] == 3
    a = np.radians([90.0, 210.0, 150.0])
    points = [_radial(a[0], 0.1), _radial(a[1], 0.1), _radial(a[2], 0.2)]
    axes = [_tangent(t) for t in a]
    pitch = np.array([0.3, 0.1, 1e-2, 1e-3])
    X = np.column_stack([np.full(4, 0.25), np.zeros(4), pitch])
    c = m.constraint_singularity(X)
    whole = m.whole_pose(X)
    for i in range(4):
        o, R = whole[i, :3], Rotation.from_euler("ZYX", whole[i, [5, 4, 3]]).as_matrix()
        A = [_radial(t, 0.2) for t in a]
        assert max(abs((o + R @ p - A_i) @ k) for p, A_i, k in zip(points, A, axes)) < 1e-14  # the rods' planes
        assert abs(c[i] - _value(whole[i], points, axes, np.hypot(0.2, 0.3))) < 1e-14
    # it vanishes linearly as the platform levels out (the lines become coplanar and meet)
    assert c[3] < 3e-4
    assert np.allclose(c[1:] / pitch[1:], c[1] / pitch[1], rtol=2e-3)
    assert np.all(m.reachable(X))


def test_the_kind_is_refused_without_chain_legs(tmp_path):
    for name in ("sps_s_legs.yaml", "p4s_paper.yaml"):
        cfg = yaml.safe_load((ROOT / "configs" / name).read_text())
        cfg["indices"]["c"] = {"kind": "constraint"}
        (tmp_path / "x.yaml").write_text(yaml.safe_dump(cfg))
        rc, out, err = run_cli_in(tmp_path, ["validate-config", "x.yaml"])
        assert rc == 2 and err.count("\n") == 1, (rc, err)
        assert err.startswith("optdesign: error: x.yaml: indices.c.kind: index 'constraint' reads the "
                              "constraint-singularity value of chain legs"), err
        del cfg["indices"]["c"]
        cfg.setdefault("optimizer", {})["constraint_singularity"] = 0.1
        (tmp_path / "x.yaml").write_text(yaml.safe_dump(cfg))
        rc, out, err = run_cli_in(tmp_path, ["validate-config", "x.yaml"])
        assert rc == 2 and err.count("\n") == 1, (rc, err)
        assert err.startswith("optdesign: error: x.yaml: optimizer.constraint_singularity: the "
                              "constraint-singularity value is a chain mechanism's"), err


def test_the_optimizer_limit(tmp_path):
    cfg = yaml.safe_load((ROOT / "configs" / "prs3_opt.yaml").read_text())
    cfg["optimizer"]["constraint_singularity"] = 0.3
    cfg["workspace"] = {**PRS3["workspace"], "points_per_axis": 3}
    f = tmp_path / "o.yaml"
    f.write_text(yaml.safe_dump(cfg))
    config = load_config(f)
    ev = Evaluator.from_config(config)
    assert ev.constraint_names[-1] == "constraint_singularity"
    assert ev.requests_all[-1].kind == "constraint"          # hidden: the config has no constraint index
    X = np.stack([ev.vector({"R_b": 0.20, "r_p": r_p, "L": 0.30}) for r_p in (0.10, 0.05)])
    res = ev(X, worst_case=False)
    got = res["constraints"]["constraint_singularity"]
    for i, row in enumerate(X):
        mech = config.mechanism_class(**{**config.parameters, **dict(zip(ev.free, row))})
        cmin = np.min(mech.constraint_singularity(ev.workspace.X))
        assert got[i] == pytest.approx(1.0 - cmin / (0.3 * (1.0 + config.optimizer.constraint_margin)), abs=1e-14)
    # a larger platform keeps the constraint lines farther apart: the reference design is feasible, the small one not
    assert got[0] < 0 < got[1]
    # the polish's difference route carries it: a larger platform moves the design away from the limit
    from optdesign.gradients import derivatives

    ev.worst_case = False
    d = derivatives(ev, X[:1], route="fd")
    assert d.constraints["constraint_singularity"][0, 0] == pytest.approx(got[0], abs=1e-15)
    g = d.constraint_grads["constraint_singularity"][0, 0]
    assert g[ev.free.index("r_p")] < 0 < g[ev.free.index("R_b")]
