"""Described mechanisms against the hand-written paths, in one process.

    python benchmarks/bench_described.py [--repeat 5] [--full-run]

1. the 3-P(4S): configs/p4s_paper.yaml (hand-written fused kernel,
   optdesign.fast) and configs/p4s_legs.yaml (the described mechanism's
   generic kernel) on the same designs and points: global dynamic, stiffness
   and isotropy indices, points per second and their ratio;
2. the 3-SPS-S optimization's evaluation: one population of configs/sps_s_opt.yaml
   (hand-written module, numpy) and configs/sps_s_legs_opt.yaml (described,
   compiled) through the optimizer's DesignProblem.index_values (the
   Evaluator: indices and the singularity constraint's worst cond_2 in one
   pass); ``--full-run`` also times both whole optimizations
   (``optdesign run --jobs 1``, a few tens of seconds each);
3. the Gough-Stewart platform: local indices over its workspace, points per
   second on all threads and on one.

The first call of each compiled kernel is timed separately (compilation, or
loading from numba's cache).  Timings are the best of --repeat runs.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def best(fn, repeat):
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def first(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def p4s(repeat):
    from optdesign.config import load_config
    from optdesign.evaluate import evaluate
    from optdesign.workspace import Workspace

    hand = load_config(ROOT / "configs" / "p4s_paper.yaml")
    desc = load_config(ROOT / "configs" / "p4s_legs.yaml")
    rng = np.random.default_rng(0)
    print("1. 3-P(4S): hand-written fused kernel vs described generic kernel (dynamic, stiffness, isotropy)")
    for D, N in ((50, 1000), (1, 1_000_000)):
        des = {"r_a": rng.uniform(0.21, 0.29, D), "r_b": rng.uniform(0.63, 0.71, D),
               "phi": np.radians(rng.uniform(25, 35, D))}
        X = np.stack([rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)], -1)
        ws = Workspace(spec=hand.workspace, names=("x", "y", "z"), X=X)
        t0 = [first(lambda c=c: evaluate(c, des, ws)) for c in (hand, desc)]
        t = [best(lambda c=c: evaluate(c, des, ws), repeat) for c in (hand, desc)]
        print(f"   {D} x {N}: hand {D * N / t[0] / 1e6:7.2f} M points/s, described {D * N / t[1] / 1e6:7.2f} M points/s, "
              f"ratio hand/described {t[1] / t[0]:5.2f}  (first calls {t0[0]:.2f} s, {t0[1]:.2f} s)")
        if N <= 10_000:
            from optdesign import fast

            def dev(a, b):
                return max(float(np.nanmax(np.abs(a.summary[k]["mean"] - b.summary[k]["mean"]) / np.abs(b.summary[k]["mean"])))
                           for k in hand.indices)

            e0, e1 = evaluate(hand, des, ws), evaluate(desc, des, ws)
            with fast.disabled():
                n0, n1 = evaluate(hand, des, ws), evaluate(desc, des, ws)
            print(f"      largest relative difference of the means: each compiled path to its numpy path {dev(e0, n0):.1e}, "
                  f"{dev(e1, n1):.1e}; the two numpy paths {dev(n1, n0):.1e} (round-off amplified at near-singular points)")


def sps(repeat, full):
    from optdesign.config import load_config
    from optdesign.evaluate import workspace_of
    from optdesign.optimize.problem import DesignProblem, index_term

    print("2. 3-SPS-S optimization: hand-written numpy path vs described mechanism (40 designs x 343 points)")
    times = []
    for name in ("sps_s_opt.yaml", "sps_s_legs_opt.yaml"):
        cfg = load_config(ROOT / "configs" / name)
        ws = workspace_of(cfg)
        pr = DesignProblem(cfg, [index_term("dexterity", "max")], ws)
        X = pr.xl + (pr.xu - pr.xl) * np.random.default_rng(1).uniform(size=(40, 4))
        pr.index_values(X)
        times.append(best(lambda pr=pr, X=X: pr.index_values(X), repeat))
    print(f"   DesignProblem.index_values (indices, extra objectives and constraints, the worst cond_2 included): "
          f"hand {times[0] * 1e3:.1f} ms, described {times[1] * 1e3:.1f} ms, ratio {times[0] / times[1]:.2f}")
    if full:
        from optdesign.optimize.pipeline import Progress
        from optdesign.optimize.runner import start_run

        walls = []
        for name in ("sps_s_opt.yaml", "sps_s_legs_opt.yaml"):
            cfg = load_config(ROOT / "configs" / name)
            with tempfile.TemporaryDirectory() as tmp:
                t = time.perf_counter()
                start_run(cfg, None, tmp, None, Progress(False), pareto=True, jobs=1)
                walls.append(time.perf_counter() - t)
        print(f"   whole optimization (--jobs 1): hand {walls[0]:.1f} s, described {walls[1]:.1f} s, "
              f"ratio {walls[0] / walls[1]:.2f}")


def gough_stewart(repeat):
    import numba

    from optdesign.config import load_config
    from optdesign.evaluate import index_requests, mechanism_class, workspace_of

    cfg = load_config(ROOT / "configs" / "gough_stewart.yaml")
    X = workspace_of(cfg).X
    rng = np.random.default_rng(2)
    D = 25
    des = {k: dv.value * rng.uniform(0.95, 1.05, (D, 1)) for k, dv in cfg.design_variables.items()}
    mech = mechanism_class(cfg)(**{**cfg.parameters, **des})
    print(f"3. Gough-Stewart local indices over its workspace ({D} designs x {len(X)} points)")
    threads = numba.get_num_threads()
    for names in (["dexterity"], ["isotropy", "dexterity", "stiffness"], ["dynamic"], list(cfg.indices)):
        req = index_requests(cfg, names)
        mech.global_statistics(req, X)
        rates = []
        for n in (threads, 1):
            numba.set_num_threads(n)
            rates.append(D * len(X) / best(lambda: mech.global_statistics(req, X), repeat) / 1e6)
        numba.set_num_threads(threads)
        print(f"   {', '.join(names):40s} {rates[0]:6.2f} M points/s on {threads} threads, {rates[1]:6.2f} on 1")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--full-run", action="store_true")
    a = ap.parse_args(argv)
    t = time.perf_counter()
    from optdesign.config import load_config
    from optdesign.evaluate import evaluate

    cfg = load_config(ROOT / "configs" / "delta.yaml")
    evaluate(cfg, [cfg.initial_design()])
    print(f"imports and a first evaluation (numba cache load or compile): {time.perf_counter() - t:.2f} s")
    p4s(a.repeat)
    sps(a.repeat, a.full_run)
    gough_stewart(a.repeat)


if __name__ == "__main__":
    main()
