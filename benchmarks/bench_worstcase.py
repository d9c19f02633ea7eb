"""What the worst case over the continuous W costs: one Evaluator call on a
population of p4s_tradeoff (the population loop's unit of work) with
``optimizer.worst_case`` on, as a ratio to the same call with it off (the
sampled maxima), for the search as it is ("new": the zoom search on the
compiled path, the Evaluator's memo cleared before every call) and the
earlier one ("old": the gradient ascent on the numpy path,
``method="ascent"``), in one process.

    python benchmarks/bench_worstcase.py [--config configs/p4s_tradeoff.yaml] [--repeats 7]

The populations are Sobol designs of the config's bounds (a first
generation) and the same designs pulled halfway to the 'after' design (a
later, more feasible one).  Prints per population: the designs the search
ran for (those the samples find feasible), the seconds of each mode (the
smallest of the repeats), the ratios new / off and old / new, how many
designs each search turned infeasible, the largest relative difference of
the two searches' maxima of cond (where both are below the stop), and the
machine's load average.  No timing is asserted anywhere.
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


def _time(ev, X, mode: str, repeats: int) -> tuple[float, dict]:
    ev.worst_case = mode != "off"
    ev.worst_case_method = "ascent" if mode == "old" else "auto"
    best, res = np.inf, None
    for _ in range(repeats):
        ev._memo.clear()                   # every repeat searches (the Evaluator keeps the designs it has seen)
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
    print(f"{'population':<13} {'D':>3} {'searched':>8} {'off s':>7} {'new s':>7} {'old s':>8} {'new/off':>8} "
          f"{'old/new':>11} {'rejected n/o':>12} {'max rel diff':>12}")
    ratios, gains = [], []
    for D in (cfg.optimizer.population, cfg.optimizer.pareto_population):
        U = qmc.Sobol(len(ev.free), seed=1).random(D)
        X1 = ev.xl + U * (ev.xu - ev.xl)
        for label, X in ((f"sobol {D}", X1), (f"halfway {D}", (X1 + after) / 2)):
            for mode in ("off", "new", "old"):
                _time(ev, X, mode, 1)                                      # warm (compiled paths)
            t, r = {}, {}
            for mode in ("off", "new", "old"):
                t[mode], r[mode] = _time(ev, X, mode, args.repeats)
            f = {m: _feasible(r[m]) for m in r}
            searched = int(np.sum((r["off"]["constraints"]["singularity"] <= 0) & (r["off"]["constraints"]["reach"] <= 0)))
            cz, ca = (r[m]["constraints"]["singularity"] + 1.0 for m in ("new", "old"))
            both = (cz < 2.0 / (1 - ev.margin)) & (ca < 2.0 / (1 - ev.margin))
            diff = float(np.max(np.abs(cz[both] - ca[both]) / ca[both])) if both.any() else float("nan")
            ratios.append(t["new"] / t["off"])
            gains.append(t["old"] / t["new"])
            print(f"{label:<13} {D:>3} {searched:>8} {t['off']:>7.4f} {t['new']:>7.4f} {t['old']:>8.4f} "
                  f"{ratios[-1]:>8.1f} {gains[-1]:>11.1f} "
                  f"{int(np.sum(f['off'] & ~f['new'])):>5} / {int(np.sum(f['off'] & ~f['old'])):<4} {diff:>12.1e}")
    load = os.getloadavg()
    print(f"new / off: {min(ratios):.1f} to {max(ratios):.1f}; old / new: {min(gains):.1f} to {max(gains):.1f}; "
          f"load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} on {os.cpu_count()} cores")

if __name__ == "__main__":
    main()
