"""The extremes of the normalization, the polish and the [0, 1] normalization,
checked against things the optimizer does not share: an exhaustive grid over
the design box (the vectorized Evaluator) and the Evaluator's own verdict on
the designs the run reports.

* configs/p4s_paper.yaml (a small GA budget; the default pre-scan and
  polish): every recorded extreme is within 1e-6 relative of the best value
  of a 41^3 grid over the box, or beyond it, and the design recorded with it
  gives that value and is feasible;
* the polished optimum and every single-objective answer are no worse than
  the GA's, feasible, and (where the polish moved them) first-order optimal:
  KKT residual below the stated tolerance (optdesign.optimize.polish.TOLERANCE);
* the Pareto polish keeps every front point feasible and dominating (or
  equal to) a design the GA found;

tests/test_normalized_terms.py checks every shipped optimization config.
"""
from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS, PAPER, edited_text

from optdesign.config import load_config, parse_config
from optdesign.evaluate import Evaluator
from optdesign.optimize.polish import TOLERANCE
from optdesign.runner import run_in_folder
from optdesign.runs import RunFolder

GRID = 41


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    """configs/p4s_paper.yaml with a small GA budget (20 x 10), pre-scan, polish and
    the multi-start of the extremes as shipped: (cfg, result).  One run for every
    test here (the polish's checks hold whatever the extremes' budget; a second
    run with a smaller multi-start cost the suite 25 s)."""
    text = edited_text(PAPER.read_text(), {"population: 50 ": "population: 20 ", "generations: 100 ": "generations: 10 "})
    cfg = parse_config(text, source=str(PAPER))
    folder = RunFolder.create(tmp_path_factory.mktemp("paper"), "paper", text, 1, "k")
    return cfg, run_in_folder(cfg, folder, 1, pareto=True)


def _grid_extremes(ev):
    axes = [np.linspace(a, b, GRID) for a, b in zip(ev.xl, ev.xu)]
    G = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(ev.xl))
    best = {k: [np.inf, -np.inf] for k in ev.index_names}
    for i in range(0, len(G), 8192):
        r = ev(G[i:i + 8192])
        ok = np.all([v <= 0 for v in r["constraints"].values()], axis=0)
        for k in ev.index_names:
            v = r["values"][k][ok]
            if len(v):
                best[k] = [min(best[k][0], v.min()), max(best[k][1], v.max())]
    return best


@pytest.mark.slow
def test_the_recorded_extremes_are_those_of_a_dense_grid_or_beyond(paper_run):
    cfg, res = paper_run
    ev = Evaluator.from_config(cfg)
    grid = _grid_extremes(ev)
    norm = res.results["normalization"]
    for k, (gmin, gmax) in grid.items():
        assert norm[k]["min"] <= gmin + 1e-6 * abs(gmin), (k, norm[k]["min"], gmin)
        assert norm[k]["max"] >= gmax - 1e-6 * abs(gmax), (k, norm[k]["max"], gmax)
        for b in ("min", "max"):
            x = ev.vector(norm[k][f"{b}_design"])[None, :]
            r = ev(x)
            assert all(v[0] <= 0 for v in r["constraints"].values()), (k, b)       # a feasible design
            assert r["values"][k][0] == pytest.approx(norm[k][b], rel=1e-12)     # that gives the value
            assert norm[k][f"{b}_found_by"] in ("prescan", "ga", "polish", "multistart", "extremes scan", "later stage",
                                                "named design")
    # the GA alone (this budget) stops short of the largest dynamic index; the polish does not
    ga = res.stages["single_dynamic_max"]["ga"]["indices"]["dynamic"]
    assert ga < (1 - 1e-3) * grid["dynamic"][1] <= norm["dynamic"]["max"]


@pytest.mark.slow
def test_the_polish_is_no_worse_feasible_and_first_order_optimal(paper_run):
    cfg, res = paper_run
    ev = Evaluator.from_config(cfg)
    for name, s in res.stages.items():
        if s["kind"] not in ("single", "weighted"):
            continue
        assert s["objective"] <= s["ga"]["objective"], name
        r = ev(ev.vector(s["design"])[None, :])
        assert all(v[0] <= 0 for v in r["constraints"].values()), name
        p = s["polish"]
        assert p["route"] == "ad"
        if s["found_by"] == "polish":
            assert p["optimality"]["kkt_relative"] <= TOLERANCE and p["optimality"]["converged"], (name, p["optimality"])
    opt = res.results["polish"]["optimality"]
    assert opt["kkt_relative"] <= TOLERANCE
    # the paper's box: the optimum is the corner where every index is best (all three bounds active)
    assert len(opt["active_bounds"]) == 3 and opt["projected_gradient_norm"] <= TOLERANCE
    md = (res.folder.path / "results.md").read_text()
    assert "First-order optimality at the optimum" in md and "Where the extremes were found" in md


@pytest.mark.slow
def test_the_pareto_polish_keeps_feasible_points_that_dominate_the_gas(paper_run):
    _, res = paper_run
    for name, s in res.stages.items():
        if s["kind"] != "pareto":
            continue
        assert s["front"] and all(r["cv"] == 0 for r in s["front"])
        assert s["polish"]["kept"] == len(s["front"]) and s["polish"]["max_improvement"] >= 0


@pytest.mark.parametrize("key, value", [("prescan", -1), ("prescan", 1.5), ("polish", -2), ("polish", "yes"),
                                        ("algorithm", "cmaes")])
