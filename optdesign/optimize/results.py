"""What a run reports: each stage's files and result, the final results and
the placement of the weighted-sum optimum and the named designs against the
Pareto fronts."""
from __future__ import annotations

import math

import numpy as np
from pymoo.indicators.hv import HV

from ..runs import RunFolder, RunFolderError
from .problem import weighted_sum, weighted_sum_term

__all__ = ["rows_csv", "population_rows", "stage_summary", "check_stage_result", "finished_stage",
           "final_results", "place_against_front"]


def rows_csv(rows: list[dict]) -> str:
    """Rows (dicts) as CSV text: the union of their keys in order of appearance,
    floats as ``repr`` (exact), None as an empty field."""
    if not rows:
        return ""
    keys = list(rows[0])
    for r in rows[1:]:
        keys.extend(k for k in r if k not in keys)
    val = lambda v: "" if v is None else repr(v) if isinstance(v, float) else str(v)  # noqa: E731
    return "\n".join([",".join(keys)] + [",".join(val(r.get(k)) for k in keys) for r in rows]) + "\n"


def population_rows(evaluator, problem, pop) -> list[dict]:
    X, F, CV, G = pop.get("X", "F", "CV", "G")
    designs = evaluator.designs(X)
    rows = []
    for i in range(len(pop)):
        r = {k: float(v[i]) for k, v in designs.items()}
        for j, t in enumerate(problem.terms):
            r[f"objective_{t.label()}"] = float(F[i, j])
        for k in evaluator.index_names:
            v = pop[i].get(f"index_{k}")
            r[k] = float(v) if v is not None else float("nan")
        r["cv"] = float(CV[i, 0])
        for j, c in enumerate(problem.constraint_names):
            r[f"g_{c}"] = float(G[i, j])
        rows.append(r)
    return rows


def stage_summary(folder: RunFolder, stage, algorithm, problem, evaluator, history: list, display=None) -> dict:
    """Write a finished stage's history.csv, population.csv (and front CSV)
    and return its result (the caller writes result.json).  ``display(rows,
    stage)``: the rows as the CSV files show them (units, own sense); the
    result keeps the internal rows (SI, minimized objectives)."""
    show = display or (lambda rows, st: rows)
    folder.stage_dir(stage.name)
    folder.write_text(f"stages/{stage.name}/history.csv", rows_csv(show(history, stage)))
    pop_rows = population_rows(evaluator, problem, algorithm.pop)
    folder.write_text(f"stages/{stage.name}/population.csv", rows_csv(show(pop_rows, None)))
    res = {"stage": stage.name, "kind": stage.kind, "generations": len(history),
           "evaluations": int(algorithm.evaluator.n_eval)}
    if stage.kind in ("single", "weighted"):
        best = algorithm.opt[0]
        feasible = bool(best.CV[0] <= 0)
        design = {k: float(v[0]) for k, v in evaluator.designs(best.X[None, :]).items()}
        res.update({"feasible": feasible, "objective": float(best.F[0]) if feasible else None,
                    "design": design,
                    "indices": {k: float(best.get(f"index_{k}")) for k in evaluator.index_names}})
        if stage.kind == "single":
            res["index"] = stage.index
            res["sense"] = stage.sense
            res["value"] = res["indices"][stage.index] if feasible else None
    else:
        opt = algorithm.opt
        opt = opt[opt.get("CV")[:, 0] <= 0]
        rows = population_rows(evaluator, problem, opt)
        folder.write_text(f"{stage.name}.csv", rows_csv(show(rows, None)))
        res.update({"front_size": len(opt), "front": rows, "terms": [t.label() for t in problem.terms]})
    return res


def _num(v, none=False) -> bool:
    return (v is None and none) or (isinstance(v, (int, float)) and not isinstance(v, bool))


def check_stage_result(res: dict, stage, path) -> dict:
    """A finished stage's result.json has what the run reads from it (else RunFolderError)."""
    ok = res.get("kind") == stage.kind and _num(res.get("evaluations"))
    if ok and stage.kind in ("single", "weighted"):
        d = res.get("design")
        ok = (isinstance(res.get("feasible"), bool) and _num(res.get("objective"), True)
              and isinstance(d, dict) and all(_num(v) and math.isfinite(v) for v in d.values())
              and isinstance(res.get("indices"), dict)
              and (stage.kind != "single" or _num(res.get("value"), True)))
    elif ok:
        ok = (isinstance(res.get("terms"), list) and isinstance(res.get("front"), list)
              and all(isinstance(r, dict) and all(_num(r.get(f"objective_{t}")) for t in res["terms"])
                      for r in res["front"]))
    if not ok:
        raise RunFolderError(f"{path}: not the result of a {stage.kind} stage")
    return res


def finished_stage(folder: RunFolder, stage, seed: int) -> dict | None:
    """The result of a stage the manifest records as finished with ``seed``
    (its files checked), or None."""
    done = folder.stage_result(stage.name)
    if done is not None:
        if folder.stage_record(stage.name).get("seed") != seed:
            raise RunFolderError(f"{folder.manifest_path}: stages.{stage.name}: finished with another seed")
        check_stage_result(done, stage, folder.path / "stages" / stage.name / "result.json")
    return done


