"""The final results of a run: the optimum, the named designs and the fronts,
every normalized objective from the final extremes (:mod:`.normalization`).

When a stage after the single-objective ones (or a named design of the box)
moved an extreme, the weighted-sum optimum is polished once more with the
final extremes (it is the same objective up to the changed scale, so the
optimum may move a little); ``normalization_updates`` in results.json lists
what moved.  A named design whose index values fall outside the final
extremes (outside the box, or infeasible) gets no normalized objective: its
terms would leave [0, 1].
"""
from __future__ import annotations

import numpy as np

from .normalization import bounds_of, fold_extremes, normalization_record, terms_in_range
from .polish import optimality, polish_designs
from .problem import DesignProblem, normalized_terms, weighted_sum_term
from .refine import merge_observed, observed
from .results import place_against_front

__all__ = ["final_results"]


def _named_observed(evaluator, designs: dict, names, ev) -> dict:
    """The extremes among the named designs that lie in the box and are feasible."""
    if not names:
        return {}
    X = np.array([evaluator.vector(designs[n]) for n in names])
    inside = np.all((X >= evaluator.xl) & (X <= evaluator.xu), axis=1)
    # a named design that changes a fixed parameter is not a design of this box
    inside &= np.array([all(designs[n].get(k, v) == v for k, v in evaluator.defaults.items()
                            if k not in evaluator.free) for n in names])
    if not inside.any():
        return {}
    r = evaluator(X)
    ok = inside & np.all([v <= 0 for v in r["constraints"].values()], axis=0)
    return observed(evaluator, X[ok], {k: np.asarray(r["values"][k])[ok] for k in evaluator.index_names},
                    "named design")


