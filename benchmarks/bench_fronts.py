"""The Pareto fronts of a config against an exhaustive grid of its design box.

    python benchmarks/bench_fronts.py [--config configs/p4s_tradeoff.yaml] [--seeds 1]
        [--grid 41] [--out DIR]

For each seed, one full run of the config (its pre-scan, extremes, single
and weighted stages, NSGA-II and NSGA-III as shipped) in ``--out`` (default:
a temporary folder; run folders already there are reused).  Then an
exhaustive grid of ``--grid`` points per free variable is evaluated (the
vectorized Evaluator), its feasible non-dominated designs are normalized as
the run normalizes its fronts (results.json ``pareto.<alg>.normalization``)
and its hypervolume (reference 1.1 per objective) is compared with the
run's.  Printed per algorithm: the front size, the hypervolume ratio run /
grid (the target: at least 0.99), how many reported points another reported
point or a grid design dominates (the target: none) and how many points have
a coordinate within 1e-9 (unit box) of a bound without being on it (the
target: none).  The measure is the hypervolume, not wall time.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def grid_front(cfg, n: int):
    from optdesign.evaluate import Evaluator, workspace_of
    from optdesign.optimize.problem import DesignProblem, extra_term, index_term
    from optdesign.optimize.refine import non_dominated

    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    terms = [index_term(k, s.sense) for k, s in cfg.indices.items()]
    terms += [extra_term(e, ev.extra[e].sense) for e in cfg.optimizer.extra_objectives]
    prob = DesignProblem(ev, terms)
    g = [np.linspace(a, b, n) for a, b in zip(ev.xl, ev.xu)]
    X = np.array(np.meshgrid(*g, indexing="ij")).reshape(len(g), -1).T
    Fs = []
    for i in range(0, len(X), 4096):
        out: dict = {}
        prob._evaluate(X[i:i + 4096], out)
        Fs.append(out["F"][np.all(out["G"] <= 0, axis=1)])
    F = np.concatenate(Fs)
    return F[non_dominated(F)], ev


def main(argv=None) -> int:
    from pymoo.indicators.hv import HV

    from optdesign.config import load_config
    from optdesign.optimize.refine import non_dominated
    from optdesign.runner import run_in_folder
    from optdesign.runs import RunFolder

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "configs/p4s_tradeoff.yaml"))
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--grid", type=int, default=41)
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    cfg = load_config(a.config)
    out = Path(a.out or tempfile.mkdtemp(prefix="bench_fronts_"))
    grid, ev = grid_front(cfg, a.grid)
    report = {}
    for s in range(1, a.seeds + 1):
        folder = out / f"{cfg.name}-s{s}"
        if not (folder / "results.json").exists():
            text = Path(a.config).read_text()
            f = RunFolder.create(out, folder.name, text, s, f"k{s}", exact=True)
            run_in_folder(cfg, f, s, reports=False)
        res = json.loads((folder / "results.json").read_text())
        for alg, p in res.get("pareto", {}).items():
            st = json.loads((folder / "stages" / alg / "result.json").read_text())
            lo, hi = np.array(p["normalization"]["best"]), np.array(p["normalization"]["worst"])
            F = np.array([[row[f"objective_{t}"] for t in st["terms"]] for row in st["front"]])
            hv = HV(ref_point=np.full(len(lo), 1.1))
            ratio = float(hv((F - lo) / (hi - lo)) / hv((grid - lo) / (hi - lo)))
            tol = 1e-9 * np.maximum(np.abs(F), 1e-12)
            by_grid = sum(bool(np.any(np.all(grid <= f + t, axis=1) & np.any(grid < f - t, axis=1)))
                          for f, t in zip(F, tol))
            by_front = len(F) - len(non_dominated(F))
            X = np.array([[row[k] for k in ev.free] for row in st["front"]])
            U = (X - ev.xl) / (ev.xu - ev.xl)
            near = int(np.sum(np.any(((U > 0) & (U < 1e-9)) | ((U < 1) & (U > 1 - 1e-9)), axis=1)))
            report[f"seed {s} {alg}"] = {"front_size": len(F), "hypervolume_ratio": ratio,
                                          "dominated_by_front": by_front, "dominated_by_grid": by_grid,
                                          "near_but_off_a_bound": near}
            print(f"seed {s} {alg}: {len(F)} points, hypervolume {ratio:.4f} of the {a.grid}^n grid's; "
                  f"dominated by the front {by_front}, by the grid {by_grid}; near but off a bound {near}")
    (out / "bench_fronts.json").write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
