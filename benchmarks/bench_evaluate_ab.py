"""The whole evaluation path of the current tree against an earlier revision's,
in one process.

* ``evaluate()`` of the embedded paper config (indices dynamic, stiffness,
  isotropy) on the bench inputs of ``bench_throughput.py`` (50 random designs x
  1000 points, 1 design x 10^6 points): the earlier revision's whole package
  is extracted from git into a temporary folder as ``optdesign_<rev>`` (its
  numba cache kept there between runs) and timed beside the current one; the
  results are compared (the largest relative difference of any statistic).

    python benchmarks/bench_evaluate_ab.py [--rev 8b1a6dd] [--repeat 7]

Best of ``--repeat`` runs; the ratios are the point (the machine may be shared).
"""
from __future__ import annotations

import argparse
import importlib
import io
import os
import subprocess
import sys
import tarfile
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _old_package(rev: str):
    """The package ``optdesign`` of revision ``rev`` imported as ``optdesign_<rev>``."""
    name = f"optdesign_{rev}"
    base = os.path.join(tempfile.gettempdir(), f"optdesign_pkg_{rev}")
    target = os.path.join(base, name)
    if not os.path.isdir(target):
        data = subprocess.run(["git", "-C", ROOT, "archive", rev, "optdesign"], capture_output=True, check=True).stdout
        os.makedirs(base, exist_ok=True)
        with tarfile.open(fileobj=io.BytesIO(data)) as tf:
            tf.extractall(base, filter="data")
        os.rename(os.path.join(base, "optdesign"), target)
        for dirpath, _, files in os.walk(target):
            for f in files:
                if f.endswith(".py"):
                    p = os.path.join(dirpath, f)
                    src = open(p).read()
                    src = (src.replace("from optdesign.", f"from {name}.").replace("import optdesign.", f"import {name}.")
                           .replace('"optdesign.', f'"{name}.'))
                    open(p, "w").write(src)
    sys.path.insert(0, base)
    return importlib.import_module(name)


def _best(fn, repeat):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return min(ts)


def _inputs(pkg, D, N, seed=0):
    cfg_mod = importlib.import_module(pkg.__name__ + ".config")
    ws_mod = importlib.import_module(pkg.__name__ + ".workspace")
    cfg = cfg_mod.load_config(os.path.join(ROOT, "configs", "p4s_paper.yaml"))
    rng = np.random.default_rng(seed)
    designs = {k: rng.uniform(dv.bounds[0], dv.bounds[1], D) for k, dv in cfg.design_variables.items() if dv.bounds}
    X = np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]
    return cfg, designs, ws_mod.Workspace(spec=cfg.workspace, names=("x", "y", "z"), X=X)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rev", default="8b1a6dd")
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    import optdesign

    old = _old_package(args.rev)
    rows = []
    for D, N in ((50, 1000), (1, 1_000_000)):
        times = {}
        results = {}
        for label, pkg in (("before", old), ("after", optdesign)):
            ev = importlib.import_module(pkg.__name__ + ".evaluate")
            cfg, designs, ws = _inputs(pkg, D, N)
            results[label] = ev.evaluate(cfg, designs, ws)          # first call: loads or compiles
            times[label] = _best(lambda: ev.evaluate(cfg, designs, ws), args.repeat)
        a, b = results["before"], results["after"]
        rel = 0.0
        for k in a.summary:
            for st in ("mean", "min", "max", "std"):
                x, y = np.asarray(a.summary[k][st]), np.asarray(b.summary[k][st])
                if not np.array_equal(np.isnan(x), np.isnan(y)):
                    rel = np.inf
                fin = np.isfinite(y) & (y != 0)
                if fin.any():
                    rel = max(rel, float(np.max(np.abs(x[fin] - y[fin]) / np.abs(y[fin]))))
        rows.append((f"evaluate, {D} x {N} points", D * N / times["before"] / 1e6, D * N / times["after"] / 1e6,
                     times["before"] / times["after"], "bitwise equal" if rel == 0 else f"max rel. difference {rel:.1e}"))

    print(f"earlier revision {args.rev}; load {os.getloadavg()[0]:.2f}; best of {args.repeat}")
    print("| case | before (M/s) | after (M/s) | after vs before (speed) | note |")
    print("|---|---:|---:|---:|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]:.1f} | {r[2]:.1f} | {r[3]:.2f} | {r[4]} |")


if __name__ == "__main__":
    main()
