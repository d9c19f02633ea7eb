"""What certificates cost: per shipped mechanism shape, the boxes and seconds
the interval branch and bound takes to prove a named design over the whole
continuous W, as a ratio to one evaluation of that design on its W sample
(the population loop's unit of work), in one process.

    python benchmarks/bench_certify.py [--budget N]

    python benchmarks/bench_certify.py --compare [--configs p4s_paper ...]

Prints one row per config: status, boxes, seconds, the evaluation's seconds
and the ratio.  The ratio is what a run pays per reported design; it does not
grow with the population or the generations.  p4s_paper also proves its
normalization extreme on the singularity constraint (r_a 0.29 m, r_b 0.63 m,
phi 28.70055 deg: max cond_F over W 999.0 against the limit 1000).
``--compare`` proves each design twice, with the preconditioned cond bound
alone (before) and with the adjugate's (after, the default), and prints the
ratios of boxes and seconds.

    python benchmarks/bench_certify.py --base REV [--repeat 3] [--configs ...]

proves each design with this tree's package and with revision REV's
(extracted by git, as bench_evaluate_ab.py does), in alternation, best of
--repeat, and prints the ratio of seconds and whether the two certificates
are the same (every field but the seconds, bit for bit).
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
#: extra designs (SI) beside each config's last named one
EXTRA = {"p4s_paper": {"extreme": {"r_a": 0.29, "r_b": 0.63, "phi": float(np.radians(28.70055))}}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=None)
    ap.add_argument("--compare", action="store_true", help="before (preconditioned bound) and after (adjugate)")
    ap.add_argument("--configs", nargs="*", default=CONFIGS)
    ap.add_argument("--base", default=None, help="an earlier revision to compare against (git rev)")
    ap.add_argument("--repeat", type=int, default=3, help="with --base: best of this many proofs per side")
    args = ap.parse_args()
    if args.base:
        return against(args)
    head = f"{'config':<16} {'design':<10} {'status':<10} {'boxes':>7} {'cert s':>8} {'eval s':>8} {'ratio':>8}"
    if args.compare:
        head += f" {'before':<10} {'boxes':>7} {'cert s':>8} {'boxes x':>8} {'s x':>7}"
    print(head)
    for name in args.configs:
        cfg = load_config(ROOT / "configs" / f"{name}.yaml")
        ws = workspace_of(cfg)
        region = region_of(ws)
        free = int(np.sum(region["hi"] > region["lo"]))
        budget = args.budget or budget_for(free, False)
        last = list(cfg.designs)[-1]
        designs = {last: cfg.design(last), **{k: {**cfg.design(last), **v} for k, v in EXTRA.get(name, {}).items()}}
        iso = [k for k, s in cfg.indices.items() if s.kind == "isotropy"]
        conv = (cfg.indices[iso[0]].convention or "frobenius") if iso else "two_norm"
        for label, design in designs.items():
            evaluate(cfg, [design], ws)          # warm (compiled paths, caches)
            t = time.perf_counter()
            for _ in range(3):
                evaluate(cfg, [design], ws)
            t_eval = (time.perf_counter() - t) / 3
            mech = build(cfg, design)
            certify_design(mech, region, cfg.optimizer.singularity_threshold, conv, cfg.optimizer.stroke_limits,
                           budget=1)             # warm (first calls of numpy's linear algebra)
            row = []
            for adj in ([True, False] if args.compare else [True]):
                t = time.perf_counter()
                c = certify_design(mech, region, cfg.optimizer.singularity_threshold, conv,
                                   cfg.optimizer.stroke_limits, budget=budget, adjugate=adj)
                row.append((c, time.perf_counter() - t))
            (c, t_cert) = row[0]
            line = (f"{name:<16} {label:<10} {c['status']:<10} {c['boxes']:>7} {t_cert:>8.3f} {t_eval:>8.4f} "
                    f"{t_cert / t_eval:>8.1f}")
            if args.compare:
                b, t_b = row[1]
                line += (f" {b['status']:<10} {b['boxes']:>7} {t_b:>8.3f} {c['boxes'] / b['boxes']:>8.3f} "
                         f"{t_cert / t_b:>7.2f}")
            print(line, flush=True)


def against(args) -> None:
    """This tree's certificates against revision ``args.base``'s, in alternation."""
    import importlib
    import os
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_evaluate_ab import _old_package

    import optdesign

    old = _old_package(args.base)
    sides = {"this tree": optdesign, args.base: old}
    print(f"certificates, this tree against {args.base}, best of {args.repeat} in alternation "
          f"(load {os.getloadavg()[0]:.1f})")
    print(f"{'config':<16} {'design':<10} {'status':<10} {'boxes':>7} {'this s':>8} {'base s':>8} {'ratio':>6}  same")
    for name in args.configs:
        cfg = load_config(ROOT / "configs" / f"{name}.yaml")
        last = list(cfg.designs)[-1]
        designs = {last: {}, **EXTRA.get(name, {})}
        iso = [k for k, s in cfg.indices.items() if s.kind == "isotropy"]
        conv = (cfg.indices[iso[0]].convention or "frobenius") if iso else "two_norm"
        for label, extra in designs.items():
            runs = {}
            for side, pkg in sides.items():    # each side wholly its own package: config, mechanism, intervals
                mod = lambda m, pkg=pkg: importlib.import_module(f"{pkg.__name__}.{m}")  # noqa: E731
                c = mod("config").load_config(ROOT / "configs" / f"{name}.yaml")
                ev, cd = mod("evaluate"), mod("certify.designs")
                region = cd.region_of(ev.workspace_of(c))
                free = int(np.sum(region["hi"] > region["lo"]))
                budget = args.budget or budget_for(free, False)
                mech = ev.build(c, {**c.design(last), **extra})
                opt = c.optimizer
                call = (lambda cd=cd, mech=mech, region=region, budget=budget, opt=opt: cd.certify_design(
                    mech, region, opt.singularity_threshold, conv, opt.stroke_limits, budget=budget))
                cd.certify_design(mech, region, opt.singularity_threshold, conv, opt.stroke_limits, budget=1)  # warm
                runs[side] = [call, np.inf, None]
            for _ in range(args.repeat):
                for r in runs.values():
                    t = time.perf_counter()
                    r[2] = r[0]()
                    r[1] = min(r[1], time.perf_counter() - t)
            a, b = runs["this tree"], runs[args.base]
            same = repr({k: v for k, v in a[2].items() if k != "seconds"}) == \
                repr({k: v for k, v in b[2].items() if k != "seconds"})
            print(f"{name:<16} {label:<10} {a[2]['status']:<10} {a[2]['boxes']:>7} {a[1]:>8.3f} {b[1]:>8.3f} "
                  f"{a[1] / b[1]:>6.2f}  {'yes' if same else 'NO'}", flush=True)
    print(f"(load {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
