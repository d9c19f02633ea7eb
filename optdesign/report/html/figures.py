"""The interactive figures of the report (plotly): convergence per stage, the
Pareto fronts as scatter matrices and parallel coordinates, the atlases.

Every axis and colorbar names its quantity and unit; objectives are shown in
their own sense (a maximized index as itself, not negated)."""
from __future__ import annotations

import html
import math

import numpy as np

from .atlas import AtlasMap
from .plot import Figure, colorscale, subplots
from .rundata import Front, RunData
from ...units import DIMENSIONLESS, index_label, label, objective_unit, variable_unit

__all__ = ["TEMPLATE", "fmt", "matrix_trace", "style_matrix", "convergence_figures", "front_splom",
           "front_parcoords", "atlas_figures", "design_points", "hover_lines", "objective_sense"]

#: a light template of our own (plotly's built-in ones add kilobytes to every figure)
TEMPLATE = dict(layout=dict(
    font=dict(family="system-ui, -apple-system, 'Segoe UI', Roboto, Helvetica, Arial, sans-serif", size=12,
              color="#222"),
    paper_bgcolor="white", plot_bgcolor="white",
    xaxis=dict(showgrid=True, gridcolor="#e5e5e5", zeroline=False, linecolor="#888", ticks="outside",
               automargin=True, showline=True, mirror=True),
    yaxis=dict(showgrid=True, gridcolor="#e5e5e5", zeroline=False, linecolor="#888", ticks="outside",
               automargin=True, showline=True, mirror=True),
    colorway=["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2"],
    hoverlabel=dict(align="left"),
    margin=dict(l=70, r=30, t=70, b=60),
))
COLORS = TEMPLATE["layout"]["colorway"]
#: markers of the weighted-sum optimum and of the config's named designs
MARKS = ["diamond", "square", "triangle-up", "cross", "triangle-down", "pentagon"]


def esc(s) -> str:
    return html.escape(str(s), quote=False)


def fmt(x, digits: int = 5) -> str:
    """A number for a table or a hover label (``-`` for missing)."""
    if x is None:
        return "-"
    x = float(x)
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == 0:
        return "0"
    ax = abs(x)
    if 1e-3 <= ax < 1e6:
        return f"{x:.{digits}g}"
    return f"{x:.{max(digits - 2, 1)}e}"


def objective_sense(run: RunData, name: str) -> str:
    if name in run.units.indices:
        return run.units.indices[name][1]
    e = run.units.extras.get(name)
    return e[2] if e is not None else "min"


def _obj_label(run: RunData, name: str, short: bool = False) -> str:
    s = index_label(run.units, name)
    if not short:
        s += " ↑ max" if objective_sense(run, name) == "max" else " ↓ min"
    return esc(s)


def _var_label(run: RunData, k: str) -> str:
    return esc(label(k, variable_unit(run.units, k)))


def hover_lines(run: RunData, designs: dict, values: dict, i: int, title: str) -> str:
    """One design's hover text: free parameters (config units), then the
    objectives and indices (SI, own sense)."""
    out = [f"<b>{esc(title)}</b>"]
    for k, dv in run.units.variables.items():
        if dv.free and k in designs:
            out.append(f"{esc(k)} = {fmt(dv.display(designs[k][i]))} {esc(variable_unit(run.units, k))}")
    for k, v in values.items():
        u, _ = objective_unit(run.units, k)
        out.append(f"{esc(k)} = {fmt(v[i])}" + (f" {esc(u)}" if u and u != DIMENSIONLESS else ""))
    return "<br>".join(out)


def _extra_value(run: RunData, name: str, design: dict) -> float:
    fn = run.model.mechanism.extra_objectives[name].func
    full = {k: np.array([float(design.get(k, v))]) for k, v in run.model.defaults.items()}
    return float(np.asarray(fn(full), dtype=float)[0])


