"""Points per second of the local index evaluation of the paper config: a
per-point Python loop, the numpy path and the compiled path (all in this one
process), poses per second of forward kinematics, and the wall time of
``optdesign reproduce`` run in fresh processes.

    python benchmarks/bench_throughput.py [--points 1000] [--designs 50] [--repeat 7]
        [--threads T] [--no-reproduce] [--numpy-only] [--json]

(also ``optdesign bench throughput ...``).  The inputs: ``--designs`` random
designs in the config's box x ``--points`` random points around the paper's
workspace plane (``_common.setup``).  The numpy path is timed on at most
``--numpy-max`` design x point pairs; ``--numpy-only`` skips every compiled
path (and the reproduce timing): a check that runs in seconds.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from contextlib import nullcontext

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _common import best as _best
from _common import machine
from _common import setup as _setup


def _mechanism(cfg, designs, scalar: bool):
    """The config's mechanism for the bench designs (first one if ``scalar``)."""
    import numpy as np

    from optdesign.evaluate import build

    params = {k: dv.value for k, dv in cfg.design_variables.items()}
    params.update({k: (float(v[0]) if scalar else np.asarray(v)[:, None]) for k, v in designs.items()})
    return build(cfg, params)


def python_loop_rate(cfg, n: int) -> float:
    """Points per second of a straightforward per-point loop (one design, one
    point at a time through the mechanism's numpy methods and the index functions)."""
    import numpy as np

    from optdesign import fast
    from optdesign.indices import local_index

    designs, ws = _setup(cfg, 1, n, seed=1)
    mech = _mechanism(cfg, designs, scalar=True)
    t = time.perf_counter()
    with np.errstate(all="ignore"), fast.disabled():
        for j in range(ws.n):
            x = ws.X[j:j + 1]
            if not mech.reachable(x)[0]:
                continue
            J = mech.jacobian(x)
            M = mech.mass_matrix(x)
            for spec in cfg.indices.values():
                local_index(spec.kind, J=J, M=M, convention=spec.convention, options=spec.options)
    return ws.n / (time.perf_counter() - t)


