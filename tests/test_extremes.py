"""The seed-free extremes (optdesign.optimize.extremes) and the reported fronts.

* the extremes stage is in the plan when the polish is on, not with
  ``optimizer.polish: 0`` or ``optimizer.extremes.starts: 0``, and its key is
  validated;
* a tiny 3-P(4S) run over seeds 1-3: the normalization extremes agree to
  1e-6 relative, every normalized term of the optimum, of the named designs
  in the box and of every Pareto point lies in [0, 1], no reported front
  point is dominated by another or by a design of a grid over the box;
* NSGA-III gets at least as many reference directions as its population.
"""
from __future__ import annotations

import numpy as np
import pytest

from optdesign.config import ConfigError, parse_config
from optdesign.evaluate import Evaluator, workspace_of
from optdesign.optimize.algorithms import build_algorithm, reference_directions
from optdesign.optimize.extremes import SNAP, extremes_scan, snap
from optdesign.optimize.pipeline import stage_plan
from optdesign.optimize.problem import DesignProblem, extra_term, index_term
from optdesign.optimize.refine import non_dominated
from optdesign.runner import run_in_folder
from optdesign.runs import RunFolder

TINY = """mechanism: p4s
name: ext_tiny
design_variables:
  r_a: {value: 0.25, bounds: [0.21, 0.29]}
  r_b: {value: 0.67, bounds: [0.63, 0.71]}
  L: 0.38
  d: 0.12
  phi: {value: 30, bounds: [25, 35], unit: deg}
designs:
  before: {r_a: 0.25, r_b: 0.67, phi: 30}
workspace: {type: box, axes: {x: [-0.05, 0.05], y: [-0.05, 0.05], z: 0.57}, sampling: grid, step: 0.05}
indices: {dynamic: {}, stiffness: {}}
optimizer: {population: 8, generations: 3, elites: 2, seed: 1, checkpoint_interval: 0, prescan: 64, polish: 1,
            extremes: {starts: 2, scan: 128}, extra_objectives: [base_radius],
            pareto: {algorithms: [nsga2, nsga3], population: 8, generations: 3}}
"""


def _plan(cfg):
    return stage_plan(cfg.optimizer, {k: s.sense for k, s in cfg.indices.items()})


def _cfg(text=TINY):
    return parse_config(text, source="ext_tiny.yaml")


def test_the_extremes_stage_runs_with_the_polish_only():
    names = [s.kind for s in _plan(_cfg())]
    assert names.count("extremes") == 1 and names.index("extremes") < names.index("weighted")
    for edit in ("polish: 1", "extremes: {starts: 2, scan: 128}"):
        off = TINY.replace(edit, {"polish: 1": "polish: 0"}.get(edit, "extremes: {starts: 0}"))
        assert "extremes" not in [s.kind for s in _plan(_cfg(off))]
    with pytest.raises(ConfigError, match=r"optimizer\.extremes"):
        _cfg(TINY.replace("starts: 2,", "stars: 2,"))
    with pytest.raises(ConfigError, match=r"optimizer\.extremes\.starts"):
        _cfg(TINY.replace("starts: 2,", "starts: -1,"))


def test_the_scan_is_seed_free_and_snap_puts_near_bound_values_on_it():
    xl, xu = np.array([0.0, 1.0]), np.array([1.0, 3.0])
    a, b = extremes_scan(xl, xu, 100), extremes_scan(xl, xu, 100)
    assert np.array_equal(a, b) and len(a) == 128 + 4 + 1 and np.all((a >= xl) & (a <= xu))
    x = np.array([0.5 * SNAP, 3.0 - 2 * 0.5 * SNAP])
    assert np.array_equal(snap(x, xl, xu), [0.0, 3.0])
    y = np.array([3 * SNAP, 2.0])
    assert np.array_equal(snap(y, xl, xu), y)


@pytest.mark.parametrize("n_obj,pop", [(2, 24), (3, 80), (4, 80), (4, 200), (6, 30)])
def test_nsga3_has_a_reference_direction_per_design(n_obj, pop):
    opt = _cfg().optimizer.__class__(pareto_population=pop)
    alg, _ = build_algorithm(opt, n_obj, "nsga3")
    assert len(alg.ref_dirs) >= pop and alg.pop_size >= pop
    assert len(reference_directions(n_obj, pop)) == len(alg.ref_dirs)


def test_non_dominated_drops_points_dominated_by_the_reference():
    F = np.array([[0.0, 1.0], [1.0, 0.0], [0.5, 0.5], [0.6, 0.6]])
    assert non_dominated(F).tolist() == [0, 1, 2]
    assert non_dominated(F, np.array([[0.4, 0.4]])).tolist() == [0, 1]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for s in (1, 2, 3):
        root = tmp_path_factory.mktemp(f"ext{s}")
        f = RunFolder.create(root, f"s{s}", TINY, s, f"k{s}", exact=True)
        out[s] = run_in_folder(_cfg(), f, s, reports=False)
    return out


@pytest.mark.slow
def test_extremes_agree_over_seeds_and_every_term_is_in_unit_range(runs):
    norms = {s: r.results["normalization"] for s, r in runs.items()}
    assert "extremes" in runs[1].stages
    for k in norms[1]:
        for b in ("min", "max"):
            vals = [norms[s][k][b] for s in norms]
            assert max(vals) - min(vals) <= 1e-6 * max(abs(v) for v in vals), (k, b, vals)
    for s, r in runs.items():
        res = r.results
        lo = {k: v["min"] for k, v in res["normalization"].items()}
        hi = {k: v["max"] for k, v in res["normalization"].items()}
        points = [res["global_indices"]]
        points += [d["global_indices"] and {k: d["global_indices"][k]["mean"] for k in lo}
                   for d in res["designs"].values() if d["objective"] is not None]
        for st in r.stages.values():
            if st["kind"] == "pareto":
                points += [{k: row[k] for k in lo} for row in st["front"]]
        for p in points:
            for k in lo:
                t = (p[k] - lo[k]) / (hi[k] - lo[k])
                assert -1e-12 <= t <= 1 + 1e-12, (s, k, p[k], lo[k], hi[k])


@pytest.mark.slow
def test_no_reported_point_is_dominated_by_another_or_by_a_grid_design(runs):
    cfg = _cfg()
    ws = workspace_of(cfg)
    ev = Evaluator.from_config(cfg, ws)
    terms = [index_term(k, s.sense) for k, s in cfg.indices.items()] + [extra_term("base_radius", "min")]
    prob = DesignProblem(ev, terms)
    g = [np.linspace(a, b, 9) for a, b in zip(ev.xl, ev.xu)]
    X = np.array(np.meshgrid(*g, indexing="ij")).reshape(len(g), -1).T
    out: dict = {}
    prob._evaluate(X, out)
    grid = out["F"][np.all(out["G"] <= 0, axis=1)]
    for r in runs.values():
        for name, st in r.stages.items():
            if st["kind"] != "pareto":
                continue
            F = np.array([[row[f"objective_{t}"] for t in st["terms"]] for row in st["front"]])
            assert len(F) and non_dominated(F).tolist() == list(range(len(F))), name
            tol = 1e-9 * np.maximum(np.abs(F), 1e-12)
            dom = [np.any(np.all(grid <= f + t, axis=1) & np.any(grid < f - t, axis=1)) for f, t in zip(F, tol)]
            assert not any(dom), name
