"""The current local-index kernel (``optdesign/mechanisms/p4s/kernels.py``) against
the one of an earlier revision whose kernel has the current signature
(``p4s_summary(P, X, want, want_two)``, ``p4s_local(P, X, want_two)`` with X
(N, 3) C-contiguous; b3b39c7 and later), in the same process: the old file is
taken from git and compiled as a module of its own (in a directory under the
temp dir that is kept between runs, so its numba cache is reused).

* speed of the bare kernel ``p4s_summary`` (incl. the per-design reductions),
  indices dynamic, stiffness, Frobenius isotropy (as ``bench_throughput.py``
  calls it): 50 random designs in the paper config's box x 1000 points (made
  as ``benchmarks/_common.setup`` makes them) and 1 design x 10^6
  points, on 1 and 2 threads, best of ``--repeat`` runs, CPU/wall of the best
  run (2 = both cores busy);
* bitwise equality (``np.array_equal(..., equal_nan=True)`` on every output:
  stats, counts, reach codes, code-2 counts; values and codes of
  ``p4s_local``) with want_two False and True, on the bench inputs and on
  random designs/poses over the wider ranges of ``tests/test_p4s_compiled.py``
  (unreachable and near-singular points included), plus the workspace centre
  and poses along the axis across the reachable range.

    python benchmarks/bench_kernel_ab.py [--rev b3b39c7] [--repeat 9] [--threads 1 2] [--no-check]
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))

from _common import setup as _setup
from _revision import kernel_module  # noqa: E402
from bench_before_after import _best  # noqa: E402


def _old_kernels(rev: str):
    """``optdesign/mechanisms/p4s/kernels.py`` of revision rev as a module (kept in a
    directory of its own under the temp dir, so its numba cache survives)."""
    mod = kernel_module(rev)
    if mod is None:
        raise SystemExit(f"no optdesign/mechanisms/p4s/kernels.py at {rev}")
    return mod


def _bench_inputs(D, N, seed=0):
    from optdesign.mechanisms.p4s import compiled as fast
    from optdesign.config import load_config
    from optdesign.mechanisms.p4s import P4S

    cfg = load_config(os.path.join(ROOT, "configs", "p4s_paper.yaml"))
    designs, ws = _setup(cfg, D, N, seed)
    params = dict(cfg.parameters)
    params.update({k: dv.value for k, dv in cfg.design_variables.items()})
    params.update({k: np.asarray(v)[:, None] for k, v in designs.items()})
    return fast.design_constants(P4S(**params)), np.ascontiguousarray(ws.X, dtype=float)


def _wide_inputs(D, N, seed):
    """Designs and poses over the ranges of tests/test_p4s_compiled.py (many points
    unreachable, some near-singular), plus special poses."""
    from optdesign.mechanisms.p4s import compiled as fast
    from optdesign.mechanisms.p4s import P4S

    rng = np.random.default_rng(seed)
    des = dict(r_a=rng.uniform(0.18, 0.32, D), r_b=rng.uniform(0.58, 0.76, D), L=rng.uniform(0.34, 0.42, D),
               d=rng.uniform(0.05, 0.15, D), phi=np.radians(rng.uniform(20, 40, D)))
    X = np.c_[rng.uniform(-0.12, 0.12, N), rng.uniform(-0.12, 0.12, N), rng.uniform(0.40, 0.70, N)]
    X[0] = [0.0, 0.0, 0.57]
    X[1] = [0.0, 0.0, 0.50]
    X[2] = [0.0, 0.0, 0.0]
    mech = P4S(**{k: np.asarray(v)[:, None] for k, v in des.items()})
    P = fast.design_constants(mech)
    # poses on the axis across the reachable range (in and out of reach) and
    # the same shifted by 1e-9 m
    z0 = np.linspace(0.3, 0.9, 2001)
    Xb = np.c_[np.zeros_like(z0), np.zeros_like(z0), z0]
    X = np.ascontiguousarray(np.r_[X, Xb, Xb + 1e-9])
    return P, X


def check_bitwise(new, old, cases):
    ok = True
    lines = []
    for name, P, X in cases:
        for two in (False, True):
            for wname, want in (("dyn,stiff2,fro", np.array([True, True, False, True, False])),
                                ("all", np.array([True, True, True, True, True])),
                                ("fro", np.array([False, False, False, True, False])),
                                ("stiff1,two", np.array([False, False, True, False, True]))):
                a = old.p4s_summary(P, X, want, two)
                b = new.p4s_summary(P, X, want, two)
                same = len(a) == len(b) and all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b))
                ok &= same
                lines.append(f"  p4s_summary {name}, want={wname}, two={two}: {'bitwise equal' if same else 'DIFFER'}")
            a = old.p4s_local(P, X, two)
            b = new.p4s_local(P, X, two)
            same = all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b))
            ok &= same
            codes = np.bincount(b[1].ravel(), minlength=3)
            lines.append(f"  p4s_local   {name}, two={two}: {'bitwise equal' if same else 'DIFFER'} "
                         f"(codes 0/1/2: {codes[0]}/{codes[1]}/{codes[2]})")
    return ok, lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rev", default="b3b39c7", help="git revision of the old kernel file (default b3b39c7)")
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--no-check", action="store_true",
                    help="timings only (the check compiles the want_two=True variants too)")
    args = ap.parse_args(argv)

    import numba

    from optdesign.mechanisms.p4s import compiled as fast

    new = fast.LOCAL.get()
    old = _old_kernels(args.rev)
    want = np.array([True, True, False, True, False])

    if not args.no_check:
        cases = [("bench 50 x 1000", *_bench_inputs(50, 1000)),
                 ("bench 1 x 10^5", *_bench_inputs(1, 100_000, seed=3)),
                 ("wide 40 x 5000", *_wide_inputs(40, 5000, seed=7)),
                 ("wide 7 x 777", *_wide_inputs(7, 777, seed=11))]
        ok, lines = check_bitwise(new, old, cases)
        print("bitwise check against", args.rev, ":", "ALL EQUAL" if ok else "DIFFERENCES")
        print("\n".join(lines))

    timing = []
    for D, N in [(50, 1000), (1, 1_000_000)]:
        P, X = _bench_inputs(D, N)
        timing.append((f"{D} x {N} points", D * N, P, X))
    print(f"old kernel: {args.rev}; load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")
    print("| threads | case | before (M/s, cpu/wall) | after (M/s, cpu/wall) | after / before |")
    print("|---:|---|---:|---:|---:|")
    for nt in args.threads:
        numba.set_num_threads(min(nt, numba.config.NUMBA_NUM_THREADS))
        for name, n, P, X in timing:
            def bf(P=P, X=X):
                return old.p4s_summary(P, X, want, False)

            def af(P=P, X=X):
                return new.p4s_summary(P, X, want, False)

            bf()
            af()
            # interleave the two so that a change of load hits both alike
            wb = ca = cb = wa = np.inf
            for _ in range(args.repeat):
                w, c = _best(bf, 1)
                if w < wb:
                    wb, cb = w, c
                w, c = _best(af, 1)
                if w < wa:
                    wa, ca = w, c
            print(f"| {nt} | {name} | {n / wb / 1e6:.1f} ({cb / wb:.2f}) | {n / wa / 1e6:.1f} ({ca / wa:.2f}) "
                  f"| {wb / wa:.2f} |", flush=True)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
