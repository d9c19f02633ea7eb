"""Helpers the benchmarks share: the machine's description, best-of-n timing
and the bench inputs (random designs in the paper config's box, random
points around its workspace plane) that bench_throughput.py,
bench_kernel_ab.py and bench_scaling.py measure on."""
from __future__ import annotations

import os
import platform
import time


def machine() -> dict:
    """CPU model, cores, Python, numpy and numba versions, numba threads, load average."""
    info = {"python": platform.python_version(), "platform": platform.platform(), "cpus": os.cpu_count()}
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        info["cpu"] = platform.processor()
    try:
        info["load"] = [round(x, 2) for x in os.getloadavg()]
    except OSError:  # pragma: no cover - no load average on this platform
        info["load"] = None
    import numpy as np

    info["numpy"] = np.__version__
    try:
        import numba

        info["numba"] = numba.__version__
        info["numba_threads"] = numba.get_num_threads()
        info["threading_layer"] = _threading_layer()
    except ImportError:  # pragma: no cover - numba missing
        info["numba"] = None
    return info


def _threading_layer():
    import numba

    try:
        return numba.threading_layer()
    except ValueError:
        return None


def best(fn, repeat: int) -> tuple[float, float]:
    """(best, median) wall time of fn() over ``repeat`` calls."""
    ts = []
    for _ in range(max(1, repeat)):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    ts.sort()
    return ts[0], ts[len(ts) // 2]


def setup(cfg, D: int, N: int, seed: int = 0):
    """D random designs inside the config's bounds and N random points in a box
    around the paper's workspace plane (x, y in +-0.05 m, z in [0.55, 0.59] m)."""
    import numpy as np

    from optdesign.workspace import Workspace

    rng = np.random.default_rng(seed)
    designs = {}
    for name, dv in cfg.design_variables.items():
        if dv.bounds is not None:
            designs[name] = rng.uniform(dv.bounds[0], dv.bounds[1], D)
    X = np.c_[rng.uniform(-0.05, 0.05, N), rng.uniform(-0.05, 0.05, N), rng.uniform(0.55, 0.59, N)]
    return designs, Workspace(spec=cfg.workspace, names=("x", "y", "z"), X=X)
