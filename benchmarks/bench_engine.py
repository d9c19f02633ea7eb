"""The one engine's targets (issue "One engine", item 3), measured as ratios in one run.

1. Compile once: with an empty numba cache (a temporary NUMBA_CACHE_DIR),
   ``optdesign evaluate`` of the Delta (the engine's first-ever compile), then
   of the Gough-Stewart (a new shape on a machine where the engine is
   compiled), then the Gough-Stewart again (warm), in fresh processes, the
   compiled path forced (OPTDESIGN_FAST=1).  Targets: the Gough-Stewart's
   first evaluate <= 3x its warm one; the first-ever compile <= 10x warm.
   The first-ever compile also records numba's compile events: the warm-up
   (optdesign.engine.warmup: a helper process and this one) must leave
   run_tasks's own compile nothing of the engine to compile (its routines
   are loaded from the cache the warm-up filled), only numba's own small
   helpers if any; the exit status is 1 otherwise.  (tests/test_engine.py
   checks the warm-up's lists against the kernel's calls from the source.)
2. The warm CLI: ``optdesign evaluate`` as a user runs it against
   OPTDESIGN_FAST=0 (the numpy path), interleaved, best of --runs.  Target:
   no slower.
3. Optimizer-sized calls (30 and 50 designs x 1000 points) against the
   asymptotic rate (50 designs x 20 000 points) of ``global_statistics``,
   for the 3-P(4S), the Delta and the Gough-Stewart.  Target: at least half.
4. The Gough-Stewart's rate (25 designs x its 4096 points, its four indices)
   on the generic and the specialized tier against the revision --base
   (today's kernel before the engine: its tree exported with git archive, run
   in a subprocess beside this one).  Target: at least 0.9x (the tier a large
   run takes: engine.specialize).
5. The 3-P(4S) on the engine against the hand-written fused kernel it
   replaced (benchmarks/p4s_hand_kernel.py, the reference), 50 x 1000 and
   1 x 10^6 points.

    python benchmarks/bench_engine.py [--base 8a2a31d] [--runs 3] [--skip 1,4]

The machine may be shared: the load is printed with each part; the ratios
are the point.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))


def load() -> str:
    return "load {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def cli(args, env=None, tree=ROOT) -> float:
    """Wall seconds of ``optdesign ARGS`` in a fresh process (output discarded)."""
    e = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg", **(env or {}))
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "optdesign", *args], cwd=tree, env=e, capture_output=True, text=True)
    dt = time.perf_counter() - t
    if p.returncode != 0:
        raise SystemExit(f"optdesign {' '.join(args)} failed: {p.stderr.strip()[-400:]}")
    return dt


#: ``optdesign ARGV`` with numba's compile events recorded: the engine's
#: routines compiled inside run_tasks's own compile are printed last (INSIDE [...])
_WATCHED = """
import sys
from numba.core import event
from optdesign.cli import main
depth, inside = [0], []
class L(event.Listener):
    def on_start(self, ev):
        name = ev.data["dispatcher"].py_func.__name__
        if depth[0] and name != "run_tasks":
            inside.append(ev.data["dispatcher"].py_func.__qualname__)
        if name == "run_tasks":
            depth[0] += 1
    def on_end(self, ev):
        if ev.data["dispatcher"].py_func.__name__ == "run_tasks":
            depth[0] -= 1
event.register("numba:compile", L())
rc = main(sys.argv[1:])
print("INSIDE", sorted(set(inside)))
sys.exit(rc)
"""


def first_compile(env) -> tuple[float, list[str]]:
    """Wall seconds of the Delta's ``optdesign evaluate`` (the engine's first
    compile, in the empty cache of ``env``) and the engine's routines compiled
    inside run_tasks's compile (qualified names with the cache key)."""
    from optdesign.engine.digest import leaf_key

    e = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", OPTDESIGN_KERNEL="generic", **env)
    e.pop("OPTDESIGN_WARMUP", None)
    t = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", _WATCHED, "evaluate", "configs/delta.yaml"], cwd=ROOT, env=e,
                       capture_output=True, text=True)
    dt = time.perf_counter() - t
    if p.returncode != 0:
        raise SystemExit(f"optdesign evaluate configs/delta.yaml failed: {p.stderr.strip()[-400:]}")
    (line,) = [x for x in p.stdout.splitlines() if x.startswith("INSIDE ")]
    inside = [q for q in line[len("INSIDE ["):-1].replace("'", "").split(", ") if q]
    return dt, [q for q in inside if q.endswith(leaf_key())]


