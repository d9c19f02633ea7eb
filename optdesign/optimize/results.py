"""What a run reports: each stage's files and result, the final results and
the placement of the weighted-sum optimum and the named designs against the
Pareto fronts."""
from __future__ import annotations

import csv
import io
import math

import numpy as np
from pymoo.indicators.hv import HV

from ..runs import RunFolder, RunFolderError
from .refine import front_population, non_dominated, merge_observed, observed, refine_front, refine_single

__all__ = ["rows_csv", "population_rows", "stage_summary", "check_stage_result", "finished_stage",
           "place_against_front"]


def rows_csv(rows: list[dict]) -> str:
    """Rows (dicts) as CSV text: the union of their keys in order of appearance,
    floats as ``repr`` (exact), None as an empty field."""
    if not rows:
        return ""
    keys = list(rows[0])
    for r in rows[1:]:
        keys.extend(k for k in r if k not in keys)
    val = lambda v: "" if v is None else repr(v) if isinstance(v, float) else str(v)  # noqa: E731
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")    # a field with a comma (a unit 'SI, mixed') is quoted
    w.writerow(keys)
    w.writerows([val(r.get(k)) for k in keys] for r in rows)
    return out.getvalue()


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


def _rows_of(evaluator, problem, X: np.ndarray) -> tuple[list[dict], dict]:
    """Population rows (as :func:`population_rows`) of designs X evaluated afresh, and the evaluation."""
    out: dict = {}
    problem._evaluate(np.atleast_2d(X), out)
    designs = evaluator.designs(X)
    rows = []
    for i in range(len(X)):
        r = {k: float(v[i]) for k, v in designs.items()}
        for j, t in enumerate(problem.terms):
            r[f"objective_{t.label()}"] = float(out["F"][i, j])
        for k in evaluator.index_names:
            r[k] = float(out[f"index_{k}"][i])
        r["cv"] = float(np.sum(np.maximum(out["G"][i], 0.0)))
        for j, c in enumerate(problem.constraint_names):
            r[f"g_{c}"] = float(out["G"][i, j])
        rows.append(r)
    return rows, out


def _pop_observed(evaluator, pop) -> dict:
    X, CV = pop.get("X", "CV")
    ok = CV[:, 0] <= 0
    vals = {k: np.array([float(ind.get(f"index_{k}")) for ind in pop])[ok] for k in evaluator.index_names}
    return observed(evaluator, X[ok], vals, "ga")


def _merge_obs(*obs) -> dict:
    ext: dict = {}
    for o in obs:
        merge_observed(ext, o, "")
    return {k: {s: {kk: vv for kk, vv in r.items() if kk != "stage"} for s, r in v.items()} for k, v in ext.items()}