def design_points(run: RunData, objectives: list[str]) -> list[tuple[str, dict, dict]]:
    """The weighted-sum optimum and the config's named designs: (name, SI
    parameters, objective values in their own sense and display units)."""
    r = run.results
    pts = [("weighted-sum optimum", r["optimum"], dict(r["global_indices"]))]
    for n, d in r["designs"].items():
        if not isinstance(d, dict) or not isinstance(d.get("parameters"), dict):
            continue
        gi = d.get("global_indices", {})
        vals = {k: v.get("mean") for k, v in gi.items() if isinstance(v, dict)}
        pts.append((f"{n} (config)", d["parameters"], vals))
    out = []
    for name, params, vals in pts:
        ov = {}
        for o in objectives:
            if o in run.units.indices:
                ov[o] = vals.get(o, math.nan)
            else:
                try:
                    ov[o] = _extra_value(run, o, params) * objective_unit(run.units, o)[1]
                except (KeyError, ValueError, TypeError):
                    ov[o] = math.nan
        out.append((name, params, ov))
    return out


def _front_values(run: RunData, front: Front) -> dict[str, np.ndarray]:
    """Objectives (own sense, display units) then the other global indices of a front."""
    vals = {}
    for o, v in front.objectives.items():
        vals[o] = v * objective_unit(run.units, o)[1]
    for k, v in front.indices.items():
        vals.setdefault(k, v)
    return vals


# --------------------------------------------------------------------------- convergence
def _col(rows: list[dict], key: str) -> np.ndarray:
    return np.array([r.get(key, math.nan) for r in rows], dtype=float)


