"""Result tables (Markdown) and plots of a finished run."""
from __future__ import annotations

import numpy as np

from ..runs import RunFolder
from ..units import Units

__all__ = ["write_report", "parameter_table", "index_table", "reference_table", "format_results", "optimum_yaml",
           "extremes_lines", "optimality_lines"]


def _f(x, digits=4) -> str:
    if x is None:
        return "-"
    x = float(x)
    if not np.isfinite(x):
        return "-" if np.isnan(x) else ("inf" if x > 0 else "-inf")
    return f"{x:.{digits}f}" if 1e-3 <= abs(x) < 1e6 or x == 0 else f"{x:.{digits}e}"


def _md(headers, rows) -> str:
    from ..tables import table

    return table(headers, rows)


def _unit(units: Units, k: str) -> str:
    from ..units import variable_unit

    return variable_unit(units, k)


def _index_unit(units: Units, k: str) -> str:
    from ..units import MIXED, index_unit

    return index_unit(units, k) or MIXED


def _named(results: dict) -> list[str]:
    return [n for n in results["designs"] if n != "initial"] or list(results["designs"])


def parameter_table(units: Units, results: dict) -> str:
    """The design parameters in the config's units: the config's named designs,
    the optimum and the bounds."""
    names = _named(results)
    headers = ["parameter", "unit"] + [f"{n} (config)" for n in names] + ["optimum", "bounds"]
    rows = []
    for k, dv in units.variables.items():
        row = [k, _unit(units, k)]
        for n in names:
            row.append(_f(dv.display(results["designs"][n]["parameters"][k])))
        row.append(_f(dv.display(results["optimum"][k])))
        row.append(f"[{_f(dv.display(dv.bounds[0]), 3)}, {_f(dv.display(dv.bounds[1]), 3)}]" if dv.free else "fixed")
        rows.append(row)
    return _md(headers, rows)


def _factor(sense: str, a, b) -> str:
    """How much better b is than a: a / b for an index to be minimized, b / a for one to be maximized."""
    if a is None or b is None or a == 0 or b == 0:
        return "-"
    return f"{(a / b if sense == 'min' else b / a):.3f}x"


def index_table(units: Units, results: dict) -> str:
    """Global indices (means over W) of the named designs and the optimum, with
    the improvement of the optimum on the first named design."""
    d = results["designs"]
    names = _named(results)
    base = names[0] if names else None
    err = results.get("global_indices_error") or {}
    headers = ["index", "unit", "sense"] + [f"{n} (config)" for n in names] + ["optimum"] + (["±"] if err else [])
    if base:
        headers.append(f"improvement on {base}")
    rows = []
    for k, (_, sense) in units.indices.items():
        o = results["global_indices"][k]
        row = [k, _index_unit(units, k), sense] + [_f(d[n]["global_indices"][k]["mean"]) for n in names] + [_f(o)]
        if err:
            row.append(f"{err[k]:.2g}" if err.get(k) is not None and err[k] == err[k] else "-")
        if base:
            row.append(_factor(sense, d[base]["global_indices"][k]["mean"], o))
        rows.append(row)
    return _md(headers, rows)


def reference_table(units: Units, results: dict) -> str:
    """The named designs' indices beside the config's ``reference:`` values
    ("" if the config has none): ours, the reference, the relative difference,
    and the improvement from the first referenced design to the second."""
    ref = results.get("reference") or {}
    d = results["designs"]
    have = [n for n in _named(results) if isinstance(ref.get(n), dict)]
    if not have:
        return ""
    headers = ["index"]
    for n in have:
        headers += [f"{n} (ours)", f"{n} (reference)", "rel. diff"]
    pair = have[:2] if len(have) >= 2 else None
    if pair:
        headers += ["improvement (ours)", "improvement (reference)"]
    rows = []
    for k, (_, sense) in units.indices.items():
        row = [k]
        for n in have:
            v, p = d[n]["global_indices"][k]["mean"], ref[n].get(k)
            row += [_f(v), _f(p), f"{100 * (v - p) / p:+.2f}%" if p else "-"]
        if pair:
            a, b = (d[n]["global_indices"][k]["mean"] for n in pair)
            row += [_factor(sense, a, b), _factor(sense, ref[pair[0]].get(k), ref[pair[1]].get(k))]
        rows.append(row)
    return _md(headers, rows)


