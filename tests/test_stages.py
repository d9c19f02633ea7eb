"""The stage plan (optimize/pipeline.py) for the shipped configs and edited ones.

What the plan must be follows from the paper's procedure (section 3.4): two
single-objective runs (minimum, maximum) per weighted index, the weighted sum,
the literal eq. 38 when an index is maximized, and a Pareto run per algorithm
the config names when there are two objectives or more; before them the
pre-scan of the box (unless ``optimizer.prescan`` is 0) that seeds them.  Each stage's problem
and algorithm are checked against the config they come from.
"""
from __future__ import annotations

from pathlib import Path

import pytest
from conftest import DATA, PAPER, edited_text, shipped_optimizations
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.algorithms.moo.nsga3 import NSGA3
from pymoo.algorithms.soo.nonconvex.de import DE
from pymoo.algorithms.soo.nonconvex.ga import GA

from optdesign.config import load_config, parse_config
from optdesign.evaluate import Evaluator, workspace_of
from optdesign.optimize.algorithms import reference_directions
from optdesign.optimize.pipeline import prescan_size, stage_plan, stage_problem, stage_seed

ALG = {"paper_ga": GA, "pymoo_ga": GA, "de": DE}


def _plan(cfg):
    """The plan of a config's run: its optimizer section and its indices' senses (what the runner hands down)."""
    return stage_plan(cfg.optimizer, {k: s.sense for k, s in cfg.indices.items()})
OPTIMIZATION_CONFIGS = list(shipped_optimizations())


def test_the_paper_plan():
    names = [s.name for s in _plan(load_config(PAPER))]
    assert names == ["prescan", "single_dynamic_min", "single_dynamic_max", "single_stiffness_min", "single_stiffness_max",
                     "single_isotropy_min", "single_isotropy_max", "extremes", "weighted_sum", "weighted_sum_literal",
                     "pareto_nsga2", "pareto_nsga3"]


@pytest.mark.parametrize("path", OPTIMIZATION_CONFIGS + [DATA / "p4s_tiny.yaml", DATA / "p4s_tradeoff_small.yaml"],
                         ids=lambda p: Path(p).name)
def test_plan_follows_the_config(path):
    cfg = load_config(path)
    opt = cfg.optimizer
    plan = _plan(cfg)
    weighted = [k for k in cfg.indices if opt.weights.get(k, 0) > 0]
    assert [s.name for s in plan if s.kind == "prescan"] == (["prescan"] if prescan_size(opt) > 0 else [])
    singles = [s for s in plan if s.kind == "single"]
    assert [(s.index, s.sense) for s in singles] == [(k, m) for k in weighted for m in ("min", "max")]
    assert [s.name for s in plan if s.kind == "weighted"] == (
        ["weighted_sum", "weighted_sum_literal"] if any(cfg.indices[k].sense == "max" for k in weighted)
        else ["weighted_sum"])
    n_obj = len(cfg.indices) + len(opt.extra_objectives)
    assert [s.algorithm for s in plan if s.kind == "pareto"] == (list(opt.pareto_algorithms) if n_obj >= 2 else [])
    # the weighted sums come after every single run, the fronts last (the order stages are taken in)
    kinds = [s.kind for s in plan]
    assert kinds == sorted(kinds, key=["prescan", "single", "extremes", "weighted", "pareto"].index)
    # the seed-free multi-start of the extremes: with the polish only
    assert kinds.count("extremes") == int(bool(weighted) and opt.polish > 0 and opt.extremes_starts > 0)
    assert len({s.name for s in plan}) == len(plan)
    seeds = [stage_seed(opt.seed, i) for i in range(len(plan))]
    assert len(set(seeds)) == len(seeds) and all(0 <= s < 2 ** 32 for s in seeds)

    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    lo = {k: 1.0 for k in weighted}
    hi = {k: 2.0 for k in weighted}
    for st in plan:
        if st.kind in ("prescan", "extremes"):
            continue
        prob, gens, factory = stage_problem(cfg.optimizer, st, lo, hi, ev)
        alg, cb = factory()
        assert prob.n_var == len(cfg.free_variables) and list(prob.xl) == list(ev.xl)
        assert prob.constraint_names == ev.constraint_names
        if st.kind == "single":
            (t,) = prob.terms
            assert (t.kind, t.name, t.sign) == ("index", st.index, 1.0 if st.sense == "min" else -1.0)
            assert gens == opt.generations and type(alg) is ALG[opt.algorithm] and alg.pop_size == opt.population
        elif st.kind == "weighted":
            (t,) = prob.terms
            assert t.kind == "weighted" and t.literal == st.literal
            assert list(t.weights) == weighted and t.weights == {k: opt.weights[k] for k in weighted}
            assert gens == opt.generations and type(alg) is ALG[opt.algorithm]
        else:
            assert prob.n_obj == n_obj and gens == opt.pareto_generations
            assert [t.label() for t in prob.terms][:len(cfg.indices)] == [
                ("-" if s.sense == "max" else "") + k for k, s in cfg.indices.items()]
            assert [t.name for t in prob.terms][len(cfg.indices):] == list(opt.extra_objectives)
            if st.algorithm == "nsga2":
                assert type(alg) is NSGA2 and alg.pop_size == opt.pareto_population
            else:
                assert type(alg) is NSGA3 and alg.pop_size >= len(reference_directions(n_obj, opt.pareto_population)) >= opt.pareto_population
        # the paper GA's adaptive mutation comes with its callback; the other algorithms need none
        assert (cb is not None) == (st.kind != "pareto" and opt.algorithm == "paper_ga")


