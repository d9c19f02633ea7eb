"""Normalized objectives of the shipped optimization configs at their full
budgets, over seeds 1-5: does any run print a normalized term outside [0, 1]?

    python benchmarks/normalized_objectives.py [--seeds 5] [--jobs 2] [--configs p4s_wide sps_s_opt]
        [--no-pareto] [--out DIR] [--from-runs DIR]

For every shipped config with free design variables (configs/*.yaml but the
batch example) and every seed, one full run (the config as shipped: its
search, budget, pre-scan and polish; ``--no-pareto`` skips the fronts) in
``--out`` (default: a temporary folder; run folders already there are
reused).  Then, read back from each run's results.json:

* the weighted-sum objective at the optimum and its range [0, sum of the
  weights]; each normalized term of the optimum and of the named designs
  (those that get one) against [0, 1];
* how each extreme was found (prescan, ga, polish, later stage, named design)
  and how many later-stage updates the run made;
* the optimum's optimality measure (KKT residual relative to max(1, gradient
  norm)) against the stated tolerance;
* per config, the spread of the extremes over the seeds (relative to their
  mean): how far the seeds agree on the scale.

``tests/test_normalized_terms.py`` checks the same on small budgets in the test suite.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def shipped_configs(names=None) -> list[Path]:
    from optdesign.config import load_config

    out = []
    for p in sorted((ROOT / "configs").glob("*.yaml")):
        if p.name == "batch_example.yaml" or (names and p.stem not in names):
            continue
        if load_config(p).free_variables:
            out.append(p)
    return out


def check_run(r: dict) -> dict:
    """What one run's results.json says about the [0, 1] normalization."""
    norm = r["normalization"]
    total = sum(v["weight"] for v in norm.values())

    def terms(values: dict) -> list[float]:
        out = []
        for k, v in norm.items():
            span = v["max"] - v["min"]
            t = (values[k] - v["min"]) / span if span > 0 else 0.0
            out.append(1 - t if v["sense"] == "max" else t)
        return out

    t_opt = terms(r["global_indices"])
    bad = [x for x in t_opt if not -1e-12 <= x <= 1 + 1e-12]
    for d in r["designs"].values():
        if d.get("objective") is not None:
            bad += [x for x in terms({k: d["global_indices"][k]["mean"] for k in norm}) if not -1e-12 <= x <= 1 + 1e-12]
            if not 0 <= d["objective"] <= total:
                bad.append(d["objective"])
    if not 0 <= r["objective"] <= total:
        bad.append(r["objective"])
    found = Counter(v[f"{b}_found_by"] for v in norm.values() for b in ("min", "max") if f"{b}_found_by" in v)
    opt = r.get("polish", {}).get("optimality", {})
    return {"objective": r["objective"], "terms": t_opt, "outside": bad, "found_by": dict(found),
            "updates": len(r.get("normalization_updates", [])), "kkt_relative": opt.get("kkt_relative"),
            "converged": opt.get("converged"), "extremes": {k: (v["min"], v["max"]) for k, v in norm.items()}}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeds 1..N (default 5)")
    ap.add_argument("--jobs", type=int, default=2, help="runs at once (default 2)")
    ap.add_argument("--configs", nargs="*", default=None, help="config names (stems) to run (default: every shipped one)")
    ap.add_argument("--no-pareto", action="store_true", help="skip the Pareto stages")
    ap.add_argument("--out", default=None, help="folder of the run folders (default: a temporary one)")
    ap.add_argument("--from-runs", default=None, metavar="DIR", help="only read the run folders in DIR")
    args = ap.parse_args(argv)
    from optdesign.batch import plan, run_batch
    from optdesign.report.summary import collect_folders
    from optdesign.tables import fmt_g, table

    if args.from_runs:
        root = Path(args.from_runs)
    else:
        root = Path(args.out or tempfile.mkdtemp(prefix="normalized-"))
        tasks = plan([str(p) for p in shipped_configs(args.configs)], seeds=list(range(1, args.seeds + 1)),
                     pareto=not args.no_pareto)
        print(f"{len(tasks)} runs in {root}", file=sys.stderr)
        run_batch(tasks, str(root), jobs=args.jobs)
    rows, per_config = [], {}
    for f in collect_folders([root]):
        p = f / "results.json"
        if not p.exists():
            continue
        r = json.loads(p.read_text())
        c = check_run(r)
        per_config.setdefault(r["config"], []).append(c)
        rows.append([r["config"], r["seed"], fmt_g(c["objective"]), ", ".join(f"{t:.4f}" for t in c["terms"]),
                     "none" if not c["outside"] else ", ".join(fmt_g(x) for x in c["outside"]),
                     ", ".join(f"{k} {n}" for k, n in sorted(c["found_by"].items())), c["updates"],
                     fmt_g(c["kkt_relative"]) if c["kkt_relative"] is not None else "-"])
    print(table(["config", "seed", "objective", "terms of the optimum", "outside [0, 1]", "extremes found by",
                 "later updates", "KKT (rel.)"], rows))
    print()
    spread = []
    for name, cs in per_config.items():
        for k in cs[0]["extremes"]:
            for b, i in (("min", 0), ("max", 1)):
                v = [c["extremes"][k][i] for c in cs]
                m = sum(v) / len(v)
                spread.append([name, k, b, fmt_g(min(v)), fmt_g(max(v)), f"{(max(v) - min(v)) / abs(m):.2e}" if m else "-"])
    print("Extremes over the seeds (min and max of the recorded value, and their spread relative to the mean):")
    print(table(["config", "index", "extreme", "lowest", "highest", "spread"], spread))
    n_bad = sum(1 for cs in per_config.values() for c in cs if c["outside"])
    print(f"\n{sum(len(cs) for cs in per_config.values())} runs, {n_bad} with a normalized value outside its range")
    return 1 if n_bad else 0


if __name__ == "__main__":
    sys.exit(main())