def part1(runs) -> bool:
    """Prints the ratios; False if run_tasks's compile compiled an engine routine itself."""
    print(f"1. compile once ({load()})")
    with tempfile.TemporaryDirectory() as cache:
        env = {"NUMBA_CACHE_DIR": cache, "OPTDESIGN_FAST": "1"}
        d_first, inside = first_compile(env)
        g_first = cli(["evaluate", "configs/gough_stewart.yaml"], env)
        d_warm = min(cli(["evaluate", "configs/delta.yaml"], env) for _ in range(runs))
        g_warm = min(cli(["evaluate", "configs/gough_stewart.yaml"], env) for _ in range(runs))
    print(f"   Delta first (the engine compiles) {d_first:6.1f} s, warm {d_warm:5.2f} s: {d_first / d_warm:5.1f}x "
          f"(target <= 10)")
    print(f"   Gough-Stewart first after it      {g_first:6.1f} s, warm {g_warm:5.2f} s: {g_first / g_warm:5.1f}x "
          f"(target <= 3)")
    print(f"   engine routines compiled inside run_tasks's compile: {', '.join(inside) or 'none'} (target: none)")
    return not inside


def part2(runs):
    print(f"2. warm CLI evaluate, default against OPTDESIGN_FAST=0, best of {runs} ({load()})")
    for cfg in ("p4s_paper", "delta", "gough_stewart"):
        args = ["evaluate", f"configs/{cfg}.yaml"]
        cli(args)
        best = {"default": np.inf, "numpy": np.inf}
        for _ in range(runs):
            best["default"] = min(best["default"], cli(args))
            best["numpy"] = min(best["numpy"], cli(args, {"OPTDESIGN_FAST": "0"}))
        print(f"   {cfg:14s} default {best['default']:5.2f} s, numpy {best['numpy']:5.2f} s: "
              f"{best['default'] / best['numpy']:4.2f}x (target <= 1)")


def _rate(cls, params, cfg, req, X, D, repeat=5):
    from optdesign.mechanisms.base import IndexRequest  # noqa: F401

    rng = np.random.default_rng(D)
    des = {k: dv.value * rng.uniform(0.99, 1.01, (D, 1)) for k, dv in cfg.design_variables.items()}
    best = np.inf
    for _ in range(repeat):
        mech = cls(**{**params, **des})          # a new population: its constants packed again, as in a run
        t = time.perf_counter()
        mech.global_statistics(req, X)
        best = min(best, time.perf_counter() - t)
    return D * len(X) / best


def part3():
    from optdesign.config import load_config
    from optdesign.evaluate import index_requests, mechanism_class, workspace_of

    print(f"3. optimizer-sized calls against the asymptotic rate ({load()})")
    for name in ("p4s_paper", "delta", "gough_stewart"):
        cfg = load_config(ROOT / "configs" / f"{name}.yaml")
        W = workspace_of(cfg).X
        lo, hi = W.min(0), W.max(0)
        rng = np.random.default_rng(0)
        Xbig = lo + (hi - lo) * rng.random((20_000, W.shape[1]))
        cls, req = mechanism_class(cfg), index_requests(cfg, list(cfg.indices))
        _rate(cls, cfg.parameters, cfg, req, Xbig[:1000], 5, 1)
        big = _rate(cls, cfg.parameters, cfg, req, Xbig, 50, 3)
        rows = [f"{D} x 1000 {_rate(cls, cfg.parameters, cfg, req, Xbig[:1000], D) / big:4.2f}" for D in (30, 50)]
        print(f"   {name:14s} asymptotic {big / 1e6:6.2f} M points/s; " + ", ".join(rows) + " of it (target >= 0.5)")


_GS_RATE = """
import sys, time, numpy as np
from optdesign.config import load_config
from optdesign.evaluate import index_requests, mechanism_class, workspace_of
cfg = load_config("configs/gough_stewart.yaml")
X = workspace_of(cfg).X
rng = np.random.default_rng(2)
des = {k: dv.value * rng.uniform(0.95, 1.05, (25, 1)) for k, dv in cfg.design_variables.items()}
cls = mechanism_class(cfg)
req = index_requests(cfg, list(cfg.indices))
mech = cls(**{**cfg.parameters, **des})
mech.global_statistics(req, X)
best = 1e9
for _ in range(int(sys.argv[1])):
    mech = cls(**{**cfg.parameters, **des})
    t = time.perf_counter(); mech.global_statistics(req, X); best = min(best, time.perf_counter() - t)
print(25 * len(X) / best)
"""


