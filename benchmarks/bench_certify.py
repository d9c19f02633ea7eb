"""What certificates cost: per shipped mechanism shape, the boxes and seconds
the interval branch and bound takes to prove a named design over the whole
continuous W, as a ratio to one evaluation of that design on its W sample
(the population loop's unit of work), in one process.

    python benchmarks/bench_certify.py [--budget N]

Prints one row per config: status, boxes, seconds, the evaluation's seconds
and the ratio.  The ratio is what a run pays per reported design; it does not
grow with the population or the generations.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from optdesign.certify.designs import certify_design, region_of
from optdesign.certify.reported import budget_for
from optdesign.config import load_config
from optdesign.evaluate import build, evaluate, workspace_of

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ["p4s_paper", "p4s_legs", "delta", "sps_s_legs_opt", "gough_stewart"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=None)
    args = ap.parse_args()
    print(f"{'config':<16} {'design':<10} {'status':<10} {'boxes':>7} {'cert s':>8} {'eval s':>8} {'ratio':>8}")
    for name in CONFIGS:
        cfg = load_config(ROOT / "configs" / f"{name}.yaml")
        ws = workspace_of(cfg)
        region = region_of(ws)
        free = int(np.sum(region["hi"] > region["lo"]))
        budget = args.budget or budget_for(free, False)
        design = list(cfg.designs)[-1]
        iso = [k for k, s in cfg.indices.items() if s.kind == "isotropy"]
        conv = (cfg.indices[iso[0]].convention or "frobenius") if iso else "two_norm"
        evaluate(cfg, [cfg.design(design)], ws)          # warm (compiled paths, caches)
        t = time.perf_counter()
        for _ in range(3):
            evaluate(cfg, [cfg.design(design)], ws)
        t_eval = (time.perf_counter() - t) / 3
        mech = build(cfg, design)
        t = time.perf_counter()
        c = certify_design(mech, region, cfg.optimizer.singularity_threshold, conv, cfg.optimizer.stroke_limits,
                           budget=budget)
        t_cert = time.perf_counter() - t
        print(f"{name:<16} {design:<10} {c['status']:<10} {c['boxes']:>7} {t_cert:>8.3f} {t_eval:>8.4f} "
              f"{t_cert / t_eval:>8.1f}")


if __name__ == "__main__":
    main()