def convergence_figures(run: RunData) -> list[Figure]:
    """One grid of small plots for the single-objective and weighted-sum
    stages (best and population mean per generation), one figure per Pareto
    stage (the best of each objective and the size of the front)."""
    figs = []
    ga = [s for s in run.history if run.stages.get(s, {}).get("kind") in ("single", "weighted")]
    if ga:
        ncol = 2 if len(ga) <= 4 else 3
        nrow = -(-len(ga) // ncol)
        titles = []
        for s in ga:
            r = run.stages[s]
            if r.get("kind") == "single":
                titles.append(f"{esc(r.get('index', s))}: {'maximum' if r.get('sense') == 'max' else 'minimum'}")
            elif s == "weighted_sum_literal":
                titles.append("weighted sum, every term as if minimized")
            else:
                titles.append("weighted sum (the optimum)")
        fig = subplots(nrow, ncol, titles, horizontal_spacing=0.1,
                       vertical_spacing=min(0.12, 0.6 / max(nrow - 1, 1)) if nrow > 1 else 0.1)
        for i, s in enumerate(ga):
            r, rows = run.stages[s], run.history[s]
            row, col = i // ncol + 1, i % ncol + 1
            if not rows:       # a stage that recorded no generation (its history is empty): an empty panel
                continue
            g = _col(rows, "generation")
            if r.get("kind") == "single" and r.get("index") in run.units.indices:
                k = r["index"]
                flip = -1.0 if r.get("sense") == "max" else 1.0
                best = _col(rows, f"best_{k}") if f"best_{k}" in rows[0] else flip * _col(rows, "best_objective")
                # the history shows the population mean in the index's own sense (mean_<k>);
                # a folder of the previous format has the minimized objective's mean
                mean = _col(rows, f"mean_{k}") if f"mean_{k}" in rows[0] else flip * _col(rows, "mean_objective")
                ylab = index_label(run.units, k)
            else:
                best, mean = _col(rows, "best_objective"), _col(rows, "mean_objective")
                ylab = "f [–]"
            fig.add_trace(dict(type="scatter", x=g, y=best, mode="lines", name="best", legendgroup="best",
                               line=dict(color=COLORS[0]), showlegend=i == 0,
                               hovertemplate="generation %{x}<br>best %{y:.5g}<extra>" + esc(s) + "</extra>"),
                          row=row, col=col)
            fig.add_trace(dict(type="scatter", x=g, y=mean, mode="lines", name="population mean", legendgroup="mean",
                               line=dict(color=COLORS[1], dash="dot"), showlegend=i == 0,
                               hovertemplate="generation %{x}<br>mean %{y:.5g}<extra>" + esc(s) + "</extra>"),
                          row=row, col=col)
            fig.update_yaxes(title=dict(text=esc(ylab)), row=row, col=col)
            if row == nrow or i + ncol >= len(ga):
                fig.update_xaxes(title=dict(text="generation"), row=row, col=col)
        height = 260 * nrow + 130
        fig.update_layout(template=TEMPLATE, height=height,
                          title=dict(text="Convergence of the single-objective and weighted-sum stages", x=0.01,
                                     yref="container", y=1 - 14 / height, yanchor="top"),
                          legend=dict(orientation="h", yref="container", y=1 - 52 / height, yanchor="top",
                                      x=0.01, xanchor="left"),
                          margin=dict(t=120))
        fig.update_annotations(font=dict(size=12))
        figs.append(fig)
    for s, rows in run.history.items():
        r = run.stages.get(s, {})
        if r.get("kind") != "pareto" or not rows:
            continue
        terms = [t for t in (r.get("terms") or []) if isinstance(t, str)]
        n = len(terms) + 1
        ncol = min(n, 4)
        nrow = -(-n // ncol)
        titles = [f"best {esc(t.lstrip('-'))}" for t in terms] + ["non-dominated designs"]
        fig = subplots(nrow, ncol, titles, horizontal_spacing=0.1, vertical_spacing=0.18 if nrow > 1 else 0.1)
        g = _col(rows, "generation")
        for i, t in enumerate(terms + [None]):
            row, col = i // ncol + 1, i % ncol + 1
            if t is None:
                y, ylab = _col(rows, "front_size"), "designs"
            else:
                k = t.lstrip("-")
                if f"best_{t}" in rows[0]:   # the previous format: the minimized objective, SI
                    y = _col(rows, f"best_{t}") * (-1.0 if t.startswith("-") else 1.0) * objective_unit(run.units, k)[1]
                else:                        # own sense, shown units
                    y = _col(rows, f"best_{k}")
                ylab = index_label(run.units, k)
            fig.add_trace(dict(type="scatter", x=g, y=y, mode="lines", showlegend=False,
                               line=dict(color=COLORS[i % len(COLORS)]),
                               hovertemplate="generation %{x}<br>%{y:.5g}<extra></extra>"), row=row, col=col)
            fig.update_yaxes(title=dict(text=esc(ylab)), row=row, col=col)
            fig.update_xaxes(title=dict(text="generation"), row=row, col=col)
        fig.update_layout(template=TEMPLATE, height=280 * nrow + 90,
                          title=dict(text=f"Convergence of {esc(s)}: the best of each objective per generation, "
                                          "and the number of non-dominated designs", x=0.01))
        fig.update_annotations(font=dict(size=12))
        figs.append(fig)
    return figs


# --------------------------------------------------------------------------- fronts
def matrix_trace(labels: list[str], columns: list, **kw):
    """A scatter matrix (lower half) of ``columns``; for two columns, one plain
    scatter (plotly.js cannot draw a one-panel lower-half matrix)."""
    if len(columns) == 2:
        return dict(type="scatter", x=columns[0], y=columns[1], mode="markers", **kw)
    return dict(type="splom", dimensions=[dict(label=lab, values=c) for lab, c in zip(labels, columns)],
                showupperhalf=False, diagonal=dict(visible=False), **kw)


def style_matrix(fig: Figure, labels: list[str]) -> None:
    """Axes of a scatter matrix: plain (no mirrored frame) on shaded panels."""
    n = len(labels)
    if n == 2:
        fig.update_xaxes(title=dict(text=labels[0]))
        fig.update_yaxes(title=dict(text=labels[1]))
    else:
        for i in range(1, n + 1):
            ax = dict(showline=False, mirror=False, zeroline=False, gridcolor="white", automargin=True)
            fig.update_layout({f"xaxis{i if i > 1 else ''}": ax, f"yaxis{i if i > 1 else ''}": ax})
    fig.update_layout(plot_bgcolor="#eef1f5")


def front_title(front: Front) -> str:
    if front.size == 1:
        return (f"{esc(front.name)}: the front collapsed to ONE design (no trade-off among the designs this "
                "stage evaluated)")
    return f"{esc(front.name)}: {front.size} non-dominated designs"


def front_splom(run: RunData, front: Front) -> Figure:
    """The front in objective space (own sense, units), one point per design;
    hover shows its parameters and indices.  The weighted-sum optimum and the
    named designs are drawn for comparison."""
    objs = list(front.objectives)
    vals = _front_values(run, front)
    text = [hover_lines(run, front.designs, vals, i, f"{front.name} design {i + 1}") for i in range(front.size)]
    big = front.size <= 3
    labels = [_obj_label(run, o, short=True) for o in objs]
    fig = Figure()
    fig.add_trace(matrix_trace(labels, [vals[o] for o in objs], text=text, hovertemplate="%{text}<extra></extra>",
                               name=f"{front.name} front",
                               marker=dict(size=15 if big else 6, color=COLORS[0], opacity=0.9 if big else 0.7,
                                           line=dict(width=1.5 if big else 0.5, color="#0b3d66")), showlegend=True))
    for j, (name, params, ov) in enumerate(design_points(run, objs)):
        d = {k: np.array([v]) for k, v in params.items()}
        t = hover_lines(run, d, {k: np.array([v]) for k, v in ov.items()}, 0, name)
        fig.add_trace(matrix_trace(labels, [[ov[o]] for o in objs], text=[t], hovertemplate="%{text}<extra></extra>",
                                   name=esc(name),
                                   marker=dict(size=11 if j == 0 else 9, symbol=MARKS[j % len(MARKS)],
                                               color="#111" if j == 0 else COLORS[(j + 1) % len(COLORS)],
                                               line=dict(width=1, color="white"))))
    n = len(objs)
    style_matrix(fig, labels)
    fig.update_layout(template=TEMPLATE, height=max(420, 230 * (n - 1) + 170), dragmode="select",
                      title=dict(text=front_title(front), x=0.01),
                      legend=dict(orientation="h", y=1.0, yanchor="bottom", x=0, xanchor="left"),
                      margin=dict(t=110, l=90, b=80), hovermode="closest")
    return fig


def front_parcoords(run: RunData, front: Front) -> Figure:
    """Parallel coordinates of the front: its free design variables (config
    units, axes spanning the bounds) and objectives (own sense, axes spanning the
    front's own range; for a single design, the index's range over the bounds)."""
    dims = []
    for k, dv in run.units.variables.items():
        if not dv.free or k not in front.designs:
            continue
        lo, hi = dv.display(dv.bounds[0]), dv.display(dv.bounds[1])
        dims.append(dict(label=_var_label(run, k), values=dv.display(front.designs[k]), range=[lo, hi],
                         tickformat=".4~g"))
    vals = _front_values(run, front)
    norm = run.results.get("normalization", {})
    for o in front.objectives:
        v = vals[o]
        lo, hi = float(np.nanmin(v)), float(np.nanmax(v))
        nm = norm.get(o)
        if hi <= lo and isinstance(nm, dict) and all(isinstance(nm.get(x), (int, float)) for x in ("min", "max")):
            # one design (or all alike): the index's range over the bounds places it
            lo, hi = min(lo, float(nm["min"])), max(hi, float(nm["max"]))
        d = dict(label=_obj_label(run, o), values=v, tickformat=".4~g")
        if hi > lo:
            d["range"] = [lo, hi]
        dims.append(d)
    color_by = next(iter(front.objectives), None)
    if color_by and front.size > 1:
        line = dict(color=vals[color_by], colorscale=colorscale("Viridis"), showscale=True,
                    colorbar=dict(title=dict(text=_obj_label(run, color_by, short=True), side="right"),
                                  thickness=14, x=1.02))
    else:
        line = dict(color=COLORS[0])
    fig = Figure([dict(
        type="parcoords", dimensions=dims, line=line,
        labelangle=0 if len(dims) <= 8 else -25, labelside="top", labelfont=dict(size=12), tickfont=dict(size=11))])
    one = " (one design: a single line; objective axes span the range over the bounds)" if front.size == 1 else ""
    fig.update_layout(template=TEMPLATE, height=470,
                      title=dict(text=f"{esc(front.name)}: the front's designs (left, config units; axes span the bounds) "
                                      f"and objectives (right){one}", x=0.01,
                                 font=dict(size=13)),
                      margin=dict(t=150, l=70, r=150 if front.size > 1 else 110, b=40))
    return fig


# --------------------------------------------------------------------------- atlas
def atlas_figures(run: RunData, amap: AtlasMap, design_name: str = "the weighted-sum optimum") -> list[Figure]:
    figs = []
    where = "; ".join(w for w in (amap.held, (f"slice through the centre: {amap.cut}" if amap.cut else "")) if w)
    for k, Z in amap.values.items():
        ul = index_label(run.units, k)
        sense = run.units.indices[k][1]
        title = f"{esc(k)} ({'max' if sense == 'max' else 'min'}) of {esc(design_name)}"
        sub = esc(where) if where else ""
        if len(amap.axes) == 1:
            fig = Figure([dict(type="scatter", x=amap.coords[0], y=Z, mode="lines", name=esc(k),
                               hovertemplate=f"{esc(amap.axes[0])} = %{{x:.4g}} {esc(amap.units[0])}<br>"
                                             f"{esc(k)} = %{{y:.5g}}<extra></extra>")])
            fig.update_xaxes(title=dict(text=esc(label(amap.axes[0], amap.units[0]))))
            fig.update_yaxes(title=dict(text=esc(ul)))
        else:
            xa, ya = amap.axes
            ux, uy = amap.units
            finite = np.isfinite(Z)
            fig = Figure()
            if finite.sum() >= 4:
                lo, hi = float(np.nanmin(Z)), float(np.nanmax(Z))
                fig.add_trace(dict(
                    type="contour", x=amap.coords[0], y=amap.coords[1], z=Z, colorscale=colorscale("Viridis"),
                    connectgaps=False, ncontours=18,
                    contours=dict(coloring="heatmap", showlabels=True, labelfont=dict(size=10, color="white")),
                    line=dict(width=0.6, color="rgba(255,255,255,0.6)"),
                    zmin=lo, zmax=hi if hi > lo else lo + 1e-12,
                    colorbar=dict(title=dict(text=esc(ul), side="right"), thickness=14),
                    hovertemplate=f"{esc(xa)} = %{{x:.4g}} {esc(ux)}<br>{esc(ya)} = %{{y:.4g}} {esc(uy)}<br>"
                                  f"{esc(k)} = %{{z:.5g}}<extra></extra>"))
            if amap.outline is not None:
                fig.add_trace(dict(type="scatter", x=amap.outline[0], y=amap.outline[1], mode="lines",
                                   name="workspace boundary", line=dict(color="#111", width=2), hoverinfo="skip",
                                   showlegend=False))
            fig.update_xaxes(title=dict(text=esc(label(xa, ux))), constrain="domain")
            fig.update_yaxes(title=dict(text=esc(label(ya, uy))), scaleanchor="x" if ux == uy else None, scaleratio=1,
                             constrain="domain")
        missing = amap.unreachable + amap.singular.get(k, 0)
        note = f"{amap.points} points inside W" + (f", {missing} blank (unreachable or singular)" if missing else "")
        fig.update_layout(template=TEMPLATE, height=480,
                          title=dict(text=f"{title}<br><span style='font-size:11px;color:#555'>"
                                          f"{sub + ('; ' if sub else '')}{note}</span>", x=0.01, font=dict(size=14)),
                          margin=dict(t=80, l=70, r=20, b=60), showlegend=False)
        figs.append(fig)
    return figs
