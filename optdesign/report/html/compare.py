"""One page setting several finished runs side by side: their optima, global
indices and manifests in tables, their Pareto fronts overlaid in one scatter
matrix, and the convergence of their weighted sums."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ...io import atomic_write_text
from .figures import (COLORS, MARKS, TEMPLATE, _front_values, design_points, esc, fmt, hover_lines, matrix_trace,
                      style_matrix)
from .page import Page
from .plot import Figure
from ...runs import RunFolderError
from .rundata import RunData, load_run
from .tables import html_table, objective_text
from ...units import DIMENSIONLESS, index_label, index_unit, objective_unit, variable_unit

__all__ = ["build_compare", "write_compare_html"]


#: the height of one legend entry (one line of 11 px text) in the legends under the plots
LEGEND_ROW = 20


def legend_below(fig: Figure, axis_room: int) -> Figure:
    """The legend under the plot, one entry per line: entries side by side
    overlap one another and are clipped at the figure's edge once run names
    are long.  The bottom margin (``axis_room``: the axes' titles) and the
    height grow by the legend's height, so the plot keeps its size."""
    n = sum(1 for d in fig.data if d.get("showlegend") is not False)
    room = LEGEND_ROW * n + 12
    fig.update_layout(legend=dict(orientation="v", yref="container", y=0, yanchor="bottom", x=0, xanchor="left",
                                  font=dict(size=11), tracegroupgap=0),
                      margin=dict(b=axis_room + room), height=int(fig.layout.get("height") or 450) + room)
    return fig


def _labels(runs: list[RunData]) -> list[str]:
    return [f"{i + 1}: {r.path.name}" for i, r in enumerate(runs)]


def _runs_table(runs, labels) -> str:
    rows = []
    for lab, r in zip(labels, runs):
        m = r.manifest
        rows.append([esc(lab), esc(r.name), f"<code>{esc(r.mechanism)}</code>", esc(m.get("seed", "-")),
                     objective_text(r.results.get("objective")), esc(m.get("evaluations", "-")),
                     f"{esc(m.get('wall_time_s', '-'))} s", esc(m.get("end_time", "-"))])
    return html_table(["run", "config", "mechanism", "seed", "f at the optimum", "design evaluations", "wall time",
                       "finished"], rows, numeric_from=3, text_cols=(7,))


def _union(lists) -> list[str]:
    out = []
    for li in lists:
        for k in li:
            if k not in out:
                out.append(k)
    return out


def _side_by_side(names, runs, labels, unit_of, value_of, extra_col=None) -> str:
    """Rows ``names``, one column per run; the unit in its own column when the
    runs agree on it, beside each value otherwise."""
    headers = ["", "unit"] + ([extra_col[0]] if extra_col else []) + [esc(x) for x in labels]
    rows = []
    for k in names:
        units = [unit_of(r, k) for r in runs]
        known = {u for u, r in zip(units, runs) if value_of(r, k) is not None}
        same = len(known) <= 1
        u0 = next(iter(known)) if known and same else None
        row = [f"<code>{esc(k)}</code>", esc(u0) if same and u0 else ("<span class=muted>per run</span>" if not same else "")]
        if extra_col:
            row.append(extra_col[1](runs, k))
        for r, u in zip(runs, units):
            v = value_of(r, k)
            if v is None:
                row.append("<span class=muted>-</span>")
            else:
                row.append(fmt(v) + ("" if same or not u or u == DIMENSIONLESS else f"&nbsp;{esc(u)}"))
        rows.append(row)
    return html_table(headers, rows, numeric_from=2 + (1 if extra_col else 0))


def _optimum(r: RunData, k: str):
    dv = r.units.variables.get(k)
    v = r.results["optimum"].get(k)
    return dv.display(v) if dv is not None and isinstance(v, (int, float)) else None


def _index(r: RunData, k: str):
    v = r.results["global_indices"].get(k)
    return v if k in r.units.indices and isinstance(v, (int, float)) else None


def _senses(runs, k) -> str:
    s = {r.units.indices[k][1] for r in runs if k in r.units.indices}
    return esc("/".join(sorted(s)))


def _fronts_figure(runs: list[RunData], labels: list[str]) -> tuple[Figure | None, str]:
    fronts = [(lab, r, f) for lab, r in zip(labels, runs) for f in r.fronts.values() if f.size]
    if not fronts:
        return None, "No run has a Pareto front."
    common = [o for o in fronts[0][2].objectives if all(o in f.objectives for _, _, f in fronts)]
    units = {o: {objective_unit(r.units, o)[0] for _, r, _ in fronts} for o in common}
    common = [o for o in common if len(units[o]) == 1]
    if len(common) < 2:
        return None, "The runs' fronts share fewer than two objectives (with the same unit): nothing to overlay."
    fig = Figure()
    r0 = fronts[0][1]
    dims_label = {o: esc(index_label(r0.units, o)) for o in common}
    dims = [dims_label[o] for o in common]
    for j, (lab, r, f) in enumerate(fronts):
        vals = _front_values(r, f)
        text = [hover_lines(r, f.designs, vals, i, f"{lab} · {f.name} design {i + 1}") for i in range(f.size)]
        big = f.size <= 3
        fig.add_trace(matrix_trace(dims, [vals[o] for o in common], text=text,
                                   hovertemplate="%{text}<extra></extra>", name=esc(f"{lab} · {f.name} ({f.size})"),
                                   marker=dict(size=14 if big else 6, color=COLORS[j % len(COLORS)], opacity=0.75,
                                               line=dict(width=1 if big else 0.3, color="#333"))))
    for j, (lab, r) in enumerate(zip(labels, runs)):
        name, params, ov = design_points(r, common)[0]
        if any(ov.get(o) is None or not np.isfinite(ov[o]) for o in common):
            continue
        t = hover_lines(r, {k: np.array([v]) for k, v in params.items()}, {k: np.array([v]) for k, v in ov.items()},
                        0, f"{lab}: {name}")
        fig.add_trace(matrix_trace(dims, [[ov[o]] for o in common], text=[t], hovertemplate="%{text}<extra></extra>",
                                   name=esc(f"{lab}: weighted-sum optimum"),
                                   marker=dict(size=11, symbol=MARKS[j % len(MARKS)], color="#111",
                                               line=dict(width=1, color="white"))))
    n = len(common)
    style_matrix(fig, dims)
    fig.update_layout(template=TEMPLATE, height=max(440, 230 * (n - 1) + 160),
                      dragmode="select", hovermode="closest",
                      title=dict(text="Pareto fronts of the runs overlaid (objectives in their own sense)", x=0.01),
                      margin=dict(t=70, l=90))
    legend_below(fig, 80)
    singles = [f"{lab} · {f.name}" for lab, _, f in fronts if f.size == 1]
    note = ""
    if singles:
        note = "Fronts that collapsed to one design (drawn large): " + ", ".join(esc(s) for s in singles) + "."
    return fig, note


def _convergence_figure(runs, labels) -> Figure | None:
    fig = Figure()
    for j, (lab, r) in enumerate(zip(labels, runs)):
        rows = r.history.get("weighted_sum")
        if not rows:
            continue
        g = np.array([x.get("generation", np.nan) for x in rows], float)
        b = np.array([x.get("best_objective", np.nan) for x in rows], float)
        fig.add_trace(dict(type="scatter", x=g, y=b, mode="lines", name=esc(lab),
                           line=dict(color=COLORS[j % len(COLORS)]),
                           hovertemplate="generation %{x}<br>best f %{y:.5g}<extra>" + esc(lab) + "</extra>"))
    if not fig.data:
        return None
    fig.update_layout(template=TEMPLATE, height=420,
                      title=dict(text="Weighted-sum stage: best f per generation (each run scaled by its own "
                                      "normalization)", x=0.01),
                      margin=dict(t=80))
    legend_below(fig, 60)
    fig.update_xaxes(title=dict(text="generation"))
    ys = np.concatenate([np.asarray(d["y"], float) for d in fig.data])
    ys = ys[np.isfinite(ys)]
    if len(ys) and np.all(ys > 0):   # f falls by decades towards 0: a linear axis shows it flat at 0
        fig.update_yaxes(title=dict(text="f [–], log scale"), type="log")
    else:
        fig.update_yaxes(title=dict(text="f [–]"))
    return fig


def build_compare(runs: list[RunData]) -> str:
    labels = _labels(runs)
    page = Page("optdesign: runs side by side")
    page.section("runs", "Runs")
    page.html(_runs_table(runs, labels))
    page.section("optima", "Optima")
    dvs = _union([list(r.units.variables) for r in runs])
    page.html(_side_by_side(dvs, runs, labels, lambda r, k: variable_unit(r.units, k) if k in r.units.variables else None,
                            _optimum))
    page.html("<p class=note>Design parameters of each run's weighted-sum optimum, in its config's units.</p>")
    page.section("indices", "Global indices")
    idx = _union([list(r.units.indices) for r in runs])
    page.html(_side_by_side(idx, runs, labels, lambda r, k: index_unit(r.units, k) if k in r.units.indices else None, _index,
                            extra_col=("sense", _senses)))
    page.html("<p class=note>Means over each run's own workspace at its optimum (SI; [–]: dimensionless). Runs with "
              "different workspaces or index conventions are not on one scale.</p>")
    page.section("fronts", "Pareto fronts")
    fig, note = _fronts_figure(runs, labels)
    if note:
        page.html(f"<p class=note>{note}</p>")
    if fig is not None:
        page.add_figure(fig)
    conv = _convergence_figure(runs, labels)
    if conv is not None:
        page.section("convergence", "Convergence")
        page.add_figure(conv)
    header = ("<header><h1>Runs side by side</h1>"
              f"<p>{len(runs)} finished runs: " + ", ".join(f"<code>{esc(x)}</code>" for x in labels) + "</p></header>")
    footer = (f"Written by optdesign from the run folders' files. Self-contained: plotly.js is embedded once (about "
              f"4.8 MB of the page); {page.figures} figures; nothing is loaded from the network.")
    return page.render(header, footer)


def write_compare_html(folders, out: str | os.PathLike) -> Path:
    """Write the comparison page of ``folders`` (finished run folders) to the
    file ``out`` (nothing else is written; a symbolic link there is refused,
    never followed) and return its path made absolute."""
    runs = [load_run(f) for f in folders]
    target = Path(os.path.abspath(out))
    try:
        text = build_compare(runs)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:  # a hand-edited or damaged folder
        raise RunFolderError(f"unexpected content in the runs' files ({type(exc).__name__}: {exc})") from None
    atomic_write_text(target, text)
    return target
