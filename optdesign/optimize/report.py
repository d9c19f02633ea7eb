"""Result tables (Markdown) and plots of a finished run."""
from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..config import Config
from ..runs import RunFolder

__all__ = ["write_report", "parameter_table", "index_table", "reference_table", "format_results", "optimum_yaml"]


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
    from ..units import variable_unit

    return variable_unit(cfg, k)


def _index_unit(cfg: Config, k: str) -> str:
    from ..units import MIXED, index_unit

    return index_unit(cfg, k) or MIXED


def _named(results: dict) -> list[str]:
    return [n for n in results["designs"] if n != "initial"] or list(results["designs"])


def parameter_table(cfg: Config, results: dict) -> str:
    """The design parameters in the config's units: the config's named designs,
    the optimum and the bounds."""
    names = _named(results)
    headers = ["parameter", "unit"] + [f"{n} (config)" for n in names] + ["optimum", "bounds"]
    rows = []
    for k, dv in cfg.design_variables.items():
        row = [k, _unit(cfg, k)]
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


def index_table(cfg: Config, results: dict) -> str:
    """Global indices (means over W) of the named designs and the optimum, with
    the improvement of the optimum on the first named design."""
    d = results["designs"]
    names = _named(results)
    base = names[0] if names else None
    headers = ["index", "unit", "sense"] + [f"{n} (config)" for n in names] + ["optimum"]
    if base:
        headers.append(f"improvement on {base}")
    rows = []
    for k, spec in cfg.indices.items():
        o = results["global_indices"][k]
        row = [k, _index_unit(cfg, k), spec.sense] + [_f(d[n]["global_indices"][k]["mean"]) for n in names] + [_f(o)]
        if base:
            row.append(_factor(spec.sense, d[base]["global_indices"][k]["mean"], o))
        rows.append(row)
    return _md(headers, rows)


def reference_table(cfg: Config, results: dict) -> str:
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
    for k, spec in cfg.indices.items():
        row = [k]
        for n in have:
            v, p = d[n]["global_indices"][k]["mean"], ref[n].get(k)
            row += [_f(v), _f(p), f"{100 * (v - p) / p:+.2f}%" if p else "-"]
        if pair:
            a, b = (d[n]["global_indices"][k]["mean"] for n in pair)
            row += [_factor(spec.sense, a, b), _factor(spec.sense, ref[pair[0]].get(k), ref[pair[1]].get(k))]
        rows.append(row)
    return _md(headers, rows)


def _objective(x) -> str:
    """The weighted-sum objective; a value within round-off of 0 says so."""
    if x is not None and abs(float(x)) < 1e-12:
        return f"0 (to round-off: {float(x):.1e})"
    return _f(x)


def format_results(cfg: Config, results: dict) -> str:
    """The whole Markdown report of a run (the config's units, the index's own sense)."""
    from ..units import design_text, index_text

    lines = [f"# {cfg.name}: optimization results", ""]
    lines.append(f"Mechanism `{cfg.mechanism}`, seed {results['seed']}, {results['workspace_points']} workspace points, "
                 f"{results.get('evaluations', '?')} design evaluations, wall time {results.get('wall_time_s', '?')} s.")
    lines.append("")
    lines.append(f"**Optimum** (weighted sum): {design_text(cfg, results['optimum']) or 'no free variable'}.  ")
    lines.append("**Global indices** (means over W): "
                 + ", ".join(index_text(cfg, k, v) for k, v in results["global_indices"].items() if k in cfg.indices)
                 + ".  ")
    lines.append("The optimum as a named design, ready to paste under a config's `designs:`: `optimum.yaml`.")
    lines.append("")
    lines.append("## Design parameters")
    lines.append("")
    lines.append(parameter_table(cfg, results))
    lines.append("")
    lines.append("## Global indices (means over W)")
    lines.append("")
    lines.append(index_table(cfg, results))
    lines.append("")
    lines.append("Units: SI ([–]: dimensionless). Improvement: the named design's value divided by the optimum's "
                 "for an index to be minimized, the optimum's divided by the named design's for one to be maximized.")
    ref = reference_table(cfg, results)
    if ref:
        lines.append("")
        lines.append("### Beside the reference values")
        lines.append("")
        lines.append(ref)
        lines.append("")
        lines.append("Reference values: the config's `reference:` section; rel. diff = (ours - reference) / reference.")
    lines.append("")
    lines.append("## Normalization")
    lines.append("")
    rows = [[k, _index_unit(cfg, k) if k in cfg.indices else "-", v["sense"], _f(v["min"]), _f(v["max"]),
             _f(v["weight"], 2)] for k, v in results["normalization"].items()]
    lines.append(_md(["index", "unit", "sense", "min over bounds", "max over bounds", "weight"], rows))
    lines.append("")
    lines += _objective_lines(cfg, results)
    lines += _pareto_lines(cfg, results)
    lines.append("")
    return "\n".join(lines)


