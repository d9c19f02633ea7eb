"""Designs and poses at and near singularities and at the edge of reachability.

For the 3-P(4S) a branch is singular when its rod is perpendicular to its
rail (n_i . m_i = 0); that is also where the two inverse-kinematics roots meet,
so the singularity is the edge of the reachable region.  We build poses that
lie exactly on it (s = 0 to the last bit), just inside and just outside, and
random designs including degenerate ones (phi = 0 or 90 deg, d = 2 r_a, short
rods), and check with every warning turned into an error that

* ``evaluate()`` gives, for each design and index, a finite mean, or ``inf``
  for an index to be minimized whose workspace meets a singularity, or NaN
  only together with the explicit flag ``reachable_fraction == 0``;
* local values at an exactly singular pose are ``inf`` (minimized indices)
  or ``0`` (maximized ones), never NaN;
* the optimization problem turns every non-finite index into a finite
  objective and a violated constraint;
* ``evaluate``, ``ik``, ``fk`` and ``atlas`` print no warning and do not crash.
"""
from __future__ import annotations

import copy
import warnings

import numpy as np
import pytest
import yaml
from hypothesis import given, settings, strategies as st

from optdesign.evaluate import build
from optdesign.config import load_config, parse_config
from optdesign.evaluate import Evaluator, evaluate, workspace_of
from optdesign.mechanisms.p4s import E, P4S, Z
from optdesign.workspace import Workspace

from cli_helpers import run_cli_in
from conftest import load_paper_config, paper_data

CFG = load_paper_config()
ALL_INDICES = {"dynamic": {"kind": "dynamic"}, "stiffness": {"kind": "stiffness"},
               "isotropy": {"kind": "isotropy"}, "isotropy2": {"kind": "isotropy", "convention": "two_norm"},
               "stiff_sqrt": {"kind": "stiffness", "convention": "sqrt_lambda_min_K"},
               "dexterity": {"kind": "dexterity"}, "manipulability": {"kind": "manipulability"},
               "driving": {"kind": "driving"}}


def _config_with_all_indices():
    raw = paper_data()
    raw["indices"] = copy.deepcopy(ALL_INDICES)
    raw.pop("reference", None)
    raw["optimizer"].pop("weights", None)
    return parse_config(yaml.safe_dump(raw), source="all_indices.yaml")


CFG_ALL = _config_with_all_indices()


def singular_poses(mech: P4S, branch: int, strokes) -> np.ndarray:
    """Platform positions with rod ``branch`` exactly perpendicular to its rail:
    the rod leaves the slider along ``sin(phi) e_i + cos(phi) z`` (n . m = 0)."""
    kw = {k: float(v) for k, v in mech.params.items()}
    phi, L, r_b = kw["phi"], kw["L"], kw["r_b"]
    rho = float(mech.rho)
    m = -np.cos(phi) * E[branch] + np.sin(phi) * Z
    n = np.sin(phi) * E[branch] + np.cos(phi) * Z
    return np.array([(r_b - rho) * E[branch] + q * m + L * n for q in strokes])


def _workspace(X) -> Workspace:
    return Workspace(CFG_ALL.workspace, ("x", "y", "z"), np.asarray(X, float))


def check_evaluation(cfg, ev) -> None:
    """The invariants of the module docstring on one Evaluation."""
    frac = ev.reachable_fraction
    assert np.all((frac >= 0) & (frac <= 1))
    for name, spec in cfg.indices.items():
        mean = ev.summary[name]["mean"]
        for stat in ("min", "max", "mean"):
            v = ev.summary[name][stat]
            # NaN only as the explicit 'nothing reachable' flag
            assert np.all(np.isnan(v) == (frac == 0)), (name, stat, v, frac)
        ok = ~np.isnan(mean)
        assert np.all(mean[ok] >= 0), (name, mean)
        if spec.sense == "max":
            assert np.all(np.isfinite(mean[ok])), (name, mean)
        else:
            assert not np.any(np.isneginf(mean)), (name, mean)
        if ev.local is not None:
            loc = ev.local[name]
            assert not np.any(np.isnan(loc) & ev.reachable), name


@pytest.fixture(autouse=True)
def _warnings_are_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