def _objective(x) -> str:
    """The weighted-sum objective; a value within round-off of 0 says so."""
    if x is not None and abs(float(x)) < 1e-12:
        return f"0 (to round-off: {float(x):.1e})"
    return _f(x)


def format_results(units: Units, results: dict) -> str:
    """The whole Markdown report of a run (the config's units, the index's own sense)."""
    from ..units import design_text, index_text

    lines = [f"# {results['config']}: optimization results", ""]
    lines.append(f"Mechanism `{results['mechanism']}`, seed {results['seed']}, {results['workspace_points']} workspace points, "
                 f"{results.get('evaluations', '?')} design evaluations, wall time {results.get('wall_time_s', '?')} s.")
    lines.append("")
    from .certificates import certificate_lines, status_text

    certs = results.get("certificates") or {}
    cert = f" ({status_text(certs['optimum'])} over W)" if "optimum" in certs else ""
    lines.append(f"**Optimum** (weighted sum): {design_text(units, results['optimum']) or 'no free variable'}{cert}.  ")
    lines.append("**Global indices** (means over W): "
                 + ", ".join(index_text(units, k, v) for k, v in results["global_indices"].items() if k in units.indices)
                 + ".  ")
    lines.append("The optimum as a named design, ready to paste under a config's `designs:`: `optimum.yaml`.")
    lines.append("")
    lines.append("## Design parameters")
    lines.append("")
    lines.append(parameter_table(units, results))
    lines.append("")
    lines.append("## Global indices (means over W)")
    lines.append("")
    lines.append(index_table(units, results))
    lines.append("")
    lines.append("Units: SI ([–]: dimensionless). Improvement: the named design's value divided by the optimum's "
                 "for an index to be minimized, the optimum's divided by the named design's for one to be maximized.")
    if results.get("global_indices_error"):
        lines.append(f"±: the error estimate of the optimum's mean against the integral over W "
                     f"({results.get('error_method', 'see docs/config.md')}).")
    ref = reference_table(units, results)
    if ref:
        lines.append("")
        lines.append("### Beside the reference values")
        lines.append("")
        lines.append(ref)
        lines.append("")
        lines.append("Reference values: the config's `reference:` section; rel. diff = (ours - reference) / reference.")
        if results.get("reference_note"):
            lines.append("")
            lines.append(results["reference_note"])
    lines.append("")
    lines.append("## Normalization")
    lines.append("")
    rows = [[k, _index_unit(units, k) if k in units.indices else "-", v["sense"], _f(v["min"]), _f(v["max"]),
             _f(v["weight"], 2)] for k, v in results["normalization"].items()]
    lines.append(_md(["index", "unit", "sense", "min over bounds", "max over bounds", "weight"], rows))
    lines.append("")
    lines += _objective_lines(units, results)
    lines += extremes_lines(units, results) + optimality_lines(results)
    lines += _pareto_lines(results)
    lines += certificate_lines(units, results)
    from .integrals import integral_lines

    lines += integral_lines(units, results)
    lines.append("")
    return "\n".join(lines)


def _objective_lines(units: Units, results: dict) -> list[str]:
    """The weighted-sum objective f at the optimum and the named designs."""
    from ..units import design_text

    ref = results.get("reference") or {}
    ref_f = [f"f = {v['objective']} for the {n} design" for n, v in ref.items()
             if isinstance(v, dict) and isinstance(v.get("objective"), (int, float))]
    lines = [f"- Weighted-sum objective f at the optimum: **{_objective(results['objective'])}** (each index scaled "
             "to [0, 1] between its minimum and maximum over the design bounds, a maximized index flipped so that 0 "
             "is its best value, then weighted and summed)" + (f"; the reference gives {', '.join(ref_f)}." if ref_f else ".")]
    flip = "paper_literal_optimum" in results or any(v["sense"] == "max" for v in results["normalization"].values())
    if flip:
        lines.append("- The same sum without the flip (every term as if minimized) at the optimum: "
                     f"{_f(results['objective_paper_literal'])}.")
    if "paper_literal_optimum" in results:
        pl = results["paper_literal_optimum"]
        lines.append(f"- Minimizing the sum without the flip instead gives {design_text(units, pl['design'])} "
                     f"(objective {_f(pl['objective'])}): it rewards a low value of a maximized index, "
                     "which is why that term is flipped.")
    for n, dd in results["designs"].items():
        if dd.get("objective") is None and dd.get("objective_note"):
            lines.append(f"- The {n} design gets no normalized objective: {dd['objective_note']}.")
            continue
        lines.append(f"- The {n} design scores {_objective(dd['objective'])} on f"
                     + (f" ({_f(dd['objective_paper_literal'])} without the flip)." if flip else "."))
    return lines