def _objective_lines(cfg: Config, results: dict) -> list[str]:
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
        lines.append(f"- Minimizing the sum without the flip instead gives {design_text(cfg, pl['design'])} "
                     f"(objective {_f(pl['objective'])}): it rewards a low value of a maximized index, "
                     "which is why that term is flipped.")
    for n, dd in results["designs"].items():
        lines.append(f"- The {n} design scores {_objective(dd['objective'])} on f"
                     + (f" ({_f(dd['objective_paper_literal'])} without the flip)." if flip else "."))
    return lines


def _pareto_lines(cfg: Config, results: dict) -> list[str]:
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


def optimum_yaml(cfg: Config, results: dict, run_name: str = "") -> str:
    """The optimum as a named design in the config's units, ready to paste
    under a config's ``designs:`` (every design variable, its unit in a comment)."""
    from ..units import DIMENSIONLESS

    width = max(len(k) for k in cfg.design_variables)
    lines = [f"# The weighted-sum optimum of {cfg.name}" + (f" (run {run_name}" if run_name else "")
             + (f", seed {results['seed']})" if run_name else f" (seed {results['seed']})") + ",",
             "# in the config's units: paste it under `designs:` of a config of mechanism "
             f"{cfg.mechanism} with the same design variables.",
             "optimum:"]
    for k, dv in cfg.design_variables.items():
        u = _unit(cfg, k)
        note = ("" if u == DIMENSIONLESS else u) + ("" if dv.free else (", " if u != DIMENSIONLESS else "") + "fixed")
        lines.append(f"  {k + ':':<{width + 1}} {dv.display(results['optimum'][k]):.12g}" + (f"   # {note}" if note else ""))
    return "\n".join(lines) + "\n"


def write_report(cfg: Config, folder: RunFolder, results: dict, stages: dict) -> None:
    folder.write_text("results.md", format_results(cfg, results))
    folder.write_text("optimum.yaml", optimum_yaml(cfg, results, folder.path.name))
    _history_csv(folder, stages)
    try:
        _plots(cfg, folder, results, stages)
    except Exception as exc:  # noqa: BLE001 - a plot must never lose a finished run
        folder.write_text("plots-error.txt", f"{type(exc).__name__}: {exc}\n")


def _read_csv(path: Path) -> list[dict]:
    """A CSV file of the run as rows keyed by quantity name (the unit suffix dropped)."""
    from ..units import strip_unit

    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return [{strip_unit(k): v for k, v in r.items()} for r in csv.DictReader(fh)]


def _history_csv(folder: RunFolder, stages: dict) -> None:
    """The weighted-sum history and final population at the top of the run folder."""
    for name, target in (("history.csv", "history.csv"), ("population.csv", "population.csv")):
        src = folder.path / "stages" / "weighted_sum" / name
        if src.exists():
            folder.write_text(target, src.read_text())


def _own_sense(cfg: Config, term: str, values) -> np.ndarray:
    """A minimized objective term's values in the objective's own sense and shown unit."""
    from ..units import objective_unit

    v = np.asarray(values, dtype=float)
    return (-v if term.startswith("-") else v) * objective_unit(cfg, term.lstrip("-"))[1]


def _objective_axis(cfg: Config, term: str) -> str:
    from ..units import index_label

    name = term.lstrip("-")
    sense = cfg.indices[name].sense if name in cfg.indices else ("max" if term.startswith("-") else "min")
    return f"{index_label(cfg, name)}, {'maximized' if sense == 'max' else 'minimized'}"


