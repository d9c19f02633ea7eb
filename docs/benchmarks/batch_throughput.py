"""Batch throughput: runs per minute for 1, 2 and 4 workers, local and Dask.

Each measurement is a fresh ``optdesign batch`` process into an empty folder,
timed by wall clock from start to exit (Python start, imports, pool or client
start-up, the runs, the summary).  For Dask, a local cluster (a scheduler and
N single-thread workers, all on 127.0.0.1) is started first and is not timed:
it stands for an existing cluster.

    python docs/benchmarks/batch_throughput.py --runs 8 --workers 1 2 4 --backends local dask --repeat 2

The workload is ``configs/p4s_paper.yaml`` (the paper's GA: population 50, 100
generations, 8 GA stages, the 11 x 11 workspace grid) without the Pareto
stages, one run per seed.  Prints a Markdown table (used in docs/scaling.md).
"""
from __future__ import annotations

import argparse
import os
import platform
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cluster(n: int, tmp: Path, nanny: bool = True) -> tuple[str, list[subprocess.Popen]]:
    from distributed import Client

    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    dn = subprocess.DEVNULL
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=dn, stderr=dn)]
    time.sleep(2)
    for i in range(n):
        procs.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", addr, "--nthreads", "1",
                                       "--nanny" if nanny else "--no-nanny",
                                       "--no-dashboard", "--host", "127.0.0.1", "--local-directory", str(tmp / f"w{i}")],
                                      stdout=dn, stderr=dn))
    with Client(addr, timeout=60) as c:
        c.wait_for_workers(n, timeout=120)
    return addr, procs


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in reversed(procs):
        p.terminate()
    for p in procs:
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def measure(backend: str, n: int, runs: int, tmp: Path, cfg: Path, nanny: bool = True) -> dict:
    out = tmp / f"out-{backend}-{n}-{time.monotonic_ns()}"
    cmd = [sys.executable, "-m", "optdesign.cli", "batch", str(cfg), "--seeds", str(runs), "--out", str(out)]
    procs = []
    if backend == "local":
        cmd += ["--jobs", str(n)]
    else:
        addr, procs = _cluster(n, tmp, nanny)
        cmd += ["--backend", "dask", "--scheduler", addr]
    try:
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        load1 = os.getloadavg()[0]
    finally:
        _stop(procs)
    import csv

    with open(out / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    per_run = sum(float(r["wall_time_s"]) for r in rows) / len(rows)
    return {"backend": backend, "workers": n, "runs": len(rows), "wall": wall, "per_run": per_run,
            "rpm": 60 * len(rows) / wall, "load": (load0, load1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=8)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--backends", nargs="+", default=["local", "dask"])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--no-nanny", action="store_true",
                    help="start Dask workers without their nanny (which sets OMP/MKL/OPENBLAS_NUM_THREADS=1)")
    ap.add_argument("--config", default=str(ROOT / "configs" / "p4s_paper.yaml"))
    ap.add_argument("--numba-threads", type=int, default=None,
                    help="NUMBA_NUM_THREADS for the batch and its workers (default: numba's, one per CPU)")
    a = ap.parse_args()
    if a.numba_threads:
        os.environ["NUMBA_NUM_THREADS"] = str(a.numba_threads)     # inherited by every process started below
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs, "
          f"Python {platform.python_version()}, NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS', 'default')}, "
          f"Dask workers {'without' if a.no_nanny else 'with'} nanny",
          flush=True)
    res = []
    with tempfile.TemporaryDirectory() as d:
        for rep in range(a.repeat):
            for b in a.backends:
                for n in a.workers:
                    r = measure(b, n, a.runs, Path(d), Path(a.config), not a.no_nanny)
                    res.append(r)
                    print(f"  {b} x{n}: {r['runs']} runs in {r['wall']:.1f} s = {r['rpm']:.1f} runs/min "
                          f"(mean run {r['per_run']:.2f} s; load {r['load'][0]:.1f} -> {r['load'][1]:.1f})", flush=True)
    print()
    print("| backend | workers | runs | wall time (s), median | runs per minute, median | each repeat (runs/min) "
          "| speed-up vs 1 worker | mean time per run (s) |")
    print("|---|---:|---:|---:|---:|---|---:|---:|")
    import statistics

    keys = list(dict.fromkeys((r["backend"], r["workers"]) for r in res))
    med = {k: statistics.median(x["rpm"] for x in res if (x["backend"], x["workers"]) == k) for k in keys}
    for k in keys:
        rs = [x for x in res if (x["backend"], x["workers"]) == k]
        base = med.get((k[0], 1))
        sp = f"{med[k] / base:.2f}" if base else "-"
        each = ", ".join(f"{x['rpm']:.1f}" for x in rs)
        print(f"| {k[0]} | {k[1]} | {rs[0]['runs']} | {statistics.median(x['wall'] for x in rs):.1f} | {med[k]:.1f} | "
              f"{each} | {sp} | {statistics.median(x['per_run'] for x in rs):.2f} |")
    loads = [x["load"][0] for x in res] + [x["load"][1] for x in res]
    print(f"\n1-minute load average during the measurements: {min(loads):.1f} to {max(loads):.1f}")


if __name__ == "__main__":
    main()