@pytest.mark.parametrize("design", ["before", "after"])
@pytest.mark.parametrize("branch", [0, 1, 2])
def test_exactly_singular_poses(design, branch):
    mech = build(CFG_ALL, design)
    X = singular_poses(mech, branch, np.linspace(0.25, 0.6, 8))
    with np.errstate(all="ignore"):          # only to pick the test poses
        st_ = mech.branch_state(X)
    s = st_["s"][:, branch]
    reach = st_["reachable"]
    assert reach.sum() >= 2                              # some are reachable by the other branches
    # the construction puts the rod at n.m = 0 up to round-off
    assert np.nanmax(np.abs(s)) < 1e-7
    ev = evaluate(CFG_ALL, [CFG_ALL.design(design)], _workspace(np.vstack([X, [[0.0, 0.0, 0.57]]])), keep_local=True)
    check_evaluation(CFG_ALL, ev)
    exact = np.append(reach & (s == 0), False)
    if design == "before":
        assert exact.any()                               # s == 0 to the last bit somewhere
    for name, spec in CFG_ALL.indices.items():
        loc = ev.local[name][0]
        if exact.any():
            want = np.inf if spec.sense == "min" else 0.0
            assert np.all(loc[exact] == want), (name, loc[exact])
        assert np.isfinite(loc[-1])                      # the regular centre pose
        if spec.sense == "min":
            assert ev.summary[name]["max"][0] > 1e6      # the singular poses dominate
        assert ev.summary[name]["count"][0] == reach.sum() + 1


@pytest.mark.parametrize("eps", [1e-15, 1e-12, 1e-9, 1e-6, 1e-3])
def test_just_inside_and_just_outside_the_edge(eps):
    """Moving an exactly singular pose along the rod (outward) leaves the
    reachable region; moving it inward enters it with a large but finite
    condition number."""
    mech = build(CFG_ALL, "before")
    X0 = singular_poses(mech, 0, [0.5])[0]
    n = np.sin(float(mech.phi)) * E[0] + np.cos(float(mech.phi)) * Z
    X = np.array([X0 + eps * n, X0 - eps * n, [0.0, 0.0, 0.57]])
    ev = evaluate(CFG_ALL, [CFG_ALL.design("before")], _workspace(X), keep_local=True)
    check_evaluation(CFG_ALL, ev)
    assert not ev.reachable[0, 0]                        # outside: flagged, left out of the means
    assert ev.reachable[0, 1] and ev.reachable[0, 2]
    for name in ("isotropy", "dynamic"):
        assert ev.local[name][0, 1] > ev.local[name][0, 2]
    assert ev.summary["isotropy"]["count"][0] == 2


def test_nothing_reachable_is_flagged_and_infeasible():
    from optdesign.optimize.problem import DesignProblem, index_term

    far = np.array([[0.0, 0.0, 5.0], [3.0, 0.0, 0.57]])
    ev = evaluate(CFG, [CFG.design("before"), CFG.design("after")], _workspace(far))
    check_evaluation(CFG, ev)
    assert np.all(ev.reachable_fraction == 0)
    assert all(np.all(np.isnan(ev.summary[k]["mean"])) for k in CFG.indices)
    prob = DesignProblem(Evaluator.from_config(CFG, _workspace(far)), [index_term(k, s.sense) for k, s in CFG.indices.items()])
    out = prob.evaluate(np.array([[0.25, 0.67, np.radians(30)]]), return_values_of=["F", "G"])
    F, G = out
    assert np.all(np.isfinite(F)) and np.all(np.isfinite(G))
    assert G.max() > 0


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_random_and_degenerate_designs(data):
    """Populations of random designs, with degenerate values mixed in, over the
    paper's workspace plus random poses."""
    D = 6
    draw = data.draw
    r_a = np.array(draw(st.lists(st.sampled_from([0.21, 0.25, 0.5]) | st.floats(0.01, 1.0), min_size=D, max_size=D)))
    frac_d = np.array(draw(st.lists(st.sampled_from([0.0, 0.5, 1.0 - 1e-15]) | st.floats(0.0, 0.999), min_size=D, max_size=D)))
    designs = {
        "r_a": r_a,
        "r_b": np.array(draw(st.lists(st.sampled_from([0.67, 0.71]) | st.floats(0.01, 2.0), min_size=D, max_size=D))),
        "L": np.array(draw(st.lists(st.sampled_from([0.38, 1e-3]) | st.floats(0.01, 2.0), min_size=D, max_size=D))),
        "d": 2 * r_a * frac_d,
        "phi": np.array(draw(st.lists(st.sampled_from([0.0, np.pi / 2, np.radians(30), 1e-9]) | st.floats(0.0, np.pi / 2),
                                      min_size=D, max_size=D))),
    }
    extra = np.array(draw(st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-0.5, 1.5)),
                                   min_size=0, max_size=20)), dtype=float).reshape(-1, 3)
    X = np.vstack([workspace_of(CFG_ALL).X, extra])
    ev = evaluate(CFG_ALL, designs, _workspace(X), keep_local=True)
    check_evaluation(CFG_ALL, ev)


