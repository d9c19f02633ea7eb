"""The current kernels against an earlier version of ``_p4s_kernels.py`` (and
of ``_fk_kernels.py``, where that revision has it) in the same process (the
old file is taken from git and compiled into a temporary module with its own
numba cache), each called the way its wrapper called it:

* local indices (dynamic, stiffness, Frobenius isotropy), bare kernel incl.
  the per-design reductions: 50 designs x 1000 points and 1 design x 10^6
  points (the old kernel took three transposed coordinate arrays, made by
  its wrapper on every call);
* forward kinematics of 10^6 poses through ``P4S.forward`` (the compiled path) (new output
  array per call, and a reused one) against the old wrapper (transposed
  copy of the strokes, then the kernel).

    python benchmarks/bench_before_after.py [--rev 7765d43] [--repeat 15] [--threads 1 2]

Prints points (poses) per second, CPU/wall time of the best run (2 = both
cores busy) and the ratio; also checks that the local results are bitwise
those of the old kernel.  Run ``uptime`` alongside: on a shared machine the
2-thread figures depend on the other jobs.
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


def _old_kernels(rev: str, tmp: str, name: str = "_p4s_kernels"):
    """Module ``optdesign/fast/<name>.py`` of revision rev, or None if it has none."""
    return kernel_module(rev, name, tmp)


def _best(fn, repeat):
    bw, bc = math.inf, 0.0
    for _ in range(repeat):
        c = time.process_time()
        t = time.perf_counter()
        fn()
        w = time.perf_counter() - t
        c = time.process_time() - c
        if w < bw:
            bw, bc = w, c
    return bw, bc


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rev", default="7765d43", help="git revision of the old kernel file (default 7765d43)")
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args(argv)

    import numba

    from optdesign.mechanisms.p4s import compiled as fast
    from optdesign.mechanisms.p4s import P4S

    k = fast.LOCAL.get()
    tmp = tempfile.mkdtemp(prefix="optdesign_old_kernels_")
    os.environ.setdefault("NUMBA_CACHE_DIR", tmp)
    old = _old_kernels(args.rev, tmp)
    # the forward kinematics moved to _fk_kernels.py (its own module) after 8ae7683
    old_fk = _old_kernels(args.rev, tmp, "_fk_kernels") or old
    rng = np.random.default_rng(0)
    want = np.array([True, True, False, True, False])
    cases = []
    for D, N in [(50, 1000), (1, 1_000_000)]:
        mech = P4S(r_a=rng.uniform(0.21, 0.29, D)[:, None], r_b=rng.uniform(0.63, 0.71, D)[:, None], L=0.38,
                   d=0.12, phi=np.radians(rng.uniform(25, 35, D))[:, None])
        X = np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]
        P = fast.design_constants(mech)

        def before(P=P, X=X):
            T = np.ascontiguousarray(X.T)
            return old.p4s_summary(P, T[0], T[1], T[2], want, False)

        def after(P=P, X=X):
            return k.p4s_summary(P, np.ascontiguousarray(X), want, False)

        same = all(np.array_equal(a, b, equal_nan=True) for a, b in zip(before(), after()))
        cases.append((f"local indices, {D} x {N} points", D * N, before, after, "bitwise equal" if same else "DIFFER"))
    mech = P4S(r_a=0.21, r_b=0.71, L=0.38, d=0.12, phi=math.radians(35.0))
    N = 1_000_000
    X = np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]
    Q = mech.inverse(X)
    F = np.array([float(mech.r_b - mech.rho), math.cos(float(mech.phi)), math.sin(float(mech.phi)),
                  float(mech.L) ** 2, float(mech.L)])

    def fk_before():
        if old_fk.p4s_forward.py_func.__code__.co_argcount == 3:   # (F, Q, out)
            return old_fk.p4s_forward(F, Q, np.empty((N, 3)))
        T = np.ascontiguousarray(Q.T)
        return old_fk.p4s_forward(F, T[0], T[1], T[2])

    out = np.empty((N, 3))
    note = "max error %.1e -> %.1e m" % (np.abs(fk_before() - X).max(), np.abs(mech.forward(Q) - X).max())
    cases.append(("forward kinematics, 10^6 poses", N, fk_before, lambda: mech.forward(Q), note))
    cases.append(("forward kinematics, 10^6 poses, reused out", N, fk_before,
                  lambda: mech.forward(Q, out=out), ""))
    print(f"old kernels: {args.rev}; load: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")
    print("| threads | case | before (M/s, cpu/wall) | after (M/s, cpu/wall) | after / before | |")
    print("|---:|---|---:|---:|---:|---|")
    for nt in args.threads:
        numba.set_num_threads(min(nt, numba.config.NUMBA_NUM_THREADS))
        for name, n, bf, af, note in cases:
            bf()
            af()
            (wb, cb), (wa, ca) = _best(bf, args.repeat), _best(af, args.repeat)
            print(f"| {nt} | {name} | {n / wb / 1e6:.1f} ({cb / wb:.2f}) | {n / wa / 1e6:.1f} ({ca / wa:.2f}) "
                  f"| {wb / wa:.2f} | {note} |")
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