def local_rates(cfg, D: int, N: int, repeat: int, numpy_max: int, compiled: bool = True) -> dict:
    """Points per second of evaluate() on the numpy path and on the compiled
    path (and of the mechanism's bare kernel call, where it offers one), D designs x N points."""
    import numpy as np

    from optdesign import fast
    from optdesign.evaluate import evaluate, index_requests
    from optdesign.workspace import Workspace

    designs, ws = _setup(cfg, D, N)
    out = {"designs": D, "points": N}
    # numpy path on at most numpy_max pairs (fewer designs, then fewer points)
    Dn = max(1, min(D, numpy_max // max(N, 1)))
    Nn = min(N, max(1, numpy_max // Dn))
    dn = {k: v[:Dn] for k, v in designs.items()}
    wsn = Workspace(spec=ws.spec, names=ws.names, X=ws.X[:Nn])
    with fast.disabled():
        evaluate(cfg, dn, wsn, errors=False)
        b, med = _best(lambda: evaluate(cfg, dn, wsn, errors=False), max(1, min(repeat, 3)))
    out["numpy"] = {"designs": Dn, "points": Nn, "seconds": b, "median_seconds": med, "points_per_s": Dn * Nn / b}
    if not compiled:
        return out
    mech = _mechanism(cfg, designs, scalar=False)
    fast.set_enabled(True)
    try:
        t = time.perf_counter()
        answer = mech.global_statistics(index_requests(cfg), ws.X)   # loads (or compiles) the kernels
        first = time.perf_counter() - t
        if answer is None:
            out["fast"] = None
            out["fast_error"] = f"mechanism {cfg.mechanism!r} has no compiled path here for these indices"
            return out
        ev = evaluate(cfg, designs, ws, errors=False)   # the timing is of the global indices alone
        b, med = _best(lambda: evaluate(cfg, designs, ws, errors=False), repeat)
    finally:
        fast.set_enabled(None)
    out["fast"] = {"first_call_seconds": first, "seconds": b, "median_seconds": med, "points_per_s": D * N / b,
                   "reachable_fraction": float(np.mean(ev.reachable_fraction))}
    # the bare kernel (no dispatch, no LAPACK hand-off of ill-conditioned points)
    bare = getattr(mech, "bare_kernel", None)
    if bare is not None:
        call, lapack = bare(ws.X)
        call()
        b, med = _best(call, repeat)
        out["kernel"] = {"seconds": b, "median_seconds": med, "points_per_s": D * N / b, "lapack_fraction": lapack}
    return out


def fk_rates(cfg, N: int, repeat: int, compiled_path: bool = True) -> dict:
    """Poses per second of forward kinematics through the public API: the numpy
    model and the compiled path (the config's ``after`` design, else its first)."""
    import numpy as np

    from optdesign import fast
    from optdesign.evaluate import build

    name = "after" if "after" in cfg.designs else next(iter(cfg.designs))
    mech = build(cfg, name)
    rng = np.random.default_rng(2)
    X = np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]
    with nullcontext() if compiled_path else fast.disabled():
        Q = mech.inverse(X)
    Nn = min(N, 100_000)
    with fast.disabled():
        best_np, _ = _best(lambda: mech.forward(Q[:Nn]), max(1, min(repeat, 3)))
    out = {"poses": N, "design": name, "numpy": {"poses": Nn, "seconds": best_np, "poses_per_s": Nn / best_np}}
    if not compiled_path:
        return out
    fast.set_enabled(True)
    try:
        P = mech.forward(Q)
        with fast.disabled():
            compiled = not np.array_equal(P[:100], mech.forward(Q[:100]), equal_nan=True)
        b, med = _best(lambda: mech.forward(Q), repeat)
    finally:
        fast.set_enabled(None)
    if compiled:
        out["fast"] = {"seconds": b, "median_seconds": med, "poses_per_s": N / b,
                       "max_error_m": float(np.max(np.abs(P - X)))}
    return out


def reproduce_time(min_points: int, pareto: bool = True) -> dict:
    """Wall time of ``optdesign reproduce`` (a fresh process, start-up included)
    on the paper's config with its workspace grid refined to at least
    ``min_points`` points: twice with the default ``--jobs`` (the second run
    finds the compiled kernels cached on disk), then once with ``--jobs 1``
    (the stages one after the other in one process) as the baseline."""
    from importlib.resources import files

    import yaml

    from optdesign.optimize.pipeline import default_jobs

    data = yaml.safe_load((files("optdesign") / "data" / "p4s_paper.yaml").read_text())
    ws = data["workspace"]
    per_axis = max(2, math.ceil(math.sqrt(min_points)))
    ws.pop("step", None)
    ws["points_per_axis"] = per_axis
    res = {"workspace_points": per_axis * per_axis, "pareto": pareto, "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        cfg = os.path.join(tmp, "p4s_bench.yaml")
        with open(cfg, "w") as f:
            yaml.safe_dump(data, f)
        cmd = [sys.executable, "-m", "optdesign.cli", "reproduce", cfg, "--out", os.path.join(tmp, "runs"), "--quiet"]
        if not pareto:
            cmd.append("--no-pareto")
        for jobs in (None, None, 1):
            t = time.perf_counter()
            p = subprocess.run(cmd + (["--jobs", str(jobs)] if jobs else []), check=False, capture_output=True, text=True)
            dt = time.perf_counter() - t
            res["runs"].append({"seconds": dt, "exit_status": p.returncode, "jobs": jobs or default_jobs()})
            if p.returncode != 0:
                res["error"] = (p.stderr or p.stdout).strip().splitlines()[-1:]
                break
    t = time.perf_counter()
    code = ("import optdesign.cli, optdesign.evaluate as e; "
            "from optdesign.commands._common import open_config as o; c = o(None); e.evaluate(c, [c.initial_design()])")
    subprocess.run([sys.executable, "-c", code], check=False, capture_output=True)
    res["startup_seconds"] = time.perf_counter() - t
    return res


def measure(args) -> dict:
    from optdesign.commands._common import open_config

    compiled = not args.numpy_only
    cfg = open_config(None)
    res = {"machine": machine()}
    loop = python_loop_rate(cfg, args.loop_points)
    res["python_loop"] = {"points": args.loop_points, "points_per_s": loop}
    res["local"] = local_rates(cfg, args.designs, args.points, args.repeat, args.numpy_max, compiled)
    res["fk"] = fk_rates(cfg, args.fk_poses, args.repeat, compiled)
    if compiled and not args.no_reproduce:
        res["reproduce"] = reproduce_time(args.reproduce_points)
    return res


def report(res: dict, args) -> None:
    from optdesign.tables import print_table

    m = res["machine"]
    load = ", ".join(f"{x:.2f}" for x in m["load"]) if m.get("load") else "?"
    print(f"machine: {m.get('cpu')}, {m['cpus']} CPUs, load average {load}; numba {m.get('numba')} "
          f"({m.get('numba_threads')} threads, {m.get('threading_layer')}); numpy {m['numpy']}")
    loc = res["local"]
    npr = loc["numpy"]["points_per_s"]
    loop = res["python_loop"]["points_per_s"]
    rows = [["per-point Python loop", f"1 x {args.loop_points}", f"{loop:,.0f}", f"{loop / npr:.3g}"],
            ["numpy path (evaluate)", f"{loc['numpy']['designs']} x {loc['numpy']['points']}", f"{npr:,.0f}", "1"]]
    if loc.get("fast"):
        f = loc["fast"]["points_per_s"]
        rows.append(["fast path (evaluate)", f"{args.designs} x {args.points}", f"{f:,.0f}", f"{f / npr:,.0f}"])
    if loc.get("kernel"):
        kr = loc["kernel"]["points_per_s"]
        rows.append(["fused kernel alone", f"{args.designs} x {args.points}", f"{kr:,.0f}", f"{kr / npr:,.0f}"])
    print(f"\nlocal indices (dynamic, stiffness, isotropy) per workspace point, best of {args.repeat}:")
    print_table(["path", "designs x points", "points/s", "vs numpy"], rows)
    if loc.get("fast_error"):
        print(loc["fast_error"])
    if loc.get("kernel"):
        print(f"first fast call (kernel load or compile): {loc['fast']['first_call_seconds']:.2f} s; "
              f"points handed to LAPACK (cond(J) >= 1000): {100 * loc['kernel']['lapack_fraction']:.2f}%")
    fk = res["fk"]
    rows = [["numpy model forward", f"{fk['numpy']['poses']}", f"{fk['numpy']['poses_per_s']:,.0f}", "1", "-"]]
    if fk.get("fast"):
        ff = fk["fast"]
        rows.append(["compiled forward (public API)", f"{fk['poses']}", f"{ff['poses_per_s']:,.0f}",
                     f"{ff['poses_per_s'] / fk['numpy']['poses_per_s']:,.0f}", f"{ff['max_error_m']:.1e}"])
    print("\nforward kinematics:")
    print_table(["path", "poses", "poses/s", "vs numpy", "max error [m]"], rows)
    if "reproduce" in res:
        r = res["reproduce"]
        runs = ", ".join(f"{x['seconds']:.2f} s (--jobs {x['jobs']})" for x in r["runs"])
        print(f"\noptdesign reproduce ({r['workspace_points']} workspace points per design, Pareto runs included), "
              f"wall time in fresh processes: {runs}; start-up (imports, kernel load): "
              f"{r['startup_seconds']:.2f} s")
        if len(r["runs"]) == 3 and all(x["exit_status"] == 0 for x in r["runs"]):
            print(f"--jobs 1 / --jobs {r['runs'][1]['jobs']}: {r['runs'][2]['seconds'] / r['runs'][1]['seconds']:.2f}")
        if "error" in r:
            print(f"reproduce failed: {r['error']}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench_throughput", description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=1000, metavar="N", help="workspace points per design (default 1000)")
    ap.add_argument("--designs", type=int, default=50, metavar="D", help="designs per call (default 50)")
    ap.add_argument("--loop-points", type=int, default=200, metavar="n",
                    help="points for the per-point Python loop (default 200)")
    ap.add_argument("--numpy-max", type=int, default=200_000, metavar="K",
                    help="at most this many design x point pairs for the numpy path (default 200000)")
    ap.add_argument("--fk-poses", type=int, default=1_000_000, metavar="N", help="poses for forward kinematics (default 1e6)")
    ap.add_argument("--repeat", type=int, default=7, help="timed repetitions; the best one is reported (default 7)")
    ap.add_argument("--threads", type=int, default=None, help="numba threads (default: all)")
    ap.add_argument("--reproduce-points", type=int, default=1000, metavar="N",
                    help="at least this many workspace points per design for the reproduce timing (default 1000)")
    ap.add_argument("--no-reproduce", action="store_true", help="skip timing optdesign reproduce")
    ap.add_argument("--numpy-only", action="store_true",
                    help="skip the compiled paths and the reproduce timing (no numba compilation: seconds)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    if min(args.points, args.designs, args.loop_points, args.fk_poses, args.repeat, args.numpy_max) < 1:
        ap.error("--points, --designs, --loop-points, --fk-poses, --numpy-max and --repeat must be positive")
    if args.threads is not None:
        import numba

        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            ap.error(f"--threads must be between 1 and {numba.config.NUMBA_NUM_THREADS}")
        numba.set_num_threads(args.threads)
    res = measure(args)
    if args.json:
        print(json.dumps(res, indent=2))
    else:
        report(res, args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
