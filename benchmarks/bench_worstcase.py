"""What the worst case over the continuous W costs: one Evaluator call on a
population of p4s_tradeoff (the population loop's unit of work) with
``optimizer.worst_case`` on, as a ratio to the same call with it off (the
sampled maxima), in one process, interleaved.

    python benchmarks/bench_worstcase.py [--config configs/p4s_tradeoff.yaml] [--repeats 7]

The populations are Sobol designs of the config's bounds (a first
generation) and the same designs pulled halfway to the 'after' design (a
later, more feasible one).  Prints per population: the designs the search
ran for (those the samples find feasible), the seconds of each mode (the
smallest of the repeats), the ratio, how many designs the search turned
infeasible, and the machine's load average.  No timing is asserted anywhere.
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
from scipy.stats import qmc

from optdesign.config import load_config
from optdesign.evaluate import Evaluator

ROOT = Path(__file__).resolve().parents[1]


def _time(ev, X, on: bool, repeats: int) -> tuple[float, dict]:
    ev.worst_case = on
    best, res = np.inf, None
    for _ in range(repeats):
        t = time.perf_counter()
        res = ev(X)
        best = min(best, time.perf_counter() - t)
    return best, res


def _feasible(res) -> np.ndarray:
    return np.all([v <= 0 for v in res["constraints"].values()], axis=0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "p4s_tradeoff.yaml"))
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    cfg = load_config(args.config)
    ev = Evaluator.from_config(cfg)
    after = ev.vector({**ev.defaults, **cfg.design("after")}) if "after" in cfg.designs else (ev.xl + ev.xu) / 2
    print(f"config {cfg.name}: W {ev.workspace.n} samples, limit {ev.threshold:g} (optimized against "
          f"{ev.limit:g}, margin {ev.margin:g})")
    print(f"{'population':<22} {'D':>4} {'searched':>8} {'off s':>8} {'on s':>8} {'ratio':>7} {'rejected':>8}")
    ratios = []
    for D in (cfg.optimizer.population, cfg.optimizer.pareto_population):
        U = qmc.Sobol(len(ev.free), seed=1).random(D)
        X1 = ev.xl + U * (ev.xu - ev.xl)
        for label, X in ((f"sobol {D}", X1), (f"halfway {D}", (X1 + after) / 2)):
            _time(ev, X, False, 1), _time(ev, X, True, 1)            # warm (compiled paths)
            t_off, r_off = _time(ev, X, False, args.repeats)
            t_on, r_on = _time(ev, X, True, args.repeats)
            f_off, f_on = _feasible(r_off), _feasible(r_on)
            searched = int(np.sum((r_off["constraints"]["singularity"] <= 0) & (r_off["constraints"]["reach"] <= 0)))
            ratios.append(t_on / t_off)
            print(f"{label:<22} {D:>4} {searched:>8} {t_off:>8.4f} {t_on:>8.4f} {t_on / t_off:>7.1f} "
                  f"{int(np.sum(f_off & ~f_on)):>8}")
    load = os.getloadavg()
    print(f"ratio worst case on / off: {min(ratios):.1f} to {max(ratios):.1f}; load average "
          f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