def final_results(subject, weights: dict, seed: int, stages: dict, evaluator, polish: int = 0,
                  reference_note=None) -> dict:
    """The run's results.json from its finished ``stages``: ``subject``
    (:class:`.spec.RunSubject`) names the config and its named designs,
    ``weights`` the indices' weights (the optimizer's settings),
    ``evaluator`` evaluates designs over the run's workspace; ``polish``: the
    polish's starts (0: none); ``reference_note() -> str | None``: a paragraph
    on the config's reference (results.json's ``reference_note``), given by
    the caller that knows the study."""
    from ..evaluate import error_method

    ws_res = stages["weighted_sum"]
    if not ws_res["feasible"]:
        raise RuntimeError("the weighted-sum GA found no feasible design")
    ws = evaluator.workspace
    indices, named = evaluator.index_names, subject.designs
    names = [n for n in named if n != "initial" or len(named) == 1]
    senses = dict(evaluator.senses)
    weighted = [k for k in indices if weights.get(k, 0) > 0]
    weights = {k: weights[k] for k in weighted}
    ext0, _ = fold_extremes(stages, upto_singles=True)
    lo0, hi0 = bounds_of(ext0, weighted)
    ext, changes = fold_extremes(stages)
    ev_named = evaluator.model.evaluate([dict(named[n]) for n in names], ws) if names else None
    for k, b, old, new in merge_observed(ext, _named_observed(evaluator, named, names, ev_named), "designs"):
        changes.append({"index": k, "bound": b, "from": old, "to": new, "stage": "designs"})
    lo, hi = bounds_of(ext, weighted)
    opt_design, repolish = ws_res["design"], None
    if changes and polish > 0:
        # the weighted sum with the final extremes, polished from the optimum
        prob = DesignProblem(evaluator, [weighted_sum_term(lo, hi, weights, senses)])
        x0 = evaluator.vector(opt_design)
        got = polish_designs(prob, x0[None, :])
        f0 = float(prob.objectives(evaluator(x0[None, :])["values"])[0, 0])
        if got["best"] is not None and got["best"][1] < f0:
            opt_design = {k: float(v[0]) for k, v in evaluator.designs(got["best"][0][None, :]).items()}
        x = evaluator.vector(opt_design)
        r = evaluator(x[None, :])
        repolish = {"objective_before": f0, "objective": float(prob.objectives(r["values"])[0, 0]),
                    "optimality": optimality(prob, x, evaluator.free)}
        # the polished optimum is a feasible design of the box too: the extremes include it
        obs = observed(evaluator, x[None, :], {k: np.asarray(r["values"][k]) for k in evaluator.index_names}, "polish")
        for k, b, old, new in merge_observed(ext, obs, "final"):
            changes.append({"index": k, "bound": b, "from": old, "to": new, "stage": "final"})
        lo, hi = bounds_of(ext, weighted)
    ev = evaluator.model.evaluate([opt_design] + [dict(named[n]) for n in names], ws)

    def summ(i):
        return {k: {s: float(ev.summary[k][s][i]) for s in ("mean", "min", "max", "std")} for k in indices}

    def err(i):   # the error estimate of each global index (mean over W) against the integral
        return {k: float(ev.error[k][i]) for k in indices}

    vals = {k: ev.summary[k]["mean"] for k in indices}
    ours, literal = _clipped_sum(vals, lo, hi, weights, senses), _clipped_sum(vals, lo, hi, weights, senses, True)
    designs = {}
    for j, n in enumerate(names):
        v = {k: float(vals[k][j + 1]) for k in weighted}
        inside = terms_in_range(v, lo, hi)
        designs[n] = {"parameters": dict(named[n]), "global_indices": summ(j + 1),
                      "global_indices_error": err(j + 1),
                      **({"global_indices_status": {k: str(ev.status[k][j + 1]) for k in indices}}
                         if ev.status else {}),
                      "reachable_fraction": float(ev.reachable_fraction[j + 1]),
                      "objective": float(ours[j + 1]) if inside else None,
                      "objective_paper_literal": float(literal[j + 1]) if inside else None}
        if not inside:
            designs[n]["objective_note"] = ("an index lies outside the extremes over the design box (the design is "
                                            "outside the box or infeasible): its normalized terms would leave [0, 1]")
    full = lambda d: {k: float(v[0]) for k, v in evaluator.designs(evaluator.vector(d)[None, :]).items()}  # noqa: E731
    results = {
        "status": "complete", "seed": seed, "config": subject.name, "mechanism": subject.mechanism,
        "optimum": {k: float(v) for k, v in opt_design.items()},
        "objective": float(ours[0]),
        "objective_paper_literal": float(literal[0]),
        "global_indices": {k: float(vals[k][0]) for k in indices},
        "global_indices_error": err(0),
        **({"global_indices_status": {k: str(ev.status[k][0]) for k in indices}} if ev.status else {}),
        "error_method": error_method(ws),
        "global_index_summary": summ(0),
        "reachable_fraction": float(ev.reachable_fraction[0]),
        "normalization": normalization_record(ext, weighted, senses, weights, full),
        "designs": designs,
        "reference": subject.reference,
        "workspace_points": int(ws.n),
    }
    results["polish"] = _polish_summary(ws_res, repolish)
    note = reference_note() if reference_note is not None else None
    if note:
        results["reference_note"] = note
    if changes:
        results["normalization_updates"] = changes
        results["normalization_of_the_weighted_stages"] = {"min": lo0, "max": hi0}
    if "weighted_sum_literal" in stages and stages["weighted_sum_literal"]["feasible"]:
        s = stages["weighted_sum_literal"]
        lv = {k: np.array([s["indices"][k]]) for k in weighted}
        results["paper_literal_optimum"] = {"design": s["design"], "global_indices": s["indices"],
                                            "objective": float(_clipped_sum(lv, lo, hi, weights, senses, True)[0])}
    candidates = {"weighted_sum_optimum": (results["global_indices"], results["optimum"])}
    for j, n in enumerate(names):
        candidates[n] = ({k: float(ev.summary[k]["mean"][j + 1]) for k in indices}, dict(named[n]))
    # each design parameter's range: a free one its bounds, a fixed one its value
    box = dict(zip(evaluator.free, zip(evaluator.xl.tolist(), evaluator.xu.tolist())))
    bounds = {p: box.get(p, (v, v)) for p, v in evaluator.defaults.items()}
    pareto = {name: place_against_front(s, candidates, lo, hi, senses, evaluator, bounds)
              for name, s in stages.items() if s["kind"] == "pareto"}
    if pareto:
        results["pareto"] = pareto
    return results


def _clipped_sum(vals: dict, lo: dict, hi: dict, weights: dict, senses: dict, literal: bool = False) -> np.ndarray:
    """The weighted sum with each normalized term clipped to [0, 1]: the
    values are those of designs whose index values lie within the extremes
    (checked, to 1e-12 relative), so the clip removes round-off only."""
    f = normalized_terms(vals, lo, hi, senses, literal)
    return sum(weights[k] * np.clip(f[k], 0.0, 1.0) for k in f)


def _polish_summary(ws_res: dict, repolish: dict | None) -> dict:
    """The optimum's polish: the GA's objective and the polished one (with
    the extremes of the weighted stage), the optimality measure at the
    reported optimum."""
    p = ws_res.get("polish")
    out = {"ga_objective": ws_res.get("ga", {}).get("objective"), "found_by": ws_res.get("found_by", "ga")}
    if p is not None:
        out.update({"objective": p["objective"], "improvement": p["improvement"],
                    "relative_improvement": p["relative_improvement"], "route": p["route"],
                    "optimality": p["optimality"], "starts": p["starts"]})
    if repolish is not None:
        out["with_final_extremes"] = repolish
        out["optimality"] = repolish["optimality"]
    return out
