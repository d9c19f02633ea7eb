"""Result tables (Markdown) and plots of a finished run."""
from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..config import Config
from ..runs import RunFolder

__all__ = ["write_report", "parameter_table", "index_table", "format_results", "extremes_lines", "optimality_lines"]


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


def _unit(cfg: Config, k: str) -> str:
    u = cfg.design_variables[k].unit
    if u == "deg":
        return "deg"
    if u == "mm":
        return "mm"
    return "rad" if k in ("phi", "theta", "psi") else "m"


def parameter_table(cfg: Config, results: dict) -> str:
    """The paper's Table 3: parameters before and after, and our optimum."""
    names = [n for n in results["designs"] if n != "initial"]
    headers = ["parameter"] + [f"{n} (config)" for n in names] + ["our optimum", "bounds"]
    rows = []
    for k, dv in cfg.design_variables.items():
        row = [f"{k} / {_unit(cfg, k)}"]
        for n in names:
            row.append(_f(dv.display(results["designs"][n]["parameters"][k])))
        row.append(_f(dv.display(results["optimum"][k])))
        row.append(f"[{_f(dv.display(dv.bounds[0]), 3)}, {_f(dv.display(dv.bounds[1]), 3)}]" if dv.free else "fixed")
        rows.append(row)
    return _md(headers, rows)


def index_table(cfg: Config, results: dict) -> str:
    """Global indices before, after (paper design), our optimum; improvement
    factors; the paper's values and our relative differences."""
    ref = results.get("reference", {})
    d = results["designs"]
    have = [n for n in ("before", "after") if n in d]
    headers = ["index", "sense"]
    for n in have:
        headers += [f"{n} (ours)", f"{n} (paper)", "rel. diff"]
    headers += ["our optimum", "improvement (ours)", "improvement (paper)"]
    rows = []
    for k, spec in cfg.indices.items():
        row = [k, spec.sense]
        for n in have:
            v = d[n]["global_indices"][k]["mean"]
            p = ref.get(n, {}).get(k)
            row += [_f(v), _f(p), f"{100 * (v - p) / p:+.2f}%" if p else "-"]
        o = results["global_indices"][k]

        def factor(a, b):
            if a is None or b is None or a == 0 or b == 0:
                return "-"
            return f"{(a / b if spec.sense == 'min' else b / a):.3f}x"

        b_ours = d["before"]["global_indices"][k]["mean"] if "before" in d else None
        pb, pa = ref.get("before", {}).get(k), ref.get("after", {}).get(k)
        row += [_f(o), factor(b_ours, o), factor(pb, pa)]
        rows.append(row)
    return _md(headers, rows)


def format_results(cfg: Config, results: dict) -> str:
    """The whole Markdown report of a run."""
    lines = [f"# {cfg.name}: optimization results", ""]
    lines.append(f"Mechanism `{cfg.mechanism}`, seed {results['seed']}, {results['workspace_points']} workspace points, "
                 f"{results.get('evaluations', '?')} design evaluations, wall time {results.get('wall_time_s', '?')} s.")
    lines.append("")
    lines.append("## Design parameters (the paper's Table 3 and our optimum)")
    lines.append("")
    lines.append(parameter_table(cfg, results))
    lines.append("")
    lines.append("## Global indices (means over W)")
    lines.append("")
    lines.append(index_table(cfg, results))
    lines.append("")
    lines.append("Improvement: before / optimum for an index to be minimized, optimum / before for one to be maximized.")
    lines.append("")
    lines.append("## Normalization (eq. 38-40)")
    lines.append("")
    rows = [[k, v["sense"], _f(v["min"]), _f(v["max"]), _f(v["weight"], 2)] for k, v in results["normalization"].items()]
    lines.append(_md(["index", "sense", "min over bounds", "max over bounds", "weight"], rows))
    lines.append("")
    paper_f = results.get("reference", {}).get("after", {}).get("objective")
    lines.append(f"- Weighted-sum objective at our optimum: **{_f(results['objective'])}** (each index scaled to [0, 1], "
                 f"stiffness flipped so that 0 is its best value)" + (f"; the paper reports f_min = {paper_f}." if paper_f else "."))
    lines.append(f"- The paper's literal eq. 38 (every term as if minimized) at our optimum: {_f(results['objective_paper_literal'])}.")
    if "paper_literal_optimum" in results:
        pl = results["paper_literal_optimum"]
        txt = ", ".join(f"{k} = {_f(cfg.design_variables[k].display(v))}" for k, v in pl["design"].items() if cfg.design_variables[k].free)
        lines.append(f"- Minimizing the literal eq. 38 instead gives {txt} (objective {_f(pl['objective'])}): "
                     "it rewards low stiffness, which is why we flip that term.")
    for n, dd in results["designs"].items():
        if dd.get("objective") is None and dd.get("objective_note"):
            lines.append(f"- The {n} design gets no normalized objective: {dd['objective_note']}.")
            continue
        lines.append(f"- The {n} design scores {_f(dd['objective'])} on our objective ({_f(dd['objective_paper_literal'])} literal).")
    lines += extremes_lines(cfg, results) + optimality_lines(cfg, results)
    if results.get("pareto"):
        lines.append("")
        lines.append("## Pareto fronts")
        lines.append("")
        rows = []
        for alg, p in results["pareto"].items():
            for n, pl in p["placement"].items():
                rows.append([alg, n, "yes" if pl["dominated"] else "no", _f(pl["epsilon"]), str(pl["dominated_by_points"])])
        lines.append(_md(["front", "point", "dominated", "additive epsilon", "front points dominating it"], rows))
        lines.append("")
        for alg, p in results["pareto"].items():
            lines.append(f"- `{alg}`: {p['front_size']} non-dominated designs, hypervolume {_f(p['hypervolume'])} "
                         f"(normalized objectives, reference point 1.1), front spread {_f(p['front_spread'])}.")
        lines.append("")
        lines.append("Additive epsilon: the smallest amount by which the front must be worsened in every "
                     "normalized objective so that it no longer dominates the point; negative means some front "
                     "design beats the point in every objective by at least that much.")
    lines.append("")
    return "\n".join(lines)


