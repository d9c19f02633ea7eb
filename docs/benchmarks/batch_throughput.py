"""Batch throughput: runs per minute for 1, 2 and 4 workers, local and Dask.

Each measurement is a fresh ``optdesign batch`` process into an empty folder,
timed by wall clock from start to exit (Python start, imports, pool or client
start-up, the runs, the summary).  For Dask, a local cluster (a scheduler and
N single-thread workers, all on 127.0.0.1) is started first and is not timed:
it stands for an existing cluster.

    python docs/benchmarks/batch_throughput.py --runs 8 --workers 1 2 4 --backends local dask

Prints a Markdown table (used in docs/scaling.md).
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

CONFIG = """\
mechanism: p4s
name: bench
parameters: {m_platform: 4.16, m_slider: 2.57, m_rod: 1.59, rod_Ixx: 0.0223, rod_Izz: 1.276e-4, rods_per_branch: 2, g: 9.81, k: 1.0}
design_variables:
  r_a: {value: 0.25, bounds: [0.21, 0.29]}
  r_b: {value: 0.67, bounds: [0.63, 0.71]}
  L:   {value: 0.38}
  d:   {value: 0.12}
  phi: {value: 30, bounds: [25, 35], unit: deg}
workspace: {type: box, axes: {x: [-0.05, 0.05], y: [-0.05, 0.05], z: 0.57}, sampling: grid, step: 0.01}
indices:
  dynamic:   {kind: dynamic}
  stiffness: {kind: stiffness, convention: lambda_min_K}
  isotropy:  {kind: isotropy, convention: frobenius}
optimizer: {population: 20, generations: 15, seed: 1}
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cluster(n: int, tmp: Path) -> tuple[str, list[subprocess.Popen]]:
    from distributed import Client

    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    dn = subprocess.DEVNULL
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
                               "--no-dashboard"], stdout=dn, stderr=dn)]
    time.sleep(2)
    for i in range(n):
        procs.append(subprocess.Popen([sys.executable, "-m", "dask", "worker", addr, "--nthreads", "1", "--no-nanny",
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


def measure(backend: str, n: int, runs: int, tmp: Path) -> dict:
    cfg = tmp / "bench.yaml"
    cfg.write_text(CONFIG)
    out = tmp / f"out-{backend}-{n}-{time.monotonic_ns()}"
    cmd = [sys.executable, "-m", "optdesign.cli", "batch", str(cfg), "--seeds", str(runs), "--out", str(out)]
    procs = []
    if backend == "local":
        cmd += ["--jobs", str(n)]
    else:
        addr, procs = _cluster(n, tmp)
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
    a = ap.parse_args()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} logical CPUs, "
          f"Python {platform.python_version()}", flush=True)
    res = []
    with tempfile.TemporaryDirectory() as d:
        for rep in range(a.repeat):
            for b in a.backends:
                for n in a.workers:
                    r = measure(b, n, a.runs, Path(d))
                    res.append(r)
                    print(f"  {b} x{n}: {r['runs']} runs in {r['wall']:.1f} s = {r['rpm']:.1f} runs/min "
                          f"(mean run {r['per_run']:.2f} s; load {r['load'][0]:.1f} -> {r['load'][1]:.1f})", flush=True)
    print()
    print("| backend | workers | runs | wall time (s) | runs per minute | speed-up vs 1 worker | mean time per run (s) | load average before -> after |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for r in res:
        base = max((x["rpm"] for x in res if x["backend"] == r["backend"] and x["workers"] == 1), default=None)
        sp = f"{r['rpm'] / base:.2f}" if base else "-"
        print(f"| {r['backend']} | {r['workers']} | {r['runs']} | {r['wall']:.1f} | {r['rpm']:.1f} | {sp} | "
              f"{r['per_run']:.2f} | {r['load'][0]:.1f} -> {r['load'][1]:.1f} |")


if __name__ == "__main__":
    main()
