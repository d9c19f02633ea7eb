"""Described mechanisms against the hand-written paths: the three targets of
their compiled path, measured in one run (the machine is shared: the load is
printed with every part).

    python benchmarks/bench_described.py [--repeat 7] [--runs 3] [--no-runs] [--cold]

1. 3-P(4S): ``evaluate`` of configs/p4s_paper.yaml (the hand-written fused
   kernel) and of configs/p4s_legs.yaml (the description, through the generic
   kernel) on the same designs and points, interleaved, best of --repeat:
   points per second and their ratio (target: described within 2x), on all
   threads and on one, by wall and by CPU time (process time: what a busy
   machine does not take away from a single thread).
2. 3-SPS-S optimization: ``optdesign run CONFIG --no-pareto`` in
   subprocesses, interleaved, best of --runs: configs/sps_s_opt.yaml at
   revision 8b1a6dd (the start; that tree extracted with ``git archive`` into a
   directory of the temp dir, kept between runs with its numba cache) against
   configs/sps_s_legs_opt.yaml (the description, compiled) and
   configs/sps_s_opt.yaml of this tree (target: at least 5x faster than the
   start).  A first run of each is not timed (caches).
3. Gough-Stewart: the config's four local indices over its workspace
   (25 designs x 4096 points) through ``global_statistics``, points per
   second on all threads and on one (target: 5 M points/s on 2 cores).

``--cold``: the first evaluation of each described config with an empty numba
cache, in a subprocess (compile time).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

START = "8b1a6dd"


def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def interleaved(fns, repeat):
    """Best (wall, CPU) seconds of each function, called in turn repeat times."""
    wall = [np.inf] * len(fns)
    cpu = [np.inf] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t, c = time.perf_counter(), time.process_time()
            fn()
            wall[i] = min(wall[i], time.perf_counter() - t)
            cpu[i] = min(cpu[i], time.process_time() - c)
    return wall, cpu


def threads(n):
    import numba

    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    return numba.get_num_threads()


def p4s(repeat):
    import numba

    from optdesign.config import load_config
    from optdesign.evaluate import evaluate
    from optdesign.workspace import Workspace

    hand = load_config(ROOT / "configs" / "p4s_paper.yaml")
    desc = load_config(ROOT / "configs" / "p4s_legs.yaml")
    rng = np.random.default_rng(0)
    print(f"1. 3-P(4S) (dynamic, stiffness, isotropy): hand-written kernel vs the description ({load()})")
    most = numba.config.NUMBA_NUM_THREADS
    for D, N in ((50, 1000), (1, 1_000_000)):
        des = {"r_a": rng.uniform(0.21, 0.29, D), "r_b": rng.uniform(0.63, 0.71, D),
               "phi": np.radians(rng.uniform(25, 35, D))}
        X = np.stack([rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)], -1)
        ws = Workspace(spec=hand.workspace, names=("x", "y", "z"), X=X)
        fns = [lambda c=c: evaluate(c, des, ws) for c in (hand, desc)]
        for fn in fns:
            fn()
        for n in sorted({most, 1}, reverse=True):
            nt = threads(n)
            (wh, wd), (ch, cd) = interleaved(fns, repeat)
            print(f"   {D} x {N}, {nt} thread{'s' * (nt > 1)}: hand {D * N / wh / 1e6:6.2f} M points/s, described "
                  f"{D * N / wd / 1e6:6.2f}, ratio {wd / wh:4.2f} (target <= 2); by CPU time {D * N / ch / 1e6:6.2f} "
                  f"and {D * N / cd / 1e6:6.2f}, ratio {cd / ch:4.2f}")
        threads(most)
        if N <= 10_000:
            from optdesign import fast

            def dev(a, b):
                return max(float(np.nanmax(np.abs(a.summary[k]["mean"] - b.summary[k]["mean"])
                                           / np.abs(b.summary[k]["mean"]))) for k in hand.indices)

            e0, e1 = evaluate(hand, des, ws), evaluate(desc, des, ws)
            with fast.disabled():
                n0, n1 = evaluate(hand, des, ws), evaluate(desc, des, ws)
            print(f"      largest relative difference of the means: each compiled path to its numpy path "
                  f"{dev(e0, n0):.1e}, {dev(e1, n1):.1e}; the two numpy paths {dev(n1, n0):.1e}")
    print(f"   ({load()})")


def _tree(rev: str) -> Path:
    """The tree of revision rev, extracted once into the temp dir (its numba cache stays)."""
    d = Path(tempfile.gettempdir()) / f"optdesign_tree_{rev}"
    if not (d / "optdesign").is_dir():
        d.mkdir(parents=True, exist_ok=True)
        arch = subprocess.run(["git", "-C", str(ROOT), "archive", rev], capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(d)], input=arch, check=True)
    return d


def _run(tree: Path, config: str, out: str) -> float:
    code = "import sys; from optdesign.cli import main; sys.exit(main())"
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", code, "run", config, "--no-pareto", "--quiet", "--out", out],
                   cwd=tree, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def sps(runs):
    old = _tree(START)
    cases = [(f"{START} configs/sps_s_opt.yaml (hand-written, numpy)", old, "configs/sps_s_opt.yaml"),
             ("this tree configs/sps_s_legs_opt.yaml (described, compiled)", ROOT, "configs/sps_s_legs_opt.yaml"),
             ("this tree configs/sps_s_opt.yaml (hand-written, numpy)", ROOT, "configs/sps_s_opt.yaml")]
    print(f"2. 3-SPS-S optimization, `optdesign run CONFIG --no-pareto` in subprocesses, best of {runs} ({load()})")
    best = [np.inf] * len(cases)
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(runs + 1):
            for i, (_, tree, cfg) in enumerate(cases):
                t = _run(tree, cfg, os.path.join(tmp, f"{r}_{i}"))
                if r:
                    best[i] = min(best[i], t)
    for (name, _, _), t in zip(cases, best):
        print(f"   {name:62s} {t:6.2f} s, {best[0] / t:5.2f}x the start")
    print(f"   target: the described run at least 5x faster than the start ({load()})")


def gough_stewart(repeat):
    import numba

    from optdesign.config import load_config
    from optdesign.evaluate import index_requests, mechanism_class, workspace_of

    cfg = load_config(ROOT / "configs" / "gough_stewart.yaml")
    X = workspace_of(cfg).X
    rng = np.random.default_rng(2)
    D = 25
    des = {k: dv.value * rng.uniform(0.95, 1.05, (D, 1)) for k, dv in cfg.design_variables.items()}
    cls = mechanism_class(cfg)
    print(f"3. Gough-Stewart local indices over its workspace ({D} designs x {len(X)} points) ({load()})")
    most = numba.config.NUMBA_NUM_THREADS
    for names in (["dexterity"], ["isotropy", "dexterity", "stiffness"], ["dynamic"], list(cfg.indices)):
        req = index_requests(cfg, names)

        def call(req=req):
            return cls(**{**cfg.parameters, **des}).global_statistics(req, X)

        call()
        rates = []
        for n in sorted({most, 1}, reverse=True):
            nt = threads(n)
            (w,), (c,) = interleaved([call], repeat)
            rates.append(f"{nt} thread{'s' * (nt > 1)} {D * len(X) / w / 1e6:5.2f} M points/s (by CPU time "
                         f"{D * len(X) / c / 1e6:5.2f})")
        threads(most)
        print(f"   {', '.join(names):37s} " + "; ".join(rates))
    print(f"   target: all four >= 5 M points/s on 2 cores ({load()})")


def cold():
    code = ("import time, sys; t = time.perf_counter(); from optdesign.config import load_config; "
            "from optdesign.evaluate import evaluate; c = load_config(sys.argv[1]); "
            "evaluate(c, [c.initial_design()]); print(time.perf_counter() - t)")
    print("cold cache: first evaluation of each described config (numba compiles its kernel), subprocesses")
    for name in ("p4s_legs.yaml", "sps_s_legs.yaml", "delta.yaml", "gough_stewart.yaml"):
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=cache)
            out = subprocess.run([sys.executable, "-c", code, str(ROOT / "configs" / name)], env=env,
                                 capture_output=True, text=True, check=True).stdout.split()[-1]
        print(f"   {name:20s} {float(out):5.1f} s")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--no-runs", action="store_true", help="skip the 3-SPS-S optimization runs")
    ap.add_argument("--cold", action="store_true", help="also time the compilation with an empty numba cache")
    a = ap.parse_args(argv)
    t = time.perf_counter()
    from optdesign.config import load_config
    from optdesign.evaluate import evaluate

    for name in ("p4s_legs.yaml", "gough_stewart.yaml"):
        cfg = load_config(ROOT / "configs" / name)
        evaluate(cfg, [cfg.initial_design()])
    print(f"imports and first evaluations (numba cache load, or compile): {time.perf_counter() - t:.2f} s")
    p4s(a.repeat)
    if not a.no_runs:
        sps(a.runs)
    gough_stewart(a.repeat)
    if a.cold:
        cold()


if __name__ == "__main__":
    main()