def _design_text(cfg: Config, design: dict) -> str:
    return ", ".join(f"{k} = {_f(dv.display(design[k]))}" for k, dv in cfg.design_variables.items()
                     if dv.free and k in design)


def extremes_lines(cfg: Config, results: dict) -> list[str]:
    """Where each extreme of the normalization was found (design, stage, how),
    and whether a later stage moved one (then every normalized objective of
    the report is recomputed from the final extremes)."""
    norm = results.get("normalization", {})
    rows = []
    for k, v in norm.items():
        for b in ("min", "max"):
            if f"{b}_found_by" in v:
                rows.append([k, b, _f(v[b]), v[f"{b}_found_by"], v.get(f"{b}_stage", ""), _design_text(cfg, v[f"{b}_design"])])
    if not rows:
        return []
    out = ["", "### Where the extremes were found", "",
           _md(["index", "extreme", "value", "found by", "stage", "design"], rows), ""]
    ups = results.get("normalization_updates")
    if ups:
        moved = "; ".join(f"{u['index']} {u['bound']} {_f(u['from'])} -> {_f(u['to'])} ({u['stage']})" for u in ups)
        out.append(f"- Later stages went beyond the extremes the weighted sums were run with ({moved}); the extremes "
                   "were updated and every normalized objective in this report is recomputed from the final extremes"
                   + (" (the optimum was polished again with them)." if "with_final_extremes" in results.get("polish", {})
                      else "."))
    else:
        out.append("- No later stage went beyond the extremes of the pre-scan and the single-objective stages.")
    out.append("- Every normalized term of a feasible design of the box lies in [0, 1] on these extremes, so the "
               f"weighted sum lies in [0, {_f(sum(v['weight'] for v in norm.values()), 2)}] (the sum of the weights).")
    return out


def optimality_lines(cfg: Config, results: dict) -> list[str]:
    """The polish of the weighted-sum optimum: the improvement over the GA and
    the first-order optimality measure with the active bounds and constraints."""
    p = results.get("polish")
    if not p or "optimality" not in p:
        return []
    o = p["optimality"]
    act = ", ".join(o["active_bounds"]) or "none"
    cons = ", ".join(f"{k} at {n} workspace point(s)" for k, n in o["active_constraints"].items()) or "none"
    rel = o.get("kkt_relative", o["kkt_residual"])
    ok = "below" if rel <= o["tolerance"] else "ABOVE"
    out = ["", "### The optimum's polish", "",
           f"- Weighted sum found by the search: {_f(p.get('ga_objective'))}; after the gradient polish "
           f"({p.get('starts', '?')} starts, derivatives by {'automatic differentiation' if o['route'] == 'ad' else 'central differences'}): "
           f"{_f(p.get('objective'))} (improvement {_f(p.get('improvement'))}).",
           f"- First-order optimality at the optimum (objective scaled by {_f(o['objective_scale'])}, design "
           f"variables scaled to the unit box): KKT residual {_f(o['kkt_residual'])}, "
           f"{_f(rel)} relative to max(1, gradient norm) ({ok} the tolerance {_f(o['tolerance'])}); projected "
           f"gradient norm {_f(o['projected_gradient_norm'])} (active bounds only), gradient norm "
           f"{_f(o['gradient_norm'])}.",
           f"- Active bounds: {act}. Active constraints: {cons}."]
    if o.get("differentiable") is False:
        out.append(f"- The objective is not differentiable at the optimum (the jump of its slope across the "
                   f"optimum along one variable is {_f(o['one_sided_jump'])} of its scale: a singular value an index takes crosses "
                   "its neighbour somewhere in W, a symmetric design for instance): the optimum sits on that kink "
                   "and the measure above is not a certificate of optimality there.")
    fin = p.get("with_final_extremes")
    if fin:
        out.insert(4, f"- With the final extremes the weighted sum at the search's optimum was {_f(fin['objective_before'])}; "
                      f"polished again with them: {_f(fin['objective'])} (the measure below is at this design).")
    return out


