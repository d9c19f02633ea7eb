"""The report's tables as HTML: the optimum, the global indices (with the
config's reference values only where it has a ``reference:`` section), the
normalization, the Pareto placement and the manifest."""
from __future__ import annotations

import math

from .figures import esc, fmt
from .rundata import RunData
from ...units import DIMENSIONLESS, index_unit, variable_unit

__all__ = ["html_table", "optimum_table", "index_table", "normalization_table", "placement_table",
           "manifest_table", "objective_text", "reference_table"]


def html_table(headers, rows, numeric_from: int = 1, cls: str = "", text_cols=()) -> str:
    """``rows`` of already-escaped cell strings; columns from ``numeric_from``
    on are right-aligned numbers, except those in ``text_cols``; no header row
    if ``headers`` is None."""
    def num(i):
        return " class=num" if i >= numeric_from and i not in text_cols else ""

    head = "" if headers is None else \
        "<thead><tr>" + "".join(f"<th{num(i)}>{h}</th>" for i, h in enumerate(headers)) + "</tr></thead>"
    body = []
    for r in rows:
        body.append("<tr>" + "".join(f"<td{num(i)}>{c}</td>" for i, c in enumerate(r)) + "</tr>")
    c = f' class="{cls}"' if cls else ""
    return f"<div class=tablewrap><table{c}>{head}<tbody>{''.join(body)}</tbody></table></div>"


def _named(run: RunData) -> list[str]:
    return [n for n, d in run.results["designs"].items() if isinstance(d, dict) and isinstance(d.get("parameters"), dict)]


def _unit_cell(u: str | None) -> str:
    if u is None:
        return "<span class=muted>mixed</span>"
    return esc(u) if u != DIMENSIONLESS else "– <span class=muted>(dimensionless)</span>"


def optimum_table(run: RunData) -> str:
    r = run.results
    names = _named(run)
    headers = ["parameter", "unit", "<b>optimum</b>"] + [f"{esc(n)} (config)" for n in names] + ["bounds"]
    rows = []
    for k, dv in run.units.variables.items():
        row = [f"<code>{esc(k)}</code>", esc(variable_unit(run.units, k)), f"<b>{fmt(dv.display(r['optimum'][k]))}</b>"]
        for n in names:
            v = r["designs"][n]["parameters"].get(k)
            row.append(fmt(dv.display(v)) if isinstance(v, (int, float)) else "-")
        row.append(f"[{fmt(dv.display(dv.bounds[0]))}, {fmt(dv.display(dv.bounds[1]))}]" if dv.free else
                   "<span class=muted>fixed</span>")
        rows.append(row)
    return html_table(headers, rows, numeric_from=2)


def _mean(d: dict, k: str):
    v = d.get("global_indices", {}).get(k)
    return v.get("mean") if isinstance(v, dict) else None


def index_table(run: RunData) -> str:
    """Means over W of each index at the optimum and the named designs, the
    spread over W at the optimum, the improvement on the first named design."""
    r = run.results
    names = _named(run)
    summ = r.get("global_index_summary", {})
    err = r.get("global_indices_error") or {}
    headers = ["index", "unit", "sense", "<b>optimum</b>"] + (["±"] if err else []) + ["min over W", "max over W"]
    headers += [f"{esc(n)} (config)" for n in names]
    base = names[0] if names else None
    if base:
        headers.append(f"improvement on {esc(base)}")
    rows = []
    for k, (_, sense) in run.units.indices.items():
        o = r["global_indices"][k]
        s = summ.get(k, {}) if isinstance(summ.get(k), dict) else {}
        row = [f"<code>{esc(k)}</code>", _unit_cell(index_unit(run.units, k)), "max" if sense == "max" else "min",
               f"<b>{fmt(o)}</b>"] + ([fmt(err.get(k), 2)] if err else []) + [fmt(s.get("min")), fmt(s.get("max"))]
        row += [fmt(_mean(r["designs"][n], k)) for n in names]
        if base:
            b = _mean(r["designs"][base], k)
            if isinstance(b, (int, float)) and b and o:
                factor = b / o if sense == "min" else o / b
                row.append(f"{factor:.3f}×")
            else:
                row.append("-")
        rows.append(row)
    return html_table(headers, rows, numeric_from=3)


