"""Scaling of the 3-P(4S) local-index evaluation with workspace points and
population size: the engine (the mechanism's compiled path, through its
description) against the hand-written fused kernel it replaced (the reference
of benchmarks/p4s_hand_kernel.py) and the numpy path, in one process.

    python benchmarks/bench_scaling.py [--repeat 5] [--threads T] [--json]

Prints two tables: 1 design x 10^2 ... 10^6 points, and 10 ... 400 designs x
1000 points, with the best-of-``repeat`` wall time per call, nanoseconds per
point, points per second, and the numpy path's points per second on the same
inputs (measured up to 2e5 points per call; larger sizes reuse the rate of the
largest measured size, marked "*").  Cost is linear when ns/point stays flat.
"""
from __future__ import annotations

import argparse
import os
import sys
import json
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def _best(fn, repeat):
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return min(ts)


def _mech(D, seed=0):
    from optdesign.mechanisms.p4s import P4S

    if D == 1:   # the paper's optimum
        return P4S(r_a=0.21, r_b=0.71, L=0.38, d=0.12, phi=np.radians(35.0))
    rng = np.random.default_rng(seed)
    return P4S(r_a=rng.uniform(0.21, 0.29, D)[:, None], r_b=rng.uniform(0.63, 0.71, D)[:, None], L=0.38, d=0.12,
               phi=np.radians(rng.uniform(25, 35, D))[:, None])


def _points(N, seed=1):
    rng = np.random.default_rng(seed)
    return np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]


def _numpy_eval(mech, X):
    from optdesign.indices import cond_fro, sigma_max, sigma_min

    with np.errstate(all="ignore"):
        reach = mech.reachable(X)
        J = mech.jacobian(X)
        M = mech.mass_matrix(X)
        vals = [sigma_max(M), sigma_min(J) ** 2, cond_fro(J)]
        return [np.where(reach, v, 0.0).sum(-1) for v in vals]


def row(D, N, repeat, np_cache):
    import p4s_hand_kernel as hand

    from optdesign.mechanisms.base import IndexRequest

    mech = _mech(D)
    X = _points(N)
    req = [IndexRequest("dynamic", "dynamic", None), IndexRequest("stiffness", "stiffness", "lambda_min_K"),
           IndexRequest("isotropy", "isotropy", "frobenius")]
    mech.global_statistics(req, X)
    t = _best(lambda: mech.global_statistics(req, X), repeat)
    P = hand.design_constants(mech)
    w = np.array((True, True, False, True, False))
    hand.p4s_summary(P, X, w, False)
    tk = _best(lambda: hand.p4s_summary(P, X, w, False), repeat)
    if D * N <= 200_000:
        tn = _best(lambda: _numpy_eval(mech, X), max(1, min(repeat, 3)))
        np_rate = D * N / tn
        np_cache["last"] = np_rate
        mark = ""
    else:
        np_rate = np_cache.get("last", float("nan"))
        mark = "*"
    return {"designs": D, "points": N, "seconds": t, "ns_per_point": 1e9 * t / (D * N), "points_per_s": D * N / t,
            "kernel_points_per_s": D * N / tk, "numpy_points_per_s": np_rate, "numpy_extrapolated": bool(mark)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    import numba
    from _common import machine

    from optdesign import engine

    if args.threads:
        numba.set_num_threads(args.threads)
    if not engine.KERNELS.available():
        raise SystemExit(f"numba kernels unavailable: {engine.KERNELS.error}")
    np_cache: dict = {}
    pts = [row(1, N, args.repeat, np_cache) for N in (100, 1_000, 10_000, 100_000, 1_000_000)]
    des = [row(D, 1000, args.repeat, np_cache) for D in (10, 25, 50, 100, 200, 400)]
    out = {"machine": machine(), "points": pts, "designs": des}
    if args.json:
        print(json.dumps(out, indent=2))
        return
    m = out["machine"]
    print(f"{m.get('cpu')}, {m['cpus']} CPUs, numba {m.get('numba')} ({m.get('numba_threads')} threads), "
          f"best of {args.repeat}")
    for title, rows in (("1 design (the paper's optimum), N points", pts), ("D designs x 1000 points", des)):
        print(f"\n{title}")
        print("| designs | points | time per call | ns/point | points/s (engine) | points/s (hand kernel, reference) "
              "| points/s (numpy) | engine / numpy |")
        print("|---:|---:|---:|---:|---:|---:|---:|---:|")
        for r in rows:
            star = "*" if r["numpy_extrapolated"] else ""
            print(f"| {r['designs']} | {r['points']:,} | {1e3 * r['seconds']:.3f} ms | {r['ns_per_point']:.1f} "
                  f"| {r['points_per_s'] / 1e6:.1f} M | {r['kernel_points_per_s'] / 1e6:.1f} M "
                  f"| {r['numpy_points_per_s'] / 1e3:.0f} k{star} | {r['points_per_s'] / r['numpy_points_per_s']:,.0f} |")


if __name__ == "__main__":
    main()