def write_report(cfg: Config, folder: RunFolder, results: dict, stages: dict) -> None:
    folder.write_text("results.md", format_results(cfg, results))
    _history_csv(folder, stages)
    try:
        _plots(cfg, folder, results, stages)
    except Exception as exc:  # noqa: BLE001 - a plot must never lose a finished run
        folder.write_text("plots-error.txt", f"{type(exc).__name__}: {exc}\n")


def _read_csv(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _history_csv(folder: RunFolder, stages: dict) -> None:
    """The weighted-sum history and final population at the top of the run folder."""
    for name, target in (("history.csv", "history.csv"), ("population.csv", "population.csv")):
        src = folder.path / "stages" / "weighted_sum" / name
        if src.exists():
            folder.write_text(target, src.read_text())


def _plots(cfg: Config, folder: RunFolder, results: dict, stages: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hist = _read_csv(folder.path / "stages" / "weighted_sum" / "history.csv")
    if hist:
        g = [int(r["generation"]) for r in hist]
        best = [float(r["best_objective"]) for r in hist]
        mean = [float(r["mean_objective"]) for r in hist]
        fig, ax = plt.subplots(figsize=(6.4, 4))
        ax.plot(g, best, label="best")
        ax.plot(g, mean, label="population mean", alpha=0.7)
        ax.set_xlabel("generation")
        ax.set_ylabel("weighted-sum objective f (eq. 40)")
        ax.set_title(f"{cfg.name}: convergence (cf. paper fig. 14)")
        ax.grid(alpha=0.3)
        ax.legend()
        fig.tight_layout()
        _save(fig, folder.path / "convergence.png")
        plt.close(fig)
    fronts = {k: v for k, v in stages.items() if v.get("kind") == "pareto" and v.get("front")}
    if not fronts:
        return
    any_front = next(iter(fronts.values()))
    terms = any_front["terms"]
    pairs = [(i, j) for i in range(len(terms)) for j in range(i + 1, len(terms))]
    ncol = min(3, len(pairs))
    nrow = -(-len(pairs) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 4.2 * nrow), squeeze=False)
    for ax in axes.flat[len(pairs):]:
        ax.set_visible(False)
    marks = {"weighted_sum_optimum": ("*", "k"), "before": ("s", "tab:red"), "after": ("D", "tab:green")}
    for ax, (i, j) in zip(axes.flat, pairs):
        for name, s in fronts.items():
            F = np.array([[r[f"objective_{t}"] for t in terms] for r in s["front"]])
            ax.scatter(F[:, i], F[:, j], s=12, alpha=0.6, label=name)
        for alg, p in results.get("pareto", {}).items():
            for n, pl in p["placement"].items():
                if n not in marks:
                    continue
                lo = np.array(p["normalization"]["best"])
                hi = np.array(p["normalization"]["worst"])
                v = np.array(pl["normalized_objectives"]) * (hi - lo) + lo
                mk, col = marks[n]
                ax.scatter([v[i]], [v[j]], marker=mk, c=col, s=70, label=n, zorder=5)
            break
        ax.set_xlabel(terms[i])
        ax.set_ylabel(terms[j])
        ax.grid(alpha=0.3)
    h, lab = axes[0][0].get_legend_handles_labels()
    uniq = dict(zip(lab, h))
    axes.flat[len(pairs) - 1].legend(uniq.values(), uniq.keys(), fontsize=8)
    fig.suptitle(f"{cfg.name}: Pareto fronts (objectives minimized; '-' = maximized index)")
    fig.tight_layout()
    _save(fig, folder.path / "pareto.png")
    plt.close(fig)


def _save(fig, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    from ..io import atomic_write_bytes

    atomic_write_bytes(path, buf.getvalue())