def test_the_new_optimizer_keys_are_validated(key, value):
    from optdesign.config import ConfigError

    text = edited_text(PAPER.read_text(), {"  seed: 1\n": f"  seed: 1\n  {key}: {value}\n"})
    with pytest.raises(ConfigError) as exc:
        parse_config(text, source="p.yaml")
    assert f"optimizer.{key}" in str(exc.value) and "\n" not in str(exc.value)


def test_the_pre_scan_follows_the_budget_unless_the_config_says():
    from optdesign.optimize.pipeline import prescan_size, stage_plan

    cfg = load_config(PAPER)
    assert prescan_size(cfg.optimizer) == 2048                       # 50 x 100 > 2048
    small = parse_config(edited_text(PAPER.read_text(), {"generations: 100 ": "generations: 3 "}), source="s.yaml")
    assert prescan_size(small.optimizer) == 150
    none = parse_config(edited_text(PAPER.read_text(), {"  seed: 1\n": "  seed: 1\n  prescan: 0\n"}), source="n.yaml")
    assert prescan_size(none.optimizer) == 0 and stage_plan(none.optimizer, {k: s.sense for k, s in none.indices.items()})[0].kind == "single"


def test_the_optimality_measure_says_where_the_objective_has_a_kink():
    """2-CPR/RRR: the two singular values of J cross at points of W, so the
    stiffness index (the smallest one, summed over a grid) has kinks: at
    f = w its one-sided slopes differ and the measure says it is no
    certificate.  The 3-P(4S)'s indices, whose double singular value at the
    centre of W persists for every design, are smooth at the corner and
    inside the box."""
    from optdesign.optimize.polish import optimality
    from optdesign.optimize.problem import DesignProblem, index_term

    ev = Evaluator.from_config(load_config(CONFIGS / "cpr_rrr_opt.yaml"))
    x = ev.vector({"n": 0.06, "f": 0.1, "w": 0.1})
    o = optimality(DesignProblem(ev, [index_term("stiffness", "max")]), x, ev.free)
    assert not o["differentiable"] and o["one_sided_jump"] > 0.1
    ev = Evaluator.from_config(load_config(PAPER))
    corner = ev.vector({"r_a": 0.21, "r_b": 0.71, "phi": np.radians(35)})
    o = optimality(DesignProblem(ev, [index_term("stiffness", "max")]), corner, ev.free)
    assert o["differentiable"] and o["kkt_relative"] <= TOLERANCE
    inside = ev.vector({"r_a": 0.25, "r_b": 0.67, "phi": np.radians(30)})
    for k in ("dynamic", "stiffness", "isotropy"):
        o = optimality(DesignProblem(ev, [index_term(k, "min")]), inside, ev.free)
        assert o["differentiable"] and o["one_sided_jump"] < 1e-4, k


class _Segment:
    """A problem along the segment x0 + t (x1 - x0), t = X[:, 0]: feasible
    where ``feasible(t)``, objective 1 - t; counts its calls."""

    def __init__(self, feasible):
        self.feasible, self.calls = feasible, 0

    def _evaluate(self, X, out):
        self.calls += 1
        t = X[:, 0]
        out["F"] = (1.0 - t)[:, None]
        out["G"] = np.where(self.feasible(t), -1.0, 1.0)[:, None]


def _bisection(feasible, x0, x1, steps=30):
    """The end one step at a time (the reference the batched steps must equal)."""
    if feasible(np.array([x1[0]]))[0]:
        return x1, 1.0 - x1[0]
    a, b, fa = 0.0, 1.0, None
    for _ in range(steps):
        m = 0.5 * (a + b)
        x = x0 + m * (x1 - x0)
        if feasible(np.array([x[0]]))[0]:
            a, fa = m, 1.0 - x[0]
        else:
            b = m
    x = x0 + a * (x1 - x0)
    return x, (fa if fa is not None else 1.0 - x[0])


@pytest.mark.parametrize("steps", [30, 7, 1])
@pytest.mark.parametrize("case", ["threshold", "islands", "none", "end feasible"])
def test_the_batched_bisection_ends_where_one_step_at_a_time_does(case, steps):
    """feasible_end checks LEVELS steps in one call; the steps it takes, and so
    its end and value, are those of the plain bisection, bit for bit, also
    where the feasible set along the segment is not an interval."""
    from optdesign.optimize.feasible import LEVELS, feasible_end

    rng = np.random.default_rng(steps)
    cut = rng.uniform(0.1, 0.9)
    feasible = {"threshold": lambda t: t <= cut,
                "islands": lambda t: ((np.sin(40.0 * t) > 0.3) & (t < 0.95)) | (t <= 1e-3),
                "none": lambda t: t < 0.0,
                "end feasible": lambda t: t <= 2.0}[case]
    x0, x1 = np.array([0.0, 0.3]), np.array([1.0, -0.7])
    prob = _Segment(feasible)
    x, f = feasible_end(prob, x0, x1, steps)
    xr, fr = _bisection(feasible, x0, x1, steps)
    assert x.tobytes() == xr.tobytes() and f == fr
    if case == "end feasible":
        assert prob.calls == 1
    else:   # the end, then ceil(steps / LEVELS) calls (and x0's value where no midpoint was feasible)
        assert prob.calls == 1 + -(-steps // LEVELS) + (case == "none")
