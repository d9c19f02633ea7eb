"""Single-objective optimizers at equal evaluation budgets: pymoo's test
problems and our own design problems.

    python benchmarks/bench_optimizers.py [--quick] [--seeds 10] [--population 50]
        [--generations 100] [--jobs 1] [--json out.json] [--from-json out.json]

Algorithms (every one stopped at the same number of evaluations,
``population x generations``; a run that stops earlier keeps its best):

* ``paper_ga``: the paper's GA as assembled from our operators
  (:func:`optdesign.optimize.pipeline.build_algorithm`, ``paper_ga``: roulette
  on rank-scaled fitness, arithmetic crossover 0.8, adaptive Gaussian mutation
  0.2, 2 elites);
* ``pymoo_ga``: pymoo's GA as the pipeline builds it (``pymoo_ga``);
* ``de``: pymoo's DE (its defaults, DE/best/1/bin);
* ``cmaes``: pymoo's CMA-ES (the ``cma`` package; its defaults, no restart);
* ``ipop_cmaes``: the same with up to 9 restarts, the population doubled at
  each (IPOP-CMA-ES);
* ``pso``: pymoo's PSO (its defaults).

Population-based algorithms use ``--population`` (default 50); CMA-ES its own.

Problems:

* pymoo's Rastrigin, Ackley, Griewank, Rosenbrock and Sphere with 5 and 10
  variables (best known value 0);
* for each of ``configs/p4s_paper.yaml``, ``configs/p4s_wide.yaml`` and
  ``configs/sps_s_opt.yaml``: the minimum and the maximum of each global index
  and the config's normalized weighted sum (eq. 38-40), built through
  :class:`optdesign.optimize.problem.DesignProblem` with the config's
  constraints.  The weighted sum is normalized by the feasible extremes of a
  Sobol scan of 4096 designs of the box (fixed constants that define the
  problem; they are not the true extremes).  The best known value of a design
  problem is the best of every run and of that scan.

Printed per problem and algorithm: the median and quartiles of the best
feasible value over the seeds, how many runs came within the target of the
best known value f* (``f - f* <= 1e-6 max(|f*|, 1)``: 1e-6 relative, 1e-6
absolute where |f*| < 1), and the median number of evaluations they needed.
Evaluations are the measure, not wall time.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

ALGORITHMS = ("paper_ga", "pymoo_ga", "de", "cmaes", "ipop_cmaes", "pso")
TEST_PROBLEMS = ("rastrigin", "ackley", "griewank", "rosenbrock", "sphere")
CONFIGS = ("configs/p4s_paper.yaml", "configs/p4s_wide.yaml", "configs/sps_s_opt.yaml")
TARGET = 1e-6


# ---------------------------------------------------------------------- algorithms
def make_algorithm(name: str, population: int):
    """(algorithm, callback or None) for one run."""
    if name in ("paper_ga", "pymoo_ga"):
        from optdesign.config import OptimizerSpec
        from optdesign.optimize.pipeline import build_algorithm

        return build_algorithm(OptimizerSpec(algorithm=name, population=population), 1)
    if name == "de":
        from pymoo.algorithms.soo.nonconvex.de import DE

        return DE(pop_size=population), None
    if name == "pso":
        from pymoo.algorithms.soo.nonconvex.pso import PSO

        return PSO(pop_size=population), None
    if name in ("cmaes", "ipop_cmaes"):
        from pymoo.algorithms.soo.nonconvex.cmaes import CMAES

        return (CMAES() if name == "cmaes" else CMAES(restarts=9, incpopsize=2)), None
    raise KeyError(name)


# ---------------------------------------------------------------------- problems
class Recorded:
    """Wraps a pymoo problem; keeps the best feasible value after every evaluation."""

    def __init__(self, inner):
        from pymoo.core.problem import Problem

        rec = self

        class _P(Problem):
            def __init__(self):
                super().__init__(n_var=inner.n_var, n_obj=1, n_ieq_constr=inner.n_ieq_constr,
                                 xl=inner.xl, xu=inner.xu, vtype=float)

            def _evaluate(self, X, out, *args, **kwargs):
                o = inner.evaluate(X, return_as_dictionary=True)
                F = np.asarray(o["F"], dtype=float).reshape(len(X), -1)
                out["F"] = F
                feas = np.ones(len(X), bool)
                if inner.n_ieq_constr:
                    G = np.asarray(o["G"], dtype=float).reshape(len(X), -1)
                    out["G"] = G
                    feas = np.all(G <= 0, axis=1)
                rec.values.append(np.where(feas & np.isfinite(F[:, 0]), F[:, 0], np.inf))

        self.problem = _P()
        self.values: list[np.ndarray] = []

    def trace(self, budget: int) -> tuple[list[list[float]], int]:
        """The improvements ``[[evaluation, best], ...]`` within the budget, and
        the evaluations used."""
        f = np.concatenate(self.values)[:budget] if self.values else np.array([np.inf])
        best = np.minimum.accumulate(f)
        idx = np.flatnonzero(np.r_[True, best[1:] < best[:-1]])
        return [[int(i + 1), float(best[i])] for i in idx if np.isfinite(best[i])], int(len(f))


def _test_problem(name: str, n_var: int):
    from pymoo.problems import get_problem

    return get_problem(name, n_var=n_var)


def _design_terms(cfg):
    out = []
    for k in cfg.indices:
        out.append((f"min {k}", ("index", k, 1.0)))
        out.append((f"max {k}", ("index", k, -1.0)))
    out.append(("weighted sum", ("weighted",)))
    return out


def prescan(config_path: str, n: int = 4096) -> dict:
    """Feasible extremes of each index over a Sobol scan of the design box."""
    from scipy.stats import qmc

    from optdesign.config import load_config
    from optdesign.evaluate import Evaluator

    cfg = load_config(ROOT / config_path)
    ev = Evaluator.from_config(cfg)
    U = qmc.Sobol(d=len(ev.free), scramble=True, seed=0).random_base2(int(np.log2(n)))
    X = ev.xl + (ev.xu - ev.xl) * U
    res = {"values": {k: [] for k in cfg.indices}, "feasible": []}
    for i in range(0, n, 256):
        r = ev(X[i:i + 256])
        feas = np.all([v <= 0 for v in r["constraints"].values()], axis=0)
        res["feasible"].append(feas)
        for k in cfg.indices:
            res["values"][k].append(r["values"][k])
    feas = np.concatenate(res["feasible"])
    vals = {k: np.concatenate(v)[feas] for k, v in res["values"].items()}
    return {"lo": {k: float(v.min()) for k, v in vals.items()}, "hi": {k: float(v.max()) for k, v in vals.items()},
            "feasible": int(feas.sum()), "designs": n}


_CACHE: dict = {}


def build_problem(spec: dict):
    """The pymoo problem of a plain problem spec (cached per process)."""
    key = spec["key"]
    if key in _CACHE:
        return _CACHE[key]
    if spec["kind"] == "test":
        p = _test_problem(spec["name"], spec["n_var"])
    else:
        from optdesign.config import load_config
        from optdesign.evaluate import workspace_of
        from optdesign.optimize.problem import Term, weighted_sum_term

        cfg = load_config(ROOT / spec["config"])
        t = spec["term"]
        if t[0] == "index":
            term = Term("index", t[1], t[2])
        else:
            term = weighted_sum_term(spec["lo"], spec["hi"], cfg.optimizer.weights,
                                     {k: s.sense for k, s in cfg.indices.items()})
        from optdesign.evaluate import Evaluator
        from optdesign.optimize.problem import DesignProblem

        p = DesignProblem(Evaluator.from_config(cfg, workspace_of(cfg)), [term])
    _CACHE[key] = p
    return p


def run_once(spec: dict, algorithm: str, seed: int, budget: int, population: int) -> dict:
    import warnings

    from pymoo.optimize import minimize

    rec = Recorded(build_problem(spec))
    alg, cb = make_algorithm(algorithm, population)
    t = time.perf_counter()
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        extra = {"callback": cb} if cb is not None else {}
        minimize(rec.problem, alg, termination=("n_eval", budget), seed=seed, verbose=False, **extra)
    trace, used = rec.trace(budget)
    return {"problem": spec["key"], "algorithm": algorithm, "seed": seed, "trace": trace, "evaluations": used,
            "best": trace[-1][1] if trace else float("inf"), "wall_s": round(time.perf_counter() - t, 3)}


def problem_specs(quick: bool) -> list[dict]:
    specs = []
    dims = (5,) if quick else (5, 10)
    tests = ("rastrigin", "sphere") if quick else TEST_PROBLEMS
    for n in dims:
        for name in tests:
            specs.append({"key": f"{name}-{n}", "kind": "test", "name": name, "n_var": n, "best_known": 0.0})
    from optdesign.config import load_config

    for path in (CONFIGS[:1] if quick else CONFIGS):
        cfg = load_config(ROOT / path)
        scan = prescan(path, 256 if quick else 4096)
        terms = _design_terms(cfg)
        if quick:
            terms = [terms[0], terms[-1]]
        for label, term in terms:
            s = {"key": f"{cfg.name}: {label}", "kind": "design", "config": path, "term": list(term),
                 "lo": scan["lo"], "hi": scan["hi"],
                 "sense": cfg.indices[term[1]].sense if term[0] == "index" else None}
            if term[0] == "index":
                v = scan["lo"][term[1]] if term[2] > 0 else -scan["hi"][term[1]]
                s["scan_best"] = v
            specs.append(s)
    return specs


# ---------------------------------------------------------------------- tables
def _target(fstar: float) -> float:
    return fstar + TARGET * max(abs(fstar), 1.0)


def _first_reach(trace, level):
    for e, v in trace:
        if v <= level:
            return e
    return None


def role(spec: dict) -> str:
    """``test`` (pymoo's problems), ``optimum`` (a design problem asking for an
    index's best value, or the weighted sum) or ``extreme`` (an index's worst
    feasible value: the other end of the normalization)."""
    if spec["kind"] == "test":
        return "test"
    term = spec["term"]
    if term[0] != "index":
        return "optimum"
    if "sense" not in spec:
        from optdesign.config import load_config

        spec["sense"] = load_config(ROOT / spec["config"]).indices[term[1]].sense
    minimize = term[2] > 0
    return "optimum" if minimize == (spec["sense"] == "min") else "extreme"


def summarize(data: dict) -> str:
    from optdesign.tables import fmt_g, table

    runs = data["runs"]
    algs = [a for a in ALGORITHMS if any(r["algorithm"] == a for r in runs)]
    lines = [f"budget: {data['budget']} evaluations per run, {data['seeds']} seeds; "
             f"target: f - f* <= {TARGET:g} max(|f*|, 1)", ""]
    groups = ("test", "optimum", "extreme")
    ranks = {a: {g: [] for g in groups} for a in algs}
    matrix = {"best": [], "evals": []}
    solved = {a: {g: 0 for g in groups} for a in algs}
    for spec in data["problems"]:
        key = spec["key"]
        rs = [r for r in runs if r["problem"] == key]
        if not rs:
            continue
        fstar = min([r["best"] for r in rs] + [spec.get("best_known", np.inf), spec.get("scan_best", np.inf)])
        level = _target(fstar)
        rows, meds = [], {}
        present = [a for a in algs if any(r["algorithm"] == a for r in rs)]
        for a in present:
            ra = [r for r in rs if r["algorithm"] == a]
            b = np.array([r["best"] for r in ra])
            q1, med, q3 = np.percentile(b, [25, 50, 75])
            meds[a] = med
            hits = [_first_reach(r["trace"], level) for r in ra]
            hits = [h for h in hits if h is not None]
            solved[a][role(spec)] += len(hits)
            rows.append([a, fmt_g(float(med), 7), fmt_g(float(q1), 7), fmt_g(float(q3), 7), f"{len(hits)}/{len(ra)}",
                         str(int(np.median(hits))) if hits else "-"])
        # ranks by the median, every median within the target counted as equal
        key_of = {a: max(meds[a], level) for a in present}
        order = sorted(present, key=lambda a: key_of[a])
        for a in present:   # ties share the mean rank
            tied = [i + 1 for i, b in enumerate(order) if key_of[b] == key_of[a]]
            ranks[a][role(spec)].append(float(np.mean(tied)))
        cell = {r[0]: r for r in rows}
        scale = max(abs(fstar), 1.0)
        matrix["best"].append([key, fmt_g(fstar, 7)] + [f"{(meds[a] - fstar) / scale:.1e} ({cell[a][4].split('/')[0]})"
                                                        if a in cell else "-" for a in algs])
        matrix["evals"].append([key] + [cell[a][5] if a in cell else "-" for a in algs])
        lines.append(f"{key}   (f* = {fmt_g(fstar, 8)})")
        lines.append(table(["algorithm", "median", "q1", "q3", "reached", "evals to reach"], rows))
        lines.append("")
    lines.append("Gap of the median best value to f*, (median - f*) / max(|f*|, 1), and (in brackets) the runs "
                 "that reached the target:")
    lines.append(table(["problem", "f*"] + algs, matrix["best"]))
    lines.append("")
    lines.append("Median evaluations to reach the target (over the runs that reached it; - : none did):")
    lines.append(table(["problem"] + algs, matrix["evals"]))
    lines.append("")
    rows = []
    for a in algs:
        rows.append([a] + [f"{np.mean(ranks[a][g]):.2f}" if ranks[a][g] else "-" for g in groups]
                    + [str(solved[a][g]) for g in groups])
    lines.append("Mean rank of the median best (1 = best; ties share the rank, and every median within the target "
                 "ties) and runs that reached the target:")
    n = {g: sum(1 for sp in data["problems"] if role(sp) == g) for g in groups}
    lines.append(f"(test: pymoo's {n['test']} problems; optimum: the {n['optimum']} design problems that ask for "
                 f"an index's best value or the weighted sum; extreme: the {n['extreme']} that ask for an index's "
                 "worst feasible value, the other end of the normalization)")
    lines.append(table(["algorithm", "rank: test", "rank: optimum", "rank: extreme", "reached: test",
                        "reached: optimum", "reached: extreme"], rows))
    return "\n".join(lines)


# ---------------------------------------------------------------------- main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="a small version (seconds): 2 test problems, 1 config, 3 seeds, 400 evaluations")
    ap.add_argument("--seeds", type=int, default=None, help="seeds 1..N (default 10; 3 with --quick)")
    ap.add_argument("--population", type=int, default=None, help="population of the population-based algorithms (default 50; 20 with --quick)")
    ap.add_argument("--generations", type=int, default=None, help="budget = population x generations (default 100; 20 with --quick)")
    ap.add_argument("--algorithms", default=",".join(ALGORITHMS), help="comma-separated subset of " + ", ".join(ALGORITHMS))
    ap.add_argument("--only", default=None, help="run only the problems whose key contains this text")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    ap.add_argument("--json", default=None, metavar="PATH", help="write every run's record here")
    ap.add_argument("--from-json", default=None, metavar="PATH", help="print the tables of an earlier --json file")
    args = ap.parse_args(argv)
    if args.from_json:
        print(summarize(json.loads(Path(args.from_json).read_text())))
        return 0
    seeds = args.seeds or (3 if args.quick else 10)
    pop = args.population or (20 if args.quick else 50)
    gens = args.generations or (20 if args.quick else 100)
    budget = pop * gens
    algs = [a.strip() for a in args.algorithms.split(",") if a.strip()]
    for a in algs:
        if a not in ALGORITHMS:
            ap.error(f"unknown algorithm {a!r}; expected some of {', '.join(ALGORITHMS)}")
    specs = problem_specs(args.quick)
    if args.only:
        specs = [s for s in specs if args.only in s["key"]]
    tasks = [(s, a, seed) for s in specs for a in algs for seed in range(1, seeds + 1)]
    data = {"budget": budget, "population": pop, "seeds": seeds, "problems": specs, "runs": []}
    t0 = time.perf_counter()
    if args.jobs > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(args.jobs) as pool:
            futs = [pool.submit(run_once, s, a, seed, budget, pop) for s, a, seed in tasks]
            for i, f in enumerate(futs):
                data["runs"].append(f.result())
                _progress(i + 1, len(tasks), t0)
    else:
        for i, (s, a, seed) in enumerate(tasks):
            data["runs"].append(run_once(s, a, seed, budget, pop))
            _progress(i + 1, len(tasks), t0)
            if args.json and (i + 1) % 50 == 0:
                Path(args.json).write_text(json.dumps(data))
    print(file=sys.stderr)
    if args.json:
        Path(args.json).write_text(json.dumps(data))
    print(summarize(data))
    return 0


def _progress(i, n, t0):
    print(f"\r{i}/{n} runs, {time.perf_counter() - t0:.0f} s", end="", file=sys.stderr, flush=True)


if __name__ == "__main__":
    sys.exit(main())
