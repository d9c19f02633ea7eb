"""Same seed, same front: whatever the threads, the hash seed, the workers
and the checkpoint timing.

pymoo 0.6.2 creates a fresh, OS-seeded generator wherever a randomized
function is called without the algorithm's (``pymoo.util.default_random_state``);
NSGA-III's tournament did so for ties between infeasible designs, and its
fronts then differed from run to run.  The first test makes every such
generator fail when drawn from: pymoo's own NSGA-III draws from one on a
problem with ties, none of the algorithms a stage runs does.  The second runs
the same config twice in fresh processes that differ in everything but the
seed and compares the files byte for byte.
"""
from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pymoo.util
import pytest
from conftest import DATA, ROOT, edited_text
from pymoo.algorithms.moo.nsga3 import NSGA3

from optdesign.config import load_config
from optdesign.evaluate import Evaluator, workspace_of
from optdesign.optimize.algorithms import build_algorithm, reference_directions
from optdesign.optimize.problem import DesignProblem, index_term

HOSTILE = DATA / "p4s_hostile_bounds.yaml"


class _Unseeded:
    def __getattr__(self, name):
        raise AssertionError(f"an unseeded generator was drawn from ({name})")


@pytest.fixture
def no_unseeded_draws(monkeypatch):
    real = np.random.default_rng
    rng = lambda seed=None, *a: _Unseeded() if seed is None else real(seed, *a)  # noqa: E731
    monkeypatch.setattr(pymoo.util, "np", types.SimpleNamespace(random=types.SimpleNamespace(default_rng=rng)))


def _problem(n_obj):
    cfg = load_config(HOSTILE)
    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    terms = [index_term(k, s.sense) for k, s in cfg.indices.items()][:n_obj]
    return cfg, DesignProblem(ev, terms)


@pytest.mark.parametrize("kind", ["paper_ga", "pymoo_ga", "nsga2", "nsga3"])
def test_every_draw_comes_from_the_seeded_generator(no_unseeded_draws, kind):
    cfg, prob = _problem(1 if kind.endswith("_ga") else 3)
    opt = dataclasses.replace(cfg.optimizer, algorithm=kind) if kind.endswith("_ga") else cfg.optimizer
    alg, cb = build_algorithm(opt, prob.n_obj, None if kind.endswith("_ga") else kind)
    alg.setup(prob, termination=("n_gen", 12), seed=3, verbose=False, **({"callback": cb} if cb else {}))
    alg.run()
    assert alg.n_gen == 13


def test_pymoo_nsga3_tournament_draws_from_an_unseeded_generator(no_unseeded_draws):
    """The check above can fail: on this problem pymoo's own NSGA-III does draw unseeded."""
    cfg, prob = _problem(3)
    ref = reference_directions(3)
    alg = NSGA3(ref_dirs=ref, pop_size=max(cfg.optimizer.pareto_population, len(ref)))
    alg.setup(prob, termination=("n_gen", 12), seed=3, verbose=False)
    with pytest.raises(AssertionError, match="unseeded"):
        alg.run()


def _run(tmp: Path, name: str, threads: int, interval: str, jobs: int) -> Path:
    cfg = tmp / f"{name}.yaml"
    # one polish start per stage (3 by default): the polish still ends every stage and polishes every
    # Pareto point, in both processes and with either BLAS thread count
    edits = {"seed: 5,": f"seed: 5, polish: 1, checkpoint_interval: {interval},"}
    cfg.write_text(edited_text(HOSTILE.read_text(), edits))
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads),
           "OPENBLAS_NUM_THREADS": str(threads), "MKL_NUM_THREADS": str(threads), "PYTHONHASHSEED": str(threads)}
    r = subprocess.run([sys.executable, "-m", "optdesign.cli", "run", str(cfg), "--out", str(tmp / name), "--quiet",
                        "--jobs", str(jobs)], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    (folder,) = list((tmp / name).iterdir())
    return folder


@pytest.mark.slow
def test_the_same_seed_gives_the_same_files(tmp_path):
    a = _run(tmp_path, "a", 1, "0", 1)
    b = _run(tmp_path, "b", 2, "1000000", 2)
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.suffix == ".csv" or p.name == "result.json")
    assert {"pareto_nsga3.csv", "pareto_nsga2.csv", "history.csv", "population.csv"} <= {str(p) for p in files}
    for rel in files:
        assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel
    ra, rb = (json.loads((f / "results.json").read_text()) for f in (a, b))
    ra.pop("wall_time_s"), rb.pop("wall_time_s")
    assert ra == rb
