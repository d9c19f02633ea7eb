"""How each workspace sampling converges to the integral mean of eq. 29 on the
3-P(4S) paper's W (the plane z = 0.57 m, x and y in [-0.05, 0.05] m) for the
before and after designs of Table 3.

    python benchmarks/quadrature_convergence.py [--config configs/p4s_paper.yaml]
        [--reference 1024] [--seeds 20]

The integral is taken from a tensor Gauss-Legendre rule of ``--reference``^2
nodes (its distance to the rule of half as many nodes per axis is printed).
For every sampling (grid 11 x 11, 21 x 21, 41 x 41; Gauss n = 4, 6, 8, 12,
16; rqmc 64 ... 4096 points x 8 scramblings) and each index: the relative
error |Q - I| / I and the rule's own error estimate, relative (in brackets).
For rqmc the first numbers are seed 1's; the last column block gives the
median relative error over ``--seeds`` seeds.  Points: those of the mean
(the error estimate of a Gauss rule adds the (n-1)^2 nodes of the coarser
rule; a grid's sub-grid and rqmc's scramblings are subsets of the sample).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def samplings(spec):
    """(label, WorkspaceSpec) of every sampling in the study."""
    half = spec.axes["x"][1] - spec.axes["x"][0]
    out = []
    for n in (11, 21, 41):
        out.append((f"grid {n} x {n}", dataclasses.replace(spec, sampling="grid", step=half / (n - 1),
                                                           points_per_axis=None)))
    for n in (4, 6, 8, 12, 16):
        out.append((f"gauss n = {n}", dataclasses.replace(spec, sampling="gauss", step=None, points_per_axis=n)))
    for p in (64, 256, 1024, 4096):
        out.append((f"rqmc {p} x 8", dataclasses.replace(spec, sampling="rqmc", step=None, points_per_axis=None,
                                                         points=p, scramblings=8, seed=1)))
    return out


def study(config_path: str, reference: int = 1024, seeds: int = 20) -> dict:
    from optdesign.config import load_config
    from optdesign.evaluate import evaluate, mechanism_class
    from optdesign.workspace import sample

    cfg = load_config(ROOT / config_path if not Path(config_path).is_absolute() else config_path)
    names = mechanism_class(cfg).pose_names
    dnames = [n for n in ("before", "after") if n in cfg.designs]
    designs = [cfg.design(n) for n in dnames]
    spec = cfg.workspace

    def means(s, errors=True):
        ev = evaluate(cfg, designs, sample(s, names), errors=errors)
        return ev

    ref_ev = means(dataclasses.replace(spec, sampling="gauss", step=None, points_per_axis=reference), errors=False)
    half_ev = means(dataclasses.replace(spec, sampling="gauss", step=None, points_per_axis=reference // 2), errors=False)
    ref = {k: ref_ev.summary[k]["mean"] for k in cfg.indices}
    ref_check = {k: np.abs(half_ev.summary[k]["mean"] / ref[k] - 1) for k in cfg.indices}
    rows = []
    for label, s in samplings(spec):
        ev = means(s)
        ws = ev.workspace
        extra = sum(r.X.shape[0] for r in ws.error_rule.rules) if ws.error_rule.method == "coarse" else 0
        rec = {"label": label, "points": ws.n, "extra": extra, "rel_error": {}, "rel_estimate": {}, "median": {}}
        for k in cfg.indices:
            rec["rel_error"][k] = np.abs(ev.summary[k]["mean"] / ref[k] - 1)
            rec["rel_estimate"][k] = ev.error[k] / np.abs(ref[k])
        if s.sampling == "rqmc":
            errs = []
            for seed in range(1, seeds + 1):
                e = means(dataclasses.replace(s, seed=seed), errors=False)
                errs.append({k: np.abs(e.summary[k]["mean"] / ref[k] - 1) for k in cfg.indices})
            rec["median"] = {k: np.median([e[k] for e in errs], axis=0) for k in cfg.indices}
        rows.append(rec)
    return {"config": config_path, "designs": dnames, "indices": list(cfg.indices), "reference": reference,
            "integral": ref, "reference_check": ref_check, "rows": rows}


def _e(x: float) -> str:
    return "0" if x == 0 else f"{x:.1e}"


def tables(res: dict) -> str:
    from optdesign.tables import table

    out = [f"{res['config']}: integral from Gauss {res['reference']}^2 "
           f"(relative distance to Gauss {res['reference'] // 2}^2: "
           + ", ".join(f"{k} {max(v):.1e}" for k, v in res["reference_check"].items()) + ")", ""]
    for j, d in enumerate(res["designs"]):
        out.append(f"{d}: integral means " + ", ".join(f"{k} {res['integral'][k][j]:.8g}" for k in res["indices"]))
        head = ["sampling", "points"] + [f"{k}: rel. error (estimate)" for k in res["indices"]]
        rqmc = any(r["median"] for r in res["rows"])
        if rqmc:
            head.append("rqmc median error over seeds")
        rows = []
        for r in res["rows"]:
            pts = str(r["points"]) + (f" (+{r['extra']})" if r["extra"] else "")
            row = [r["label"], pts] + [f"{_e(r['rel_error'][k][j])} ({_e(r['rel_estimate'][k][j])})"
                                       for k in res["indices"]]
            if rqmc:
                row.append(" / ".join(_e(r["median"][k][j]) for k in res["indices"]) if r["median"] else "")
            rows.append(row)
        out.append(table(head, rows))
        out.append("")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default="configs/p4s_paper.yaml")
    ap.add_argument("--reference", type=int, default=1024, help="Gauss nodes per axis of the reference rule")
    ap.add_argument("--seeds", type=int, default=20, help="rqmc seeds for the median error")
    args = ap.parse_args(argv)
    print(tables(study(args.config, args.reference, args.seeds)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
