"""Every shipped optimization config on a small budget (seeds 1-5 in turn
over the configs): each normalized term of the optimum in [0, 1], the
weighted sum in [0, sum of the weights], the extremes bracket every index
value the run reports.  benchmarks/normalized_objectives.py runs the full
budgets over seeds 1-5.  (Apart from tests/test_polish.py so that the two
test workers share the long runs.)"""
from __future__ import annotations

import numpy as np
import pytest
import yaml
from conftest import shipped_optimizations

from optdesign.config import parse_config
from optdesign.runner import run_in_folder
from optdesign.runs import RunFolder


def _small(text: str) -> str:
    raw = yaml.safe_load(text)
    opt = raw.setdefault("optimizer", {})
    opt.update(population=6, generations=2, prescan=16, polish=0, checkpoint_interval=100)
    opt.pop("elites", None)
    opt["pareto"] = {"algorithms": ["nsga2"], "population": 6, "generations": 2}
    raw["checks"] = {"certificate_budget": 0, "integral_tolerance": 0}   # not what these tests check
    return yaml.safe_dump(raw)


SHIPPED = list(shipped_optimizations())


@pytest.mark.slow
@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_no_normalized_objective_leaves_zero_one(path, tmp_path):
    # the reports are not what is checked here (and take most of a small run's time): the
    # pipeline without outputs writes none. One seed per config, seeds 1-5 in turn over the
    # configs (the chain mechanisms' numpy path costs 15-30 s a seed);
    # benchmarks/normalized_objectives.py runs every config over seeds 1-5 at full budgets
    text = _small(path.read_text())
    for seed in (1 + SHIPPED.index(path) % 5,):
        cfg = parse_config(text, source=str(path))
        r = run_in_folder(cfg, RunFolder.create(tmp_path, f"s{seed}", text, seed, "k"), seed, reports=False).results
        norm = r["normalization"]
        total = sum(v["weight"] for v in norm.values())
        assert 0.0 <= r["objective"] <= total and 0.0 <= r["objective_paper_literal"] <= total, seed
        for k, v in norm.items():
            assert v["min"] <= r["global_indices"][k] <= v["max"], (seed, k)
        for d in r["designs"].values():
            if d["objective"] is not None:
                assert 0.0 <= d["objective"] <= total
                assert all(norm[k]["min"] <= d["global_indices"][k]["mean"] <= norm[k]["max"] for k in norm)
        for p in r.get("pareto", {}).values():
            Fn = np.array(p["placement"]["weighted_sum_optimum"]["normalized_objectives"])
            assert np.all((Fn >= -1e-12) & (Fn <= 1 + 1e-12)), seed