def test_an_index_of_weight_zero_gets_no_single_run_but_stays_a_front_objective():
    text = edited_text(PAPER.read_text(), {"weights: {dynamic: 1, stiffness: 1, isotropy: 1}":
                                           "weights: {dynamic: 1, stiffness: 1, isotropy: 0}"})
    cfg = parse_config(text, source="w0.yaml")
    plan = _plan(cfg)
    assert not [s for s in plan if s.index == "isotropy"]
    pareto = [s for s in plan if s.kind == "pareto"]
    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    prob, _, _ = stage_problem(cfg.optimizer, pareto[0], {"dynamic": 1.0, "stiffness": 1.0}, {"dynamic": 2.0, "stiffness": 2.0}, ev)
    assert [t.label() for t in prob.terms] == ["dynamic", "-stiffness", "isotropy"]
    w, = [prob for st in plan if st.name == "weighted_sum"
          for prob in [stage_problem(cfg.optimizer, st, {"dynamic": 1.0, "stiffness": 1.0}, {"dynamic": 2.0, "stiffness": 2.0}, ev)[0]]]
    assert set(w.terms[0].weights) == {"dynamic", "stiffness"}


def test_one_minimized_index_no_literal_stage_and_no_front():
    text = edited_text((DATA / "p4s_tiny.yaml").read_text(), {"indices: {dynamic: {}, stiffness: {}}": "indices: {dynamic: {}}"})
    plan = _plan(parse_config(text, source="one.yaml"))
    assert [s.name for s in plan] == ["prescan", "single_dynamic_min", "single_dynamic_max", "extremes", "weighted_sum"]


def test_the_optimizer_layer_knows_vectors_not_mechanisms():
    """optimize/ never imports a mechanism, the CLI, the commands or the config
    (it is handed plain pieces); the problem, the algorithms, the checkpoints
    and the stage loop not even the evaluator's module."""
    import ast

    pkg = Path(__file__).resolve().parents[1] / "optdesign" / "optimize"
    for path in sorted(pkg.glob("*.py")):
        names = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                mod = node.module or ""
                names.add(("." * node.level + mod) if node.level else mod)
            elif isinstance(node, ast.Import):
                names.update(a.name for a in node.names)
        absolute = {n.replace("..", "optdesign.", 1).lstrip(".") if n.startswith("..") else n for n in names}
        assert not {n for n in absolute if n.startswith(("optdesign.mechanisms", "optdesign.cli", "optdesign.commands",
                                                         "optdesign.config"))}, path
        if path.stem in ("problem", "algorithms", "checkpoint", "stage", "workers", "progress", "operators"):
            assert not {n for n in absolute if n.startswith("optdesign.evaluate")}, path
