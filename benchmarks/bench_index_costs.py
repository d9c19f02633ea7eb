"""What each index costs: evaluate() time per design x point for each index
kind alone and added to the paper's three, on the 3-P(4S) (compiled path for
dynamic, stiffness and isotropy; the numpy path on the compiled Jacobian for
the others) and on the 3-SPS-S (numpy path), relative to the paper's three
indices on the 3-P(4S).

    python benchmarks/bench_index_costs.py [--designs 50] [--points 1000] [--repeat 7]
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _time(cfg, designs, ws, repeat):
    from optdesign.evaluate import evaluate

    evaluate(cfg, designs, ws)
    ts = []
    for _ in range(repeat):
        t = time.perf_counter()
        evaluate(cfg, designs, ws)
        ts.append(time.perf_counter() - t)
    return min(ts)


def _config(base: str, indices: dict):
    import yaml

    from optdesign.config import config_from_dict

    data = yaml.safe_load(open(os.path.join(ROOT, "configs", base)).read())
    data["indices"] = indices
    data.pop("reference", None)
    opt = data.get("optimizer") or {}
    opt.pop("weights", None)
    data["optimizer"] = opt
    return config_from_dict(data, base)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--designs", type=int, default=50)
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    from optdesign.evaluate import workspace_of
    from optdesign.workspace import Workspace

    rng = np.random.default_rng(0)
    rows = []
    base_t = None
    for mech_cfg, kinds, paper in (("p4s_paper.yaml", ("dynamic", "stiffness", "isotropy", "dexterity",
                                                      "manipulability", "driving"), ("dynamic", "stiffness", "isotropy")),
                                   ("sps_s_opt.yaml", ("stiffness", "isotropy", "dexterity", "manipulability",
                                                       "driving"), ("dexterity", "stiffness", "driving"))):
        cfg0 = _config(mech_cfg, {k: {"kind": k} for k in paper})
        designs = {k: rng.uniform(dv.bounds[0], dv.bounds[1], args.designs)
                   for k, dv in cfg0.design_variables.items() if dv.bounds}
        ws0 = workspace_of(cfg0)
        lo, hi = ws0.X.min(axis=0), ws0.X.max(axis=0)
        X = lo + (hi - lo) * rng.random((args.points, ws0.X.shape[1]))
        ws = Workspace(spec=cfg0.workspace, names=ws0.names, X=X)
        t_paper = _time(cfg0, designs, ws, args.repeat)
        if base_t is None:
            base_t = t_paper
        rows.append((mech_cfg.split(".")[0], "+".join(paper), t_paper))
        for k in kinds:
            cfg = _config(mech_cfg, {k: {"kind": k}})
            rows.append((mech_cfg.split(".")[0], k, _time(cfg, designs, ws, args.repeat)))
            if k not in paper:
                cfg = _config(mech_cfg, {**{p: {"kind": p} for p in paper}, k: {"kind": k}})
                rows.append((mech_cfg.split(".")[0], "+".join(paper) + " + " + k, _time(cfg, designs, ws, args.repeat)))
    n = args.designs * args.points
    print(f"{args.designs} designs x {args.points} points, best of {args.repeat}; load {os.getloadavg()[0]:.2f}")
    print("| mechanism | indices | ns per design x point | relative to the 3-P(4S)'s three |")
    print("|---|---|---:|---:|")
    for m, k, t in rows:
        print(f"| {m} | {k} | {1e9 * t / n:.0f} | {t / base_t:.1f} |")


if __name__ == "__main__":
    main()
