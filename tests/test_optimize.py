"""The optimizer: the paper's GA operators, the problem, the weighted sum, fronts."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from pymoo.core.population import Population
from pymoo.core.problem import Problem
from scipy import stats

from optdesign.config import load_config
from optdesign.evaluate import Evaluator, evaluate, workspace_of
from optdesign.optimize.operators import (AdaptiveGaussianMutation, ArithmeticCrossover, RouletteSelection,
                                          roulette_fitness)
from optdesign.optimize.algorithms import build_algorithm
from optdesign.optimize.problem import DesignProblem, index_term, normalized_terms

DATA = Path(__file__).parent / "data"


class _Box(Problem):
    def __init__(self, xl, xu):
        super().__init__(n_var=len(xl), n_obj=1, xl=np.asarray(xl, float), xu=np.asarray(xu, float))


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 40), st.integers(0, 2**31 - 1))
def test_children_stay_inside_bounds(n_var, n_mat, seed):
    rng = np.random.default_rng(seed)
    xl = rng.uniform(-5, 0, n_var)
    xu = xl + rng.uniform(1e-3, 5, n_var)
    prob = _Box(xl, xu)
    parents = rng.uniform(xl, xu, (2, n_mat, n_var))
    kids = ArithmeticCrossover(prob=1.0)._do(prob, parents, random_state=rng)
    assert kids.shape == (2, n_mat, n_var)
    assert np.all(kids >= xl - 1e-12) and np.all(kids <= xu + 1e-12)
    mut = AdaptiveGaussianMutation(prob=1.0, initial_scale=0.5)
    Y = mut._do(prob, kids.reshape(-1, n_var), random_state=rng)
    assert np.all(Y >= xl) and np.all(Y <= xu)


def test_arithmetic_crossover_is_a_convex_combination():
    rng = np.random.default_rng(0)
    prob = _Box([0, 0], [1, 1])
    P = rng.uniform(0, 1, (2, 100, 2))
    C = ArithmeticCrossover()._do(prob, P, random_state=np.random.default_rng(1))
    # children sum to the parents' sum and lie on the segment between them
    assert np.allclose(C[0] + C[1], P[0] + P[1])
    d = P[1] - P[0]
    t = np.sum((C[0] - P[0]) * d, axis=1) / np.sum(d * d, axis=1)
    assert np.allclose(C[0], P[0] + t[:, None] * d)
    assert np.all((t >= 0) & (t <= 1))


def test_roulette_picks_in_proportion_to_fitness():
    F = np.array([1.0, 2.0, 3.0, 5.0, 9.0])
    fit = roulette_fitness(F, np.zeros(5), "linear")
    pop = Population.new(X=np.zeros((5, 1)), F=F[:, None], CV=np.zeros((5, 1)))
    sel = RouletteSelection("linear")
    n = 20000
    idx = sel._do(None, pop, n, 1, random_state=np.random.default_rng(42)).ravel()
    counts = np.bincount(idx, minlength=5)
    expected = n * fit / fit.sum()
    chi2, p = stats.chisquare(counts, expected)
    assert p > 0.01, (counts, expected)
    # and the best individual is chosen most often, the worst least
    assert counts.argmax() == 0 and counts.argmin() == 4


def test_roulette_infeasible_get_less_than_any_feasible():
    F = np.array([1.0, 2.0, 0.5, 3.0])
    CV = np.array([0.0, 0.0, 1.0, 0.0])
    for scaling in ("linear", "rank"):
        fit = roulette_fitness(F, CV, scaling)
        assert fit[2] < fit[[0, 1, 3]].min()
        assert np.all(fit > 0)


def test_adaptive_mutation_adapts():
    m = AdaptiveGaussianMutation(initial_scale=0.1)
    m.adapt(True)
    assert m.scale == pytest.approx(0.125)
    for _ in range(200):
        m.adapt(False)
    assert m.scale == pytest.approx(m.min_scale)


def test_paper_ga_on_pymoo_reference_problem():
    """Our GA operators, in pymoo's GA, on pymoo's own Rastrigin problem."""
    from pymoo.problems import get_problem

    prob = get_problem("rastrigin", n_var=2)
    cfg = load_config(DATA / "p4s_two_var.yaml")
    cfg.optimizer = dataclasses.replace(cfg.optimizer, algorithm="paper_ga", population=40, generations=80)
    alg, cb = build_algorithm(cfg.optimizer)
    alg.setup(prob, termination=("n_gen", 80), seed=1, verbose=False, callback=cb)
    while alg.has_next():
        alg.next()
    # global minimum 0 at the origin; local minima are >= 1 apart in value
    assert alg.opt[0].F[0] < 0.5
    assert np.all(np.abs(alg.opt[0].X) < 0.1)


def _grid_optimum(cfg):
    ra = np.linspace(0.15, 0.35, 161)
    phi = np.radians(np.linspace(50, 75, 161))
    A, P = np.meshgrid(ra, phi, indexing="ij")
    ev = evaluate(cfg, {"r_a": A.ravel(), "phi": P.ravel()})
    v = np.where(ev.reachable_fraction == 1, ev.summary["dynamic"]["mean"], np.nan)
    i = np.nanargmin(v)
    return A.ravel()[i], P.ravel()[i], v[i]


def test_ga_finds_the_grid_optimum_and_beats_random_search():
    cfg = load_config(DATA / "p4s_two_var.yaml")
    ws = workspace_of(cfg)
    ra0, phi0, f0 = _grid_optimum(cfg)
    assert 0.2 < ra0 < 0.33 and np.radians(55) < phi0 < np.radians(74)  # an interior optimum
    prob = DesignProblem(Evaluator.from_config(cfg, ws), [index_term("dynamic", "min")])
    alg, cb = build_algorithm(cfg.optimizer)
    alg.setup(prob, termination=("n_gen", cfg.optimizer.generations), seed=11, verbose=False,
              **({"callback": cb} if cb else {}))
    while alg.has_next():
        alg.next()
    best = alg.opt[0]
    n_eval = alg.evaluator.n_eval
    assert best.CV[0] <= 0
    assert best.F[0] <= f0 * (1 + 2e-3), (best.F[0], f0)
    assert abs(best.X[0] - ra0) < 0.01 and abs(best.X[1] - phi0) < np.radians(1.0)
    # random search with the same number of evaluations, several seeds: the GA is better than each
    for seed in range(5):
        Xr = np.random.default_rng(seed).uniform(prob.xl, prob.xu, (n_eval, 2))
        out = prob.evaluate(Xr, return_as_dictionary=True)
        feas = np.all(out["G"] <= 0, axis=1)
        assert best.F[0] < out["F"][feas, 0].min()


def test_infeasible_designs_are_constraints_and_never_the_optimum():
    """A workspace (z = 0.70 m) that part of the design box cannot reach: those
    designs get G > 0 (the unreachable fraction is recorded), the GA still runs,
    and the optimum it reports is feasible."""
    cfg = load_config(DATA / "p4s_small.yaml")
    far = dataclasses.replace(cfg.workspace, axes={"x": (-0.05, 0.05), "y": (-0.05, 0.05), "z": (0.70, 0.70)})
    cfg = dataclasses.replace(cfg, workspace=far)
    ws = workspace_of(cfg)
    evaluator = Evaluator.from_config(cfg, ws)
    prob = DesignProblem(evaluator, [index_term("dynamic", "min")])
    X = np.array([[0.25, 0.67, np.radians(30)], [0.21, 0.71, np.radians(35)]])
    out = prob.evaluate(X, return_as_dictionary=True)
    reach = out["G"][:, prob.constraint_names.index("reach")]
    assert reach[0] == pytest.approx(1.0)      # the before design reaches no point of this W
    assert reach[1] <= 0                        # the after design reaches all of it
    assert np.all(np.isfinite(out["F"]))        # pymoo gets numbers; feasibility is in G
    # a sample of the box: a real mix of feasible and infeasible designs
    Xs = np.random.default_rng(0).uniform(prob.xl, prob.xu, (200, 3))
    G = prob.evaluate(Xs, return_as_dictionary=True)["G"]
    feasible = np.all(G <= 0, axis=1)
    assert 0.05 < feasible.mean() < 0.95
    alg, cb = build_algorithm(cfg.optimizer)
    alg.setup(prob, termination=("n_gen", 6), seed=2, verbose=False, **({"callback": cb} if cb else {}))
    while alg.has_next():
        alg.next()
    best = alg.opt[0]
    assert best.CV[0] <= 0
    ev = evaluate(cfg, evaluator.designs(best.X[None, :]), ws)
    assert ev.reachable_fraction[0] == 1.0


def test_normalized_terms_flip_maximized_indices():
    lo = {"a": 1.0, "b": 0.1}
    hi = {"a": 3.0, "b": 0.5}
    senses = {"a": "min", "b": "max"}
    vals = {"a": np.array([1.0, 3.0]), "b": np.array([0.5, 0.1])}
    f = normalized_terms(vals, lo, hi, senses)
    assert np.allclose(f["a"], [0, 1]) and np.allclose(f["b"], [0, 1])
    lit = normalized_terms(vals, lo, hi, senses, literal=True)
    assert np.allclose(lit["b"], [1, 0])  # the literal eq. 38 rewards low stiffness


def test_the_problem_takes_any_evaluation_callable():
    """The Problem knows vectors, not mechanisms: around a plain callable (pymoo's
    own ZDT1 behind it) NSGA-II runs exactly as on pymoo's ZDT1 itself."""
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.problems import get_problem

    zdt = get_problem("zdt1", n_var=5)

    def evaluate(X):
        F = zdt.evaluate(X, return_values_of=["F"])
        return {"values": {"f1": F[:, 0], "f2": F[:, 1]}, "constraints": {}}

    ours = DesignProblem(evaluate, [index_term("f1", "min"), index_term("f2", "min")], xl=zdt.xl, xu=zdt.xu)
    assert ours.n_var == 5 and ours.n_obj == 2 and ours.n_ieq_constr == 0
    pops = []
    for prob in (zdt, ours):
        alg = NSGA2(pop_size=20)
        alg.setup(prob, termination=("n_gen", 15), seed=1, verbose=False)
        alg.run()
        pops.append(alg.pop.get("F"))
    assert pops[0].tobytes() == pops[1].tobytes()
