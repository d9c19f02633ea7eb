"""What the adaptive integral costs against the paper's 11 x 11 grid, and how
close each is to the integral over W (3-P(4S), configs/p4s_paper.yaml).

    python benchmarks/bench_cubature.py [--repeat N]

For the before and after designs, a population of 50 designs in the box
(seeded), and the singular design of issue 19, per rule: nodes evaluated,
seconds, the ratio of both to the 11 x 11 grid, and for the two named
designs the largest relative distance of the three means to a 401 x 401
Gauss-Legendre reference and the largest stated relative error.  Then the
disc W of docs/reproduction.md (r = 0.05 m at z = 0.57 m): the grids of step
0.01 and 0.005 m, Gauss 16 and the adaptive integral, before and after.  No
timing is asserted anywhere; the ratios depend on the machine's load.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from optdesign.config import load_config
from optdesign.evaluate import evaluate, workspace_of
from optdesign.optimize.integrals import adaptive_workspace
from optdesign.workspace import WorkspaceSpec, sample

ROOT = Path(__file__).resolve().parents[1]
SINGULAR = {"r_a": 0.2846, "r_b": 0.6462, "phi": math.radians(27.91)}


def _timed(cfg, designs, ws, repeat):
    evaluate(cfg, designs, ws)                    # warm (compiled paths)
    t = time.perf_counter()
    for _ in range(repeat):
        ev = evaluate(cfg, designs, ws)
    return ev, (time.perf_counter() - t) / repeat


def _nodes(ev, ws) -> int:
    """Nodes per design: the adaptive count (reachable nodes, all reachable here) or the rule's points."""
    if ws.spec.sampling == "adaptive":
        return int(np.max(next(iter(ev.summary.values()))["count"]))
    return ws.n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    cfg = load_config(ROOT / "configs" / "p4s_paper.yaml")
    names = workspace_of(cfg).names
    grid = workspace_of(cfg)
    base = cfg.design("before")
    rng = np.random.default_rng(7)
    pop = [{**base, "r_a": a, "r_b": b, "phi": p} for a, b, p in
           zip(rng.uniform(0.21, 0.29, 50), rng.uniform(0.63, 0.71, 50), np.radians(rng.uniform(25, 35, 50)))]
    named = [cfg.design("before"), cfg.design("after")]
    ref = evaluate(cfg, named, sample(dataclasses.replace(cfg.workspace, sampling="gauss", step=None,
                                                          points_per_axis=401), names), errors=False)
    rules = [("grid 11x11", grid)] + [(f"adaptive {t:g}", adaptive_workspace(grid, t, 200_000)) for t in (1e-3, 1e-4, 1e-6)]
    print(f"{'rule':<15} {'designs':<10} {'nodes':>7} {'seconds':>9} {'x grid nodes':>12} {'x grid s':>9} "
          f"{'max rel dist':>12} {'max rel err':>11} status")
    base_cost = {}
    for label, ws in rules:
        for what, designs in (("named", named), ("pop 50", pop), ("singular", [{**base, **SINGULAR}])):
            ev, sec = _timed(cfg, designs, ws, args.repeat)
            nodes = _nodes(ev, ws)
            if label.startswith("grid"):
                base_cost[what] = (nodes, sec)
            n0, s0 = base_cost[what]
            dist = err = float("nan")
            if what == "named":
                dist = max(float(np.max(np.abs(ev.summary[k]["mean"] / ref.summary[k]["mean"] - 1))) for k in cfg.indices)
                err = max(float(np.max(ev.error[k] / np.abs(ev.summary[k]["mean"]))) for k in cfg.indices)
            st = ""
            if ev.status is not None:
                st = ",".join(sorted({str(s) for v in ev.status.values() for s in v}))
            print(f"{label:<15} {what:<10} {nodes:>7} {sec:>9.4f} {nodes / n0:>12.1f} {sec / s0:>9.1f} "
                  f"{dist:>12.2g} {err:>11.2g} {st}")
    print()
    print("disc W, r = 0.05 m at z = 0.57 m (docs/reproduction.md): mean ± error estimate")
    disc = WorkspaceSpec(type="cylinder", axes={"z": (0.57, 0.57)}, radius=0.05, sampling="grid", step=0.01)
    cfgd = dataclasses.replace(cfg, workspace=disc)
    for label, spec in (("grid 0.01", disc), ("grid 0.005", dataclasses.replace(disc, step=0.005)),
                        ("gauss 16", dataclasses.replace(disc, sampling="gauss", step=None, points_per_axis=16)),
                        ("adaptive 1e-7", dataclasses.replace(disc, sampling="adaptive", step=None, tolerance=1e-7,
                                                              max_points=500_000))):
        ws = sample(spec, names)
        ev = evaluate(cfgd, named, ws)
        cells = [f"{k} {ev.summary[k]['mean'][i]:.6g} ± {ev.error[k][i]:.2g}" for i in range(2) for k in cfg.indices]
        print(f"{label:<14} before: {', '.join(cells[:3])}; after: {', '.join(cells[3:])}")


if __name__ == "__main__":
    main()
