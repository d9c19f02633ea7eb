"""Forward kinematics (``P4S.forward`` (the compiled path)) against an earlier version of the
FK kernel in the same process: the old kernel file is taken from git
(``optdesign/fast/_fk_kernels.py`` of that revision, or ``_p4s_kernels.py``
before the FK kernels had a module of their own) and compiled into a
temporary module with its own numba cache.  Both sides are called alike
(strokes (N, 3), a new output array per call) on the same strokes, alternately,
best of --repeat runs for each thread count and size; also the accuracy of
both on random designs and poses (the ranges of ``tests/test_p4s_compiled.py``).

    python benchmarks/bench_fk.py [--rev 8ae7683] [--repeat 11] [--threads 1 2] [--sizes 100000 1000000]

Prints poses per second of the best run and CPU/wall of that side over a
sustained series of calls (0.5 s; 2 = both cores busy: per call, the CPU
time of the second thread is accounted in lumps and is not reliable).
Run ``uptime`` alongside: on a shared machine the 2-thread figures depend on
the other jobs.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _revision import kernel_module  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def old_fk_module(rev: str, tmp: str):
    """The FK kernels of revision rev (in ``_fk_kernels.py``, or in ``_p4s_kernels.py`` before they moved)."""
    for name in ("_fk_kernels", "_p4s_kernels"):
        mod = kernel_module(rev, name, tmp)
        if mod is not None:
            return mod
    raise SystemExit(f"no FK kernel file at {rev}")


def constants(mech) -> np.ndarray:
    return np.array([float(mech.r_b - mech.rho), math.cos(float(mech.phi)), math.sin(float(mech.phi)),
                     float(mech.L) ** 2, float(mech.L)])


def accuracy(kernel, designs: int = 60, poses: int = 20_000, seed: int = 5):
    """(max |P - X| where cond(J) < 1000, max |P - P4S.forward| there, max |P - X|
    over all reachable poses, number of poses where the test's bound
    err <= 2 err_numpy + 1e-13 fails) for kernel(F, Q) -> P."""
    from optdesign.indices import cond_2
    from optdesign.mechanisms.p4s import P4S

    rng = np.random.default_rng(seed)
    e_wc = d_wc = e_all = 0.0
    nbad = 0
    for _ in range(designs):
        mech = P4S(r_a=rng.uniform(0.18, 0.32), r_b=rng.uniform(0.58, 0.76), L=rng.uniform(0.34, 0.42),
                   d=rng.uniform(0.05, 0.15), phi=math.radians(rng.uniform(20, 40)))
        X = np.c_[rng.uniform(-0.12, 0.12, poses), rng.uniform(-0.12, 0.12, poses), rng.uniform(0.40, 0.70, poses)]
        with np.errstate(all="ignore"):
            Q = mech.inverse(X)
            ok = np.all(np.isfinite(Q), axis=-1)
            Q, X = np.ascontiguousarray(Q[ok]), X[ok]
            cond = cond_2(mech.jacobian(X))
            P0 = mech.forward(Q)
        P = kernel(constants(mech), Q)
        err = np.abs(P - X).max(axis=-1)
        err0 = np.abs(P0 - X).max(axis=-1)
        wc = cond < 1e3
        e_wc = max(e_wc, err[wc].max())
        d_wc = max(d_wc, np.abs(P - P0)[wc].max())
        e_all = max(e_all, err.max())
        nbad += int(np.sum(~(err <= 2 * err0 + 1e-13)))
    return e_wc, d_wc, e_all, nbad


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rev", default="8ae7683", help="git revision of the old kernel (default 8ae7683)")
    ap.add_argument("--repeat", type=int, default=11)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--no-accuracy", action="store_true")
    args = ap.parse_args(argv)

    import numba

    from optdesign.mechanisms.p4s import compiled as fast
    from optdesign.mechanisms.p4s import P4S

    new = fast.FK.get()
    tmp = tempfile.mkdtemp(prefix="optdesign_old_fk_")
    os.environ.setdefault("NUMBA_CACHE_DIR", tmp)
    old = old_fk_module(args.rev, tmp)

    def run_old(F, Q):
        return old.p4s_forward(F, Q, np.empty(Q.shape))

    def run_new(F, Q):
        return new.p4s_forward(F, Q, np.empty(Q.shape))

    if not args.no_accuracy:
        for name, fn in (("before", run_old), ("after", run_new)):
            e_wc, d_wc, e_all, nbad = accuracy(fn)
            print(f"accuracy {name}: max |P - X| (cond < 1000) {e_wc:.2e} m, max |P - P4S.forward| (cond < 1000) "
                  f"{d_wc:.2e} m, max |P - X| (all) {e_all:.2e} m, test bound exceeded at {nbad} poses")

    mech = P4S(r_a=0.21, r_b=0.71, L=0.38, d=0.12, phi=math.radians(35.0))
    F = constants(mech)
    rng = np.random.default_rng(0)
    print(f"old kernel: {args.rev}; load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")
    print("| threads | poses | before M/s (cpu/wall) | after M/s (cpu/wall) | after / before | max error before, after |")
    print("|---:|---:|---:|---:|---:|---|")
    for nt in args.threads:
        numba.set_num_threads(min(nt, numba.config.NUMBA_NUM_THREADS))
        for N in args.sizes:
            X = np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]
            Q = np.ascontiguousarray(mech.inverse(X))
            ea = np.abs(run_old(F, Q) - X).max()
            eb = np.abs(run_new(F, Q) - X).max()
            best = {"old": math.inf, "new": math.inf}
            for _ in range(args.repeat):      # alternate, so that both see the same load
                for key, fn in (("old", run_old), ("new", run_new)):
                    t = time.perf_counter()
                    fn(F, Q)
                    best[key] = min(best[key], time.perf_counter() - t)
            # CPU/wall over a sustained series (>= 0.5 s; per call, the CPU time
            # of the other thread is accounted in lumps)
            ratio = {}
            for key, fn in (("old", run_old), ("new", run_new)):
                c = time.process_time()
                t0 = t = time.perf_counter()
                while t - t0 < 0.5:
                    fn(F, Q)
                    t = time.perf_counter()
                ratio[key] = (time.process_time() - c) / (t - t0)
            wo, wn = best["old"], best["new"]
            print(f"| {nt} | {N:,} | {N / wo / 1e6:.1f} ({ratio['old']:.2f}) | {N / wn / 1e6:.1f} ({ratio['new']:.2f}) "
                  f"| {wo / wn:.2f} | {ea:.1e}, {eb:.1e} |", flush=True)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