def _pareto_lines(results: dict) -> list[str]:
    if not results.get("pareto"):
        return []
    lines = ["", "## Pareto fronts", ""]
    rows = []
    for alg, p in results["pareto"].items():
        for n, pl in p["placement"].items():
            label = "weighted-sum optimum" if n == "weighted_sum_optimum" else f"{n} (config)"
            rows.append([alg, label, "yes" if pl["dominated"] else "no", _f(pl["epsilon"]), str(pl["dominated_by_points"])])
    lines.append(_md(["front", "design", "dominated", "additive epsilon", "front designs dominating it"], rows))
    lines.append("")
    for alg, p in results["pareto"].items():
        one = " (the front collapsed to one design: no trade-off was found)" if p["front_size"] == 1 else ""
        lines.append(f"- `{alg}`: {p['front_size']} non-dominated designs{one}, hypervolume {_f(p['hypervolume'])} "
                     f"(normalized objectives, reference point 1.1), front spread {_f(p['front_spread'])}.")
    lines.append("")
    lines.append("Additive epsilon: the smallest amount by which the front must be worsened in every "
                 "normalized objective so that it no longer dominates the design; negative means some front "
                 "design beats it in every objective by at least that much.")
    return lines


def optimum_yaml(units: Units, results: dict, run_name: str = "") -> str:
    """The optimum as a named design in the config's units, ready to paste
    under a config's ``designs:`` (every design variable, its unit in a comment)."""
    from ..units import DIMENSIONLESS

    width = max(len(k) for k in units.variables)
    lines = [f"# The weighted-sum optimum of {results['config']}" + (f" (run {run_name}" if run_name else "")
             + (f", seed {results['seed']})" if run_name else f" (seed {results['seed']})") + ",",
             "# in the config's units: paste it under `designs:` of a config of mechanism "
             f"{results['mechanism']} with the same design variables.",
             "optimum:"]
    for k, dv in units.variables.items():
        u = _unit(units, k)
        note = ("" if u == DIMENSIONLESS else u) + ("" if dv.free else (", " if u != DIMENSIONLESS else "") + "fixed")
        lines.append(f"  {k + ':':<{width + 1}} {dv.display(results['optimum'][k]):.12g}" + (f"   # {note}" if note else ""))
    return "\n".join(lines) + "\n"


def _design_text(units: Units, design: dict) -> str:
    from ..units import design_text

    return design_text(units, design)


def extremes_lines(units: Units, results: dict) -> list[str]:
    """Where each extreme of the normalization was found (design, stage, how),
    and whether a later stage moved one (then every normalized objective of
    the report is recomputed from the final extremes)."""
    from .certificates import status_text

    norm = results.get("normalization", {})
    certs = results.get("certificates") or {}
    rows = []
    for k, v in norm.items():
        for b in ("min", "max"):
            if f"{b}_found_by" in v:
                row = [k, b, _f(v[b]), v[f"{b}_found_by"], v.get(f"{b}_stage", ""), _design_text(units, v[f"{b}_design"])]
                if certs:
                    row.append(status_text(certs.get(f"{k}.{b}")))
                rows.append(row)
    if not rows:
        return []
    out = ["", "### Where the extremes were found", "",
           _md(["index", "extreme", "value", "found by", "stage", "design"] + (["over W"] if certs else []), rows), ""]
    ups = results.get("normalization_updates")
    if ups:
        moved = "; ".join(f"{u['index']} {u['bound']} {_f(u['from'])} -> {_f(u['to'])} ({u['stage']})" for u in ups)
        out.append(f"- Later stages went beyond the extremes the weighted sums were run with ({moved}); the extremes "
                   "were updated and every normalized objective in this report is recomputed from the final extremes"
                   + (" (the optimum was polished again with them)." if "with_final_extremes" in results.get("polish", {})
                      else "."))
    else:
        out.append("- No later stage went beyond the extremes of the pre-scan, the single-objective stages and the "
                   "seed-free multi-start (stage `extremes`, when the polish is on).")
    out.append("- Every normalized term of a feasible design of the box lies in [0, 1] on these extremes, so the "
               f"weighted sum lies in [0, {_f(sum(v['weight'] for v in norm.values()), 2)}] (the sum of the weights).")
    return out