def test_problem_flags_designs_at_the_corner_of_the_bounds():
    """The optimizer's view: designs at the corners of the paper bounds and a
    population that mixes hostile designs give finite objectives, and a
    design whose indices are not finite violates a constraint."""
    from optdesign.optimize.problem import DesignProblem, index_term

    ws = workspace_of(CFG)
    evaluator = Evaluator.from_config(CFG, ws)
    prob = DesignProblem(evaluator, [index_term(k, s.sense) for k, s in CFG.indices.items()])
    corners = np.array([[a, b, np.radians(p)] for a in (0.21, 0.29) for b in (0.63, 0.71) for p in (25, 35)])
    hostile = np.array([[0.21, 0.71, 1e-9], [0.29, 0.63, np.pi / 2], [0.06, 0.63, np.radians(30)],
                        [0.21, 5.0, np.radians(30)]])
    Xd = np.vstack([corners, hostile])
    F, G = prob.evaluate(Xd, return_values_of=["F", "G"])
    assert np.all(np.isfinite(F)) and np.all(np.isfinite(G))
    vals = evaluator(Xd)["values"]
    bad = ~np.all(np.isfinite(np.stack(list(vals.values()), axis=-1)), axis=-1)
    assert np.all(G[bad].max(axis=-1) > 0)


# ----------------------------------------------------------------------------- commands
def test_commands_at_the_edge_of_reachability(tmp_path, write_yaml):
    """A workspace that runs past the reach of the designs (z up to 0.9 m) and
    poses exactly at a singularity: no warning, no traceback."""
    raw = paper_data()
    raw["workspace"] = {"type": "box", "axes": {"x": [-0.3, 0.3], "y": 0.0, "z": [0.3, 0.9]},
                        "sampling": "grid", "points_per_axis": 13}
    write_yaml(raw, "edge.yaml")
    rc, out, err = run_cli_in(tmp_path, ["evaluate", "edge.yaml", "--json"])
    assert rc == 0 and err == ""
    import json

    res = json.loads(out)
    for name, rec in res["designs"].items():
        assert 0 < rec["reachable_fraction"] < 1
    rc, out, err = run_cli_in(tmp_path, ["atlas", "edge.yaml", "--design", "before", "--no-plots", "--resolution", "9"])
    assert rc == 0 and err == ""
    mech = build(CFG, "before")
    X = singular_poses(mech, 0, [0.3])[0]
    rc, out, err = run_cli_in(tmp_path, ["ik", "edge.yaml", "--design", "before", *map(repr, X.tolist())])
    assert rc == 0 and err == "" and "l1" in out
    rc, out, err = run_cli_in(tmp_path, ["ik", "edge.yaml", "--design", "before", "0", "0", "5"])
    assert rc == 1 and err == "" and "unreachable" in out
    rc, out, err = run_cli_in(tmp_path, ["fk", "edge.yaml", "--design", "before", "0", "0", "5"])
    assert rc in (0, 1) and err == ""


@pytest.mark.slow
def test_no_nan_reaches_the_optimum(tmp_path):
    """A small optimization over bounds full of unreachable and singular
    designs (rails from 1 to 89 deg, base radius from 0.2 to 1.2 m): the
    optimum is a feasible design with finite indices."""
    from optdesign.runner import start_run

    text = """\
mechanism: p4s
name: hostile_bounds
design_variables:
  r_a: {value: 0.25, bounds: [0.05, 0.6]}
  r_b: {value: 0.67, bounds: [0.2, 1.2]}
  L: 0.38
  d: 0.08
  phi: {value: 30, bounds: [1, 89], unit: deg}
workspace: {type: box, axes: {x: [-0.05, 0.05], y: [-0.05, 0.05], z: 0.57}, sampling: grid, step: 0.05}
indices: {dynamic: {}, stiffness: {}, isotropy: {}}
optimizer: {population: 12, generations: 4, elites: 2, seed: 5}
"""
    (tmp_path / "h.yaml").write_text(text)
    cfg = load_config(tmp_path / "h.yaml")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = start_run(cfg, seed=5, out=tmp_path / "runs", pareto=False).results
    design = {k: np.array([v]) for k, v in res["optimum"].items()}
    ev = evaluate(cfg, design)
    assert ev.reachable_fraction[0] == 1.0
    for k in cfg.indices:
        assert np.isfinite(res["global_indices"][k])
        assert res["global_indices"][k] == pytest.approx(float(ev.summary[k]["mean"][0]), rel=1e-9)
    assert np.isfinite(res["objective"])
    # the bounds really are hostile: many sampled designs cannot reach W
    rng = np.random.default_rng(0)
    sample = {"r_a": rng.uniform(0.05, 0.6, 200), "r_b": rng.uniform(0.2, 1.2, 200),
              "phi": np.radians(rng.uniform(1, 89, 200))}
    frac = evaluate(cfg, sample).reachable_fraction
    assert (frac < 1).mean() > 0.3
    # and the run warned about nothing
    assert not caught, [f"{w.category.__name__}: {str(w.message)[:200]}" for w in caught]