def _plots(cfg: Config, folder: RunFolder, results: dict, stages: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker  # noqa: F401

    hist = _read_csv(folder.path / "stages" / "weighted_sum" / "history.csv")
    if hist:
        g = [int(r["generation"]) for r in hist]
        best = [float(r["best_objective"]) for r in hist]
        mean = [float(r["mean_objective"]) for r in hist]
        fig, ax = plt.subplots(figsize=(6.4, 4), layout="constrained")
        ax.plot(g, best, label="best")
        ax.plot(g, mean, label="population mean", alpha=0.7)
        ax.set_xlabel("generation")
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
        ax.set_ylabel("weighted-sum objective f [–]")
        ax.set_title(f"{cfg.name}: convergence of the weighted sum (minimized)", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend()
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
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.8 * ncol, 4.2 * nrow + 0.5), squeeze=False, layout="constrained")
    for ax in axes.flat[len(pairs):]:
        ax.set_visible(False)
    marks = {"weighted_sum_optimum": ("*", "k", "weighted-sum optimum")}
    for n, (mk, col) in zip([n for n in results.get("designs", {})], [("s", "tab:red"), ("D", "tab:green"),
                                                                    ("^", "tab:purple"), ("v", "tab:brown")]):
        marks[n] = (mk, col, f"{n} (config)")
    sizes = {name: len(s["front"]) for name, s in fronts.items()}
    own = {name: np.array([[_own_sense(cfg, t, r[f"objective_{t}"]) for t in terms] for r in s["front"]])
           for name, s in fronts.items()}
    points = {}   # the weighted-sum optimum and the named designs, in the objectives' own sense
    for alg, p in results.get("pareto", {}).items():
        lo, hi = np.array(p["normalization"]["best"]), np.array(p["normalization"]["worst"])
        for n, pl in p["placement"].items():
            if n in marks:
                v = np.array(pl["normalized_objectives"]) * (hi - lo) + lo
                points[n] = np.array([_own_sense(cfg, t, v[k]) for k, t in enumerate(terms)])
        break
    for ax, (i, j) in zip(axes.flat, pairs):
        for n_front, (name, F) in enumerate(own.items()):
            label = f"{name} ({len(F)} design{'s' if len(F) != 1 else ''})"
            if len(F) == 1:   # a front of one design: a large ring (one size per front), seen around other marks
                ax.scatter(F[:, i], F[:, j], s=260 + 160 * n_front, facecolors="none", linewidths=2.2,
                           edgecolors=f"C{n_front}", label=label, zorder=6)
            else:
                ax.scatter(F[:, i], F[:, j], s=14, alpha=0.6, color=f"C{n_front}", edgecolors="none", label=label,
                           zorder=4)
        # the view: the fronts and the weighted-sum optimum; a named design far away is drawn at the edge
        core = np.vstack([*own.values()] + ([points["weighted_sum_optimum"][None, :]] if "weighted_sum_optimum" in points else []))
        lims = []
        for k in (i, j):
            a, b = float(np.min(core[:, k])), float(np.max(core[:, k]))
            scale = max(abs(a), abs(b), 1e-300)
            if b - a > 1e-6 * scale:       # a real spread: zoom on it
                pad = 0.08 * (b - a)
            else:                          # one design, or designs apart by round-off only
                a = b = 0.5 * (a + b)
                pad = 0.05 * scale
            lims.append((a - pad, b + pad))
        for n, v in points.items():
            mk, col, lab = marks[n]
            x, y = v[i], v[j]
            inside = lims[0][0] <= x <= lims[0][1] and lims[1][0] <= y <= lims[1][1]
            if not inside:
                lab = f"{lab}, outside: at the edge"
                x, y = np.clip(x, *lims[0]), np.clip(y, *lims[1])
            ax.scatter([x], [y], marker=mk, s=80, label=lab, zorder=7 if n == "weighted_sum_optimum" else 5, clip_on=False,
                       c=col if inside else "none", edgecolors=col, linewidths=1.5)
        ax.set_xlim(*lims[0])
        ax.set_ylim(*lims[1])
        ax.set_xlabel(_objective_axis(cfg, terms[i]), fontsize=9)
        ax.set_ylabel(_objective_axis(cfg, terms[j]), fontsize=9)
        ax.tick_params(labelsize=8)
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(5))
        ax.ticklabel_format(axis="both", style="sci", scilimits=(-3, 4), useOffset=False)
        ax.grid(alpha=0.3)
    h, lab = axes[0][0].get_legend_handles_labels()
    uniq = dict(zip(lab, h))
    longest = max(len(k) for k in uniq) + 5           # characters of an entry (8 pt: about 15 per inch)
    fig.legend(uniq.values(), uniq.keys(), fontsize=8, loc="outside lower center",
               ncol=max(1, min(len(uniq), int(ncol * 4.8 * 15 // longest))))
    one = [n for n, k in sizes.items() if k == 1]
    title = f"{cfg.name}: Pareto fronts, each objective in its own sense"
    if one:
        title += f"\n{', '.join(one)}: the front collapsed to ONE design (no trade-off found)"
    fig.suptitle(title, fontsize=10)
    _save(fig, folder.path / "pareto.png")
    plt.close(fig)


def _save(fig, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    from ..io import atomic_write_bytes

    atomic_write_bytes(path, buf.getvalue())