def optimality_lines(results: dict) -> list[str]:
    """The polish of the weighted-sum optimum: the improvement over the GA and
    the first-order optimality measure with the active bounds and constraints."""
    p = results.get("polish")
    if not p or "optimality" not in p:
        return []
    o = p["optimality"]
    act = ", ".join(o["active_bounds"]) or "none"
    cons = ", ".join(f"{k} at {n} workspace point(s)" for k, n in o["active_constraints"].items()) or "none"
    rel = o.get("kkt_relative", o["kkt_residual"])
    out = ["", "### The optimum's polish", "",
           f"- Weighted sum found by the search: {_f(p.get('ga_objective'))}; after the gradient polish "
           f"({p.get('starts', '?')} starts, derivatives by {'automatic differentiation' if o['route'] == 'ad' else 'central differences'}): "
           f"{_f(p.get('objective'))} (improvement {_f(p.get('improvement'))}).",
           f"- Active bounds: {act}. Active constraints: {cons}."]
    if o.get("measurable") is False or rel is None:
        out.insert(4, "- First-order optimality at the optimum: not measured, the derivative of the objective or of an "
                      "active constraint is not finite there (impossible geometry next to the design).")
    else:
        ok = "below" if rel <= o["tolerance"] else "ABOVE"
        out.insert(4, f"- First-order optimality at the optimum (objective scaled by {_f(o['objective_scale'])}, design "
                      f"variables scaled to the unit box): KKT residual {_f(o['kkt_residual'])}, "
                      f"{_f(rel)} relative to max(1, gradient norm) ({ok} the tolerance {_f(o['tolerance'])}); projected "
                      f"gradient norm {_f(o['projected_gradient_norm'])} (active bounds only), gradient norm "
                      f"{_f(o['gradient_norm'])}.")
    if o.get("differentiable") is False and (o.get("measurable") is False or o.get("one_sided_jump") is None):
        out.append("- The objective is not finite next to the optimum along one variable (impossible geometry "
                   "there): the optimum sits at the edge of the feasible designs and the measure is no certificate.")
    elif o.get("differentiable") is False:
        out.append(f"- The objective is not differentiable at the optimum (the jump of its slope across the "
                   f"optimum along one variable is {_f(o['one_sided_jump'])} of its scale: a singular value an index takes crosses "
                   "its neighbour somewhere in W, a symmetric design for instance): the optimum sits on that kink "
                   "and the measure above is not a certificate of optimality there.")
    fin = p.get("with_final_extremes")
    if fin:
        out.insert(4, f"- With the final extremes the weighted sum at the search's optimum was {_f(fin['objective_before'])}; "
                      f"polished again with them: {_f(fin['objective'])} (the measure below is at this design).")
    return out


def write_report(units: Units, folder: RunFolder, results: dict, stages: dict) -> None:
    """results.md, optimum.yaml, the top-level CSV files and the plots of a
    finished run (``units``: how the config shows its quantities)."""
    from .png import plots as _plots

    folder.write_text("results.md", format_results(units, results))
    folder.write_text("optimum.yaml", optimum_yaml(units, results, folder.path.name))
    _history_csv(folder, stages)
    try:
        _plots(units, folder, results, stages)
    except Exception as exc:  # noqa: BLE001 - a plot must never lose a finished run
        folder.write_text("plots-error.txt", f"{type(exc).__name__}: {exc}\n")


def _history_csv(folder: RunFolder, stages: dict) -> None:
    """The weighted-sum history and final population at the top of the run folder."""
    for name, target in (("history.csv", "history.csv"), ("population.csv", "population.csv")):
        src = folder.path / "stages" / "weighted_sum" / name
        if src.exists():
            folder.write_text(target, src.read_text())