def reference_table(run: RunData) -> str:
    """The named designs' indices beside the config's ``reference:`` values
    (empty if the config has none)."""
    r = run.results
    ref = run.reference or {}
    names = [n for n in _named(run) if n in ref]
    if not names:
        return ""
    headers = ["index", "unit"]
    for n in names:
        headers += [f"{esc(n)} (ours)", f"{esc(n)} (reference)", "rel. diff"]
    rows = []
    for k in run.units.indices:
        row = [f"<code>{esc(k)}</code>", _unit_cell(index_unit(run.units, k))]
        for n in names:
            v, p = _mean(r["designs"][n], k), ref[n].get(k)
            row += [fmt(v), fmt(p), f"{100 * (v - p) / p:+.2f}%" if isinstance(v, (int, float)) and p else "-"]
        rows.append(row)
    return html_table(headers, rows, numeric_from=2)


def _design_text(run: RunData, design) -> str:
    if not isinstance(design, dict):
        return "<span class=muted>not recorded</span>"
    parts = []
    for k, dv in run.units.variables.items():
        if dv.free and isinstance(design.get(k), (int, float)):
            parts.append(f"{esc(k)}&nbsp;=&nbsp;{fmt(dv.display(design[k]), 4)}&nbsp;{esc(variable_unit(run.units, k))}")
    return ", ".join(parts) or "-"


def normalization_table(run: RunData) -> str:
    """Each index's range over the design bounds (the single-objective stages'
    minimum and maximum, which scale the weighted sum), with the designs where
    they were found and the weights."""
    norm = run.results["normalization"]
    rows = []
    for k, v in norm.items():
        if not isinstance(v, dict):
            continue
        unit = index_unit(run.units, k) if k in run.units.indices else None
        # where each extreme was found: results.json records it (a later stage may
        # have moved it); older runs have only the single-objective stages
        lo_d = v.get("min_design") or run.stages.get(f"single_{k}_min", {}).get("design")
        hi_d = v.get("max_design") or run.stages.get(f"single_{k}_max", {}).get("design")
        rows.append([f"<code>{esc(k)}</code>", _unit_cell(unit), esc(v.get("sense", "")), fmt(v.get("min")),
                     _design_text(run, lo_d), fmt(v.get("max")), _design_text(run, hi_d), fmt(v.get("weight"), 3)])
    return html_table(["index", "unit", "sense", "min over the bounds", "found at", "max over the bounds", "found at",
                       "weight"], rows, numeric_from=3, cls="norm", text_cols=(4, 6))


def objective_text(x) -> str:
    """The weighted-sum objective; a value within round-off of 0 says so."""
    if not isinstance(x, (int, float)) or math.isnan(x):
        return "-"
    if abs(x) < 1e-12:
        return f"0 (to round-off: {x:.1e})"
    return fmt(x)


def placement_table(run: RunData, front_name: str) -> str:
    p = run.results.get("pareto", {}).get(front_name, {})
    rows = []
    for n, pl in (p.get("placement") or {}).items():
        if not isinstance(pl, dict):
            continue
        label = "weighted-sum optimum" if n == "weighted_sum_optimum" else f"{n} (config)"
        rows.append([esc(label), "yes" if pl.get("dominated") else "no", fmt(pl.get("epsilon"), 4),
                     esc(pl.get("dominated_by_points", "-"))])
    if not rows:
        return ""
    return html_table(["design", "dominated by the front", "additive epsilon", "front designs dominating it"], rows)


def manifest_table(run: RunData) -> str:
    m = run.manifest
    rows = []

    def add(k, v, raw: bool = False):
        if v is not None and v != "" and v != []:
            rows.append([esc(k), v if raw else esc(v)])

    add("status", m.get("status"))
    add("seed", m.get("seed"))
    add("run key", m.get("run_key"))
    add("config", m.get("config_source") or m.get("config_name"))
    add("mechanism", run.mechanism)
    add("started", m.get("start_time"))
    add("finished", m.get("end_time"))
    add("wall time", f"{m.get('wall_time_s')} s" if m.get("wall_time_s") is not None else None)
    add("design evaluations", m.get("evaluations"))
    add("workspace points (optimization)", run.results.get("workspace_points"))
    add("Pareto stages", "yes" if m.get("pareto", True) else "no")
    stages = m.get("stages_done")
    if isinstance(stages, list):
        add("stages", ", ".join(str(s) for s in stages))
    vers = m.get("versions")
    if isinstance(vers, dict):
        add("versions", ", ".join(f"{k} {v}" for k, v in vers.items()))
    mach = m.get("machine")
    if isinstance(mach, dict):
        add("machine", ", ".join(f"{k}: {v}" for k, v in mach.items()))
    cmd = m.get("command")
    if isinstance(cmd, list):
        add("command", "<code>" + esc(" ".join(str(c) for c in cmd)) + "</code>", raw=True)
    return html_table(None, rows, numeric_from=99, cls="kv")