def stage_summary(folder: RunFolder, stage, algorithm, problem, evaluator, history: list,
                  seeds: np.ndarray | None = None, polish: int = 0, display=None) -> dict:
    """Write a finished stage's history.csv, population.csv (and front CSV),
    polish its best designs (``polish`` starts; 0: none) and return its result
    (the caller writes result.json).  ``display(rows, stage)``: the rows as the
    CSV files show them (units, own sense); the result keeps the internal rows
    (SI, minimized objectives)."""
    show = display or (lambda rows, st: rows)
    folder.stage_dir(stage.name)
    folder.write_text(f"stages/{stage.name}/history.csv", rows_csv(show(history, stage)))
    pop_rows = population_rows(evaluator, problem, algorithm.pop)
    folder.write_text(f"stages/{stage.name}/population.csv", rows_csv(show(pop_rows, None)))
    res = {"stage": stage.name, "kind": stage.kind, "generations": len(history),
           "evaluations": int(algorithm.evaluator.n_eval)}
    seeds = np.zeros((0, problem.n_var)) if seeds is None else np.asarray(seeds, dtype=float)
    ga_obs = _pop_observed(evaluator, algorithm.pop)
    if stage.kind in ("single", "weighted"):
        best = algorithm.opt[0]
        feasible = bool(best.CV[0] <= 0)
        ref = refine_single(problem, algorithm, seeds, polish)
        rows, out = _rows_of(evaluator, problem, ref["x"][None, :])
        design = {k: float(v[0]) for k, v in evaluator.designs(ref["x"][None, :]).items()}
        indices = {k: rows[0][k] for k in evaluator.index_names}
        res.update({"feasible": feasible, "objective": float(ref["value"]) if feasible else None,
                    "design": design, "indices": indices, "found_by": ref["found_by"],
                    "ga": {"objective": float(best.F[0]) if feasible else None,
                           "design": {k: float(v[0]) for k, v in evaluator.designs(best.X[None, :]).items()},
                           "indices": {k: float(best.get(f"index_{k}")) for k in evaluator.index_names}}})
        if ref["record"] is not None:
            res["polish"] = ref["record"]
        pol = observed(evaluator, ref["x"][None, :], {k: np.array([v]) for k, v in indices.items()}, "polish") \
            if ref["found_by"] == "polish" else {}
        res["observed"] = _merge_obs(ga_obs, pol)
        if stage.kind == "single":
            res["index"] = stage.index
            res["sense"] = stage.sense
            res["value"] = res["indices"][stage.index] if feasible else None
    else:
        opt = front_population(algorithm)
        X, F = opt.get("X", "F") if len(opt) else (np.zeros((0, problem.n_var)), np.zeros((0, problem.n_obj)))
        pol_obs, ref = {}, None
        if len(seeds) and len(X):   # the pre-scan's feasible designs: no reported point is dominated by one
            out0: dict = {}
            problem._evaluate(seeds, out0)
            ref = out0["F"][np.all(out0["G"] <= 0, axis=1)]
        if polish > 0 and len(opt):
            X, F, rec = refine_front(problem, X, F, reference=ref)
            res["polish"] = rec
        elif len(X):
            keep = non_dominated(F, ref)
            X, F = X[keep], F[keep]
        if len(X):
            rows, out = _rows_of(evaluator, problem, X)
            pol_obs = observed(evaluator, X, {k: out[f"index_{k}"] for k in evaluator.index_names},
                               "polish" if polish > 0 else "ga")
        else:
            rows = []
        folder.write_text(f"{stage.name}.csv", rows_csv(show(rows, None)))
        res.update({"front_size": len(rows), "front": rows, "terms": [t.label() for t in problem.terms],
                    "observed": _merge_obs(ga_obs, pol_obs)})
    return res


def _num(v, none=False) -> bool:
    return (v is None and none) or (isinstance(v, (int, float)) and not isinstance(v, bool))


def check_stage_result(res: dict, stage, path) -> dict:
    """A finished stage's result.json has what the run reads from it (else RunFolderError)."""
    ok = res.get("kind") == stage.kind and _num(res.get("evaluations"))
    ok = ok and (stage.kind == "prescan" or _observed_ok(res.get("observed")))
    if ok and stage.kind == "prescan":
        X, vals, names = res.get("designs"), res.get("values"), res.get("variables")
        ok = (isinstance(X, list) and isinstance(vals, dict) and isinstance(names, list)
              and all(isinstance(x, list) and len(x) == len(names) and all(_num(v) and math.isfinite(v) for v in x)
                      for x in X)
              and all(isinstance(v, list) and len(v) == len(X) and all(_num(a) for a in v) for v in vals.values()))
    elif ok and stage.kind == "extremes":
        ok = isinstance(res.get("runs"), dict)
    elif ok and stage.kind in ("single", "weighted"):
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


def _observed_ok(obs) -> bool:
    """A stage's observed extremes: index -> min/max -> value, design (numbers), found_by."""
    if not isinstance(obs, dict):
        return False
    for rec in obs.values():
        if not isinstance(rec, dict) or not set(rec) <= {"min", "max"}:
            return False
        for r in rec.values():
            if not (isinstance(r, dict) and _num(r.get("value")) and math.isfinite(r["value"])
                    and isinstance(r.get("design"), dict) and all(_num(v) for v in r["design"].values())
                    and isinstance(r.get("found_by"), str)):
                return False
    return True


def finished_stage(folder: RunFolder, stage, seed: int) -> dict | None:
    """The result of a stage the manifest records as finished with ``seed``
    (its files checked), or None."""
    done = folder.stage_result(stage.name)
    if done is not None:
        if folder.stage_record(stage.name).get("seed") != seed:
            raise RunFolderError(f"{folder.manifest_path}: stages.{stage.name}: finished with another seed")
        check_stage_result(done, stage, folder.path / "stages" / stage.name / "result.json")
    return done


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