def _base_tree(rev: str) -> Path:
    sha = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short=12", rev], check=True, capture_output=True,
                         text=True).stdout.strip()
    d = Path(tempfile.gettempdir()) / f"optdesign_tree_{sha}"
    if not (d / ".complete").exists():
        d.mkdir(parents=True, exist_ok=True)
        arch = subprocess.run(["git", "-C", str(ROOT), "archive", sha], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(d)], input=arch, check=True)
        (d / ".complete").touch()
    return d


def _gs(tree: Path, repeat: int, env=None) -> float:
    e = dict(os.environ, PYTHONPATH=str(tree), **(env or {}))
    p = subprocess.run([sys.executable, "-c", _GS_RATE, str(repeat)], cwd=tree, env=e, capture_output=True, text=True,
                       check=True)
    return float(p.stdout.strip().splitlines()[-1])


def part4(base, runs):
    tree = _base_tree(base)
    _gs(tree, 1)                 # its kernels compiled (once: kept with the tree)
    _gs(ROOT, 1, {"OPTDESIGN_KERNEL": "specialized"})
    print(f"4. Gough-Stewart, 25 designs x 4096 points, all four indices, best of {runs} runs ({load()})")
    best = {"base": 0.0, "generic": 0.0, "specialized": 0.0}
    for _ in range(runs):
        best["base"] = max(best["base"], _gs(tree, 5))
        best["generic"] = max(best["generic"], _gs(ROOT, 5, {"OPTDESIGN_KERNEL": "generic"}))
        best["specialized"] = max(best["specialized"], _gs(ROOT, 5, {"OPTDESIGN_KERNEL": "specialized"}))
    print(f"   {base}: {best['base'] / 1e6:5.2f} M points/s; generic tier {best['generic'] / 1e6:5.2f} "
          f"({best['generic'] / best['base']:4.2f}x); specialized tier {best['specialized'] / 1e6:5.2f} "
          f"({best['specialized'] / best['base']:4.2f}x, target >= 0.9)")


def part5(repeat=5):
    import p4s_hand_kernel as hand

    from optdesign.mechanisms.base import IndexRequest
    from optdesign.mechanisms.p4s import P4S

    print(f"5. 3-P(4S): the engine against the hand-written kernel it replaced (the reference) ({load()})")
    req = [IndexRequest("dynamic", "dynamic", None), IndexRequest("stiffness", "stiffness", "lambda_min_K"),
           IndexRequest("isotropy", "isotropy", "frobenius")]
    w = np.array((True, True, False, True, False))
    rng = np.random.default_rng(0)
    for D, N in ((50, 1000), (1, 1_000_000)):
        mech = P4S(r_a=rng.uniform(0.21, 0.29, (D, 1)), r_b=rng.uniform(0.63, 0.71, (D, 1)), L=0.38, d=0.12,
                   phi=np.radians(rng.uniform(25, 35, (D, 1))))
        X = np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]
        P = hand.design_constants(mech)
        mech.global_statistics(req, X)
        hand.p4s_summary(P, X, w, False)
        te = th = np.inf
        for _ in range(repeat):
            t = time.perf_counter()
            mech.global_statistics(req, X)
            te = min(te, time.perf_counter() - t)
            t = time.perf_counter()
            hand.p4s_summary(P, X, w, False)
            th = min(th, time.perf_counter() - t)
        print(f"   {D} x {N}: engine {D * N / te / 1e6:6.2f} M points/s, hand kernel {D * N / th / 1e6:6.2f}: "
              f"the hand kernel {te / th:4.2f}x faster")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="8a2a31d", help="revision of part 4's baseline (default 8a2a31d)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--skip", default="", help="parts to leave out, e.g. 1,4")
    args = ap.parse_args(argv)
    skip = {int(x) for x in args.skip.split(",") if x.strip()}
    os.chdir(ROOT)
    ok = True
    if 1 not in skip:
        ok = part1(args.runs)
    if 2 not in skip:
        part2(args.runs)
    if 3 not in skip:
        part3()
    if 4 not in skip:
        part4(args.base, args.runs)
    if 5 not in skip:
        part5()
    print(json.dumps({"done": True, "load": os.getloadavg()}))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