def final_results(cfg, seed: int, stages: dict, lo: dict, hi: dict, ws, evaluator) -> dict:
    from ..evaluate import evaluate

    ws_res = stages["weighted_sum"]
    if not ws_res["feasible"]:
        raise RuntimeError("the weighted-sum GA found no feasible design")
    opt_design = ws_res["design"]
    names = [n for n in cfg.designs if n != "initial" or len(cfg.designs) == 1]
    ev = evaluate(cfg, [opt_design] + [cfg.design(n) for n in names], ws)
    senses = {k: s.sense for k, s in cfg.indices.items()}
    weights = {k: cfg.optimizer.weights[k] for k in lo}

    def summ(i):
        return {k: {s: float(ev.summary[k][s][i]) for s in ("mean", "min", "max", "std")} for k in cfg.indices}

    vals = {k: ev.summary[k]["mean"] for k in cfg.indices}
    ours = weighted_sum(vals, weighted_sum_term(lo, hi, weights, senses))
    literal = weighted_sum(vals, weighted_sum_term(lo, hi, weights, senses, literal=True))
    designs = {}
    for j, n in enumerate(names):
        designs[n] = {"parameters": cfg.design(n), "global_indices": summ(j + 1),
                      "reachable_fraction": float(ev.reachable_fraction[j + 1]),
                      "objective": float(ours[j + 1]), "objective_paper_literal": float(literal[j + 1])}
    results = {
        "status": "complete", "seed": seed, "config": cfg.name, "mechanism": cfg.mechanism,
        "optimum": {k: float(v) for k, v in opt_design.items()},
        "objective": float(ws_res["objective"]),
        "objective_paper_literal": float(literal[0]),
        "global_indices": {k: float(vals[k][0]) for k in cfg.indices},
        "global_index_summary": summ(0),
        "reachable_fraction": float(ev.reachable_fraction[0]),
        "normalization": {k: {"min": lo[k], "max": hi[k], "sense": senses[k], "weight": weights[k]} for k in lo},
        "designs": designs,
        "reference": cfg.reference,
        "workspace_points": int(ws.n),
    }
    if "weighted_sum_literal" in stages and stages["weighted_sum_literal"]["feasible"]:
        s = stages["weighted_sum_literal"]
        results["paper_literal_optimum"] = {"design": s["design"], "objective": s["objective"], "global_indices": s["indices"]}
    candidates = {"weighted_sum_optimum": (results["global_indices"], results["optimum"])}
    for j, n in enumerate(names):
        candidates[n] = ({k: float(ev.summary[k]["mean"][j + 1]) for k in cfg.indices}, cfg.design(n))
    bounds = {p: tuple(dv.bounds or (dv.value,) * 2) for p, dv in cfg.design_variables.items()}
    pareto = {name: place_against_front(s, candidates, lo, hi, senses, evaluator, bounds)
              for name, s in stages.items() if s["kind"] == "pareto"}
    if pareto:
        results["pareto"] = pareto
    return results


def place_against_front(s: dict, candidates: dict, lo: dict, hi: dict, senses: dict, evaluator, bounds: dict) -> dict:
    """Hypervolume of the front and the additive-epsilon placement of the
    candidates (name -> (index values, design)) in normalized objective space."""
    terms = s["terms"]
    extras = evaluator.extra
    front = np.array([[row[f"objective_{t}"] for t in terms] for row in s["front"]]) if s["front"] else np.zeros((0, len(terms)))
    # normalization: indices by their single-objective extremes (best -> 0, worst -> 1)
    scale_lo, scale_hi = [], []
    for t in terms:
        k = t.lstrip("-")
        col = front[:, terms.index(t)] if len(front) else np.array([0.0, 1.0])
        if k in lo:
            a, b = (lo[k], hi[k]) if senses[k] == "min" else (-hi[k], -lo[k])
        elif k in extras:  # the range over its parameters' bounds and the front
            a, b = float(np.min(col)), float(np.max(col))
            vmin, vmax = evaluator.extra_range(k, bounds)
            emin, emax = (vmin, vmax) if t == k else (-vmax, -vmin)
            a, b = min(a, emin), max(b, emax)
        else:  # an index with weight 0 (no single-objective runs): the front's own range
            a, b = float(np.min(col)), float(np.max(col))
        scale_lo.append(a)
        scale_hi.append(b if b > a else a + 1.0)
    scale_lo, scale_hi = np.array(scale_lo), np.array(scale_hi)
    norm = lambda F: (np.asarray(F) - scale_lo) / (scale_hi - scale_lo)  # noqa: E731
    Fn = norm(front) if len(front) else front
    hv = float(HV(ref_point=np.full(len(terms), 1.1))(Fn)) if len(Fn) else 0.0

    def point(values: dict) -> np.ndarray:
        return np.array([-values[t[1:]] if t.startswith("-") else values[t] for t in terms])

    placed = {}
    spread = float(np.max(Fn.max(axis=0) - Fn.min(axis=0))) if len(Fn) else 0.0
    for n, (indices, design) in candidates.items():
        ex = evaluator.extra_values({k: np.array([v]) for k, v in design.items()})
        p = norm(point({**indices, **{e: float(np.asarray(v)[0]) for e, v in ex.items()}}))
        if len(Fn):
            eps = float(np.min(np.max(Fn - p, axis=1)))
            dominated_by = int(np.sum(np.all(Fn <= p, axis=1) & np.any(Fn < p, axis=1)))
        else:
            eps, dominated_by = float("nan"), 0
        placed[n] = {"normalized_objectives": p.tolist(), "epsilon": eps, "dominated": eps < 0,
                     "dominated_by_points": dominated_by}
    return {"front_size": int(len(front)), "hypervolume": hv, "hypervolume_reference": [1.1] * len(terms),
            "normalization": {"terms": terms, "best": scale_lo.tolist(), "worst": scale_hi.tolist()},
            "front_spread": spread, "placement": placed}
