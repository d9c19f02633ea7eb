"""The designer's views of the report: the mechanism drawn in 3-D at chosen
poses of W (a slider over the poses), the same for the best Pareto
alternatives, the workspace in 3-D coloured by a local index, and a copy
button for each Pareto design's ``designs:`` snippet.

The geometry is the mechanism's own (:meth:`Mechanism.drawing`); lengths are
shown in the workspace's length unit (m unless a pose axis says otherwise)."""
from __future__ import annotations

import html
import itertools

import numpy as np

from ...workspace import Workspace, WorkspaceSpec
from ...units import index_label, pose_display, variable_unit
from .figures import TEMPLATE, esc
from .plot import Figure, colorscale
from .rundata import Front, RunData

__all__ = ["mechanism_figure", "alternatives", "workspace_figure", "copy_table", "COPY_SCRIPT"]


def _design(run: RunData, params: dict) -> dict:
    return {k: float(params.get(k, v)) for k, v in run.model.defaults.items()}


def _mech(run: RunData, params: dict):
    return run.model.build(_design(run, params))


def chosen_poses(run: RunData, params: dict) -> list[tuple[str, np.ndarray]]:
    """(label, pose) pairs: the centre of W, its box's corners, the worst-conditioned sample."""
    names = run.model.mechanism.pose_names
    ws = run.workspace
    if ws.type == "cylinder":
        lo = np.array([ws.center[0] - ws.radius, ws.center[1] - ws.radius, ws.axes[names[2]][0]])
        hi = np.array([ws.center[0] + ws.radius, ws.center[1] + ws.radius, ws.axes[names[2]][1]])
    else:
        lo = np.array([ws.axes[a][0] for a in names], float)
        hi = np.array([ws.axes[a][1] for a in names], float)
    poses = [("centre of W", 0.5 * (lo + hi))]
    free = [i for i in range(len(names)) if hi[i] > lo[i]][:3]
    for corner in itertools.product((0, 1), repeat=len(free)):
        x = 0.5 * (lo + hi)
        for j, i in enumerate(free):
            x[i] = hi[i] if corner[j] else lo[i]
        if ws.type == "cylinder" and len(free) >= 2:   # the disc's extremes, not the square's
            x[:2] = np.array(ws.center[:2]) + ws.radius * np.array([1 if corner[0] else -1, 1 if corner[1] else -1]) / np.sqrt(2)
        poses.append(("corner " + ", ".join(f"{names[i]} {'max' if corner[j] else 'min'}" for j, i in enumerate(free)), x))
    mech = _mech(run, params)
    X = _sample(run)
    with np.errstate(all="ignore"):
        J = mech.jacobian(X)
        cond = np.linalg.cond(np.where(np.isfinite(J), J, 0.0))
    cond = np.where(mech.reachable(X) & np.isfinite(cond), cond, -1)
    if np.any(cond > 0):
        i = int(np.argmax(cond))
        poses.append((f"worst-conditioned sample (cond J = {cond[i]:.4g})", X[i]))
    return poses


#: the most poses a grid over W holds here (a 6-D W: 5 per axis)
MAX_SAMPLE = 20_000


def _sample(run: RunData, per_axis: int | None = None, slice_extra: bool = False) -> np.ndarray:
    """A grid over W (its box, clipped to a cylinder's disc) in SI, at most
    MAX_SAMPLE poses; ``slice_extra``: the free axes after the first three at
    the centre of their ranges (a 3-D slice of a higher-dimensional W)."""
    names = run.model.mechanism.pose_names
    ws = run.workspace
    if ws.type == "cylinder":
        ranges = [(ws.center[0] - ws.radius, ws.center[0] + ws.radius), (ws.center[1] - ws.radius, ws.center[1] + ws.radius),
                  tuple(ws.axes[names[2]])]
    else:
        ranges = [tuple(ws.axes[a]) for a in names]
    free = [i for i, (lo, hi) in enumerate(ranges) if hi > lo]
    if slice_extra:
        for i in free[3:]:
            ranges[i] = (0.5 * sum(ranges[i]),) * 2
        free = free[:3]
    nfree = len(free)
    n = per_axis or {0: 1, 1: 81, 2: 41}.get(nfree, 15)
    n = max(2, min(n, int(MAX_SAMPLE ** (1.0 / max(nfree, 1)))))
    grids = [np.linspace(lo, hi, n) if hi > lo else np.array([lo]) for lo, hi in ranges]
    X = np.stack([g.ravel() for g in np.meshgrid(*grids, indexing="ij")], axis=-1)
    if ws.type == "cylinder":
        X = X[(X[:, 0] - ws.center[0]) ** 2 + (X[:, 1] - ws.center[1]) ** 2 <= ws.radius ** 2 * (1 + 1e-9)]
    return X


def _ordered(P: np.ndarray) -> np.ndarray:
    """An order of polygon vertices P (m, 3) around their centroid (in their best-fit plane)."""
    ok = np.all(np.isfinite(P), axis=-1)
    if ok.sum() < 3:
        return np.arange(len(P))
    c = P[ok].mean(axis=0)
    _, _, vt = np.linalg.svd(P[ok] - c)
    d = np.where(ok[:, None], P - c, 0.0)
    return np.argsort(np.arctan2(d @ vt[1], d @ vt[0]))


def _line(chains: list[np.ndarray]) -> np.ndarray:
    """Chains (n_pts, 3) joined into one line with NaN breaks."""
    out = []
    for c in chains:
        out += [c, np.full((1, 3), np.nan)]
    return np.concatenate(out) if out else np.zeros((0, 3))


def _traces(dr: dict, k: int, order: np.ndarray, scale: float) -> list:
    base = dr["base"][k] * scale
    plat = dr["platform"][k][order] * scale
    # each leg's actuated link (rail to slider, crank, or the whole strut) and its rods
    act = [(leg[k][:-1] if leg.shape[1] > 2 else leg[k]) * scale for leg in dr["legs"]]
    rods = [r * scale for r in dr["rods"][k]]
    bo = _ordered(dr["base"][k])
    base_loop = np.concatenate([base[bo], base[bo][:1]])
    plat_loop = np.concatenate([plat, plat[:1]])
    L, Ra = _line(act), _line(rods)
    J = dr["joints"][k] * scale
    c = np.nanmean(plat, axis=0) if np.any(np.isfinite(plat)) else np.zeros(3)
    m = len(plat)
    xyz = lambda a: dict(x=a[:, 0], y=a[:, 1], z=a[:, 2])  # noqa: E731
    lines = lambda a, color, width, name: dict(type="scatter3d", **xyz(a), mode="lines",  # noqa: E731
                                               line=dict(color=color, width=width), name=name, hoverinfo="skip")
    return [
        lines(base_loop, "#555", 6, "base"),
        lines(L, "#2ca02c", 7, f"legs: {len(act)} actuated links"),
        lines(Ra, "#1f77b4", 4, f"rods ({len(rods)})"),
        dict(type="scatter3d", **xyz(J), mode="markers", marker=dict(size=3.5, color="#d62728"), name="joints"),
        dict(type="mesh3d", x=np.append(plat[:, 0], c[0]), y=np.append(plat[:, 1], c[1]), z=np.append(plat[:, 2], c[2]),
             i=np.full(m, m), j=np.arange(m), k=(np.arange(m) + 1) % m, color="#ff7f0e", opacity=0.45,
             name="platform", hoverinfo="skip", showlegend=True),
        lines(plat_loop, "#ff7f0e", 5, "platform outline"),
    ]


def mechanism_figure(run: RunData, params: dict, title: str, height: int = 620) -> Figure | None:
    """The design drawn at the chosen poses, one frame per pose, with a slider;
    None when the mechanism has no drawing."""
    mech = _mech(run, params)
    poses = chosen_poses(run, params)
    X = np.array([p for _, p in poses])
    with np.errstate(all="ignore"):
        dr = mech.drawing(X)
    if dr is None:
        return None
    unit, scale = "m", 1.0
    order = _ordered(dr["platform"][0])
    names = run.model.mechanism.pose_names
    labels = []
    for (lab, x), k in zip(poses, range(len(poses))):
        where = ", ".join(f"{a} = {x[i] * pose_display(run.units, a)[1]:.4g} {pose_display(run.units, a)[0]}"
                          for i, a in enumerate(names))
        ok = np.all(np.isfinite(dr["platform"][k]))
        labels.append(f"{lab}: {where}" + ("" if ok else " (not reachable)"))
    frames = [dict(data=_traces(dr, k, order, scale), name=str(k)) for k in range(len(poses))]
    fig = Figure(frames[0]["data"], frames=frames)
    # the slider's current value names the pose (its tick labels, the same long names, are hidden)
    steps = [dict(method="animate", label=f"{k + 1} of {len(poses)}: {esc(labels[k])}",
                  args=[[str(k)], dict(mode="immediate", frame=dict(duration=0, redraw=True), transition=dict(duration=0))])
             for k in range(len(poses))]
    allpts = np.concatenate([dr["joints"].reshape(-1, 3), dr["platform"].reshape(-1, 3)]) * scale
    allpts = allpts[np.all(np.isfinite(allpts), axis=-1)]
    lo, hi = allpts.min(axis=0), allpts.max(axis=0)
    mid, half = 0.5 * (lo + hi), 0.55 * float(np.max(hi - lo)) + 1e-9
    axis = lambda i, n: dict(title=dict(text=f"{n} [{unit}]"), range=[mid[i] - half, mid[i] + half])  # noqa: E731
    fig.update_layout(template=TEMPLATE, height=height, title=dict(text=esc(title), x=0.01, y=0.98),
                      margin=dict(l=10, r=10, t=60, b=10), legend=dict(x=0.0, y=0.92),
                      scene=dict(xaxis=axis(0, "x"), yaxis=axis(1, "y"), zaxis=axis(2, "z"), aspectmode="cube"),
                      sliders=[dict(active=0, steps=steps, pad=dict(t=10), font=dict(color="rgba(0,0,0,0)"),
                                    currentvalue=dict(prefix="pose ", font=dict(size=12, color="#222")))])
    return fig


def alternatives(run: RunData, count: int = 3) -> list[tuple[str, dict]]:
    """The best Pareto alternatives: each front's best design in each objective (deduplicated)."""
    out, seen = [], set()
    for name, front in run.fronts.items():
        for o, v in front.objectives.items():
            if not front.size or not np.any(np.isfinite(v)):
                continue
            sense = run.units.indices[o][1] if o in run.units.indices else "min"
            i = int(np.nanargmax(v) if sense == "max" else np.nanargmin(v))
            d = {k: float(a[i]) for k, a in front.designs.items()}
            key = tuple(round(x, 12) for x in d.values())
            if key not in seen:
                seen.add(key)
                out.append((f"{name}: best {o} ({'max' if sense == 'max' else 'min'})", d))
    return out[:count]


def _local_values(run: RunData, params: dict, X: np.ndarray) -> dict:
    """Local indices (SI) of one design at the points X (N, dof): index -> (N,)."""
    names = list(run.model.mechanism.pose_names)
    ws = Workspace(WorkspaceSpec(type="box", axes={a: (float(X[:, i].min()), float(X[:, i].max())) for i, a in enumerate(names)},
                                 sampling="grid", points_per_axis=2), tuple(names), X, None)
    with np.errstate(all="ignore"):
        ev = run.model.evaluate([_design(run, params)], ws, keep_local=True)
    return {k: np.asarray(ev.local[k][0], float) for k in run.units.indices}


def _surface_grid(run: RunData, n: int = 41):
    """For a W with exactly two free axes: (free axis indices, the two grids,
    the poses (n*n, dof) in SI, inside mask (n*n,)); None otherwise."""
    names = run.model.mechanism.pose_names
    ws = run.workspace
    if ws.type == "cylinder":
        ranges = [(ws.center[0] - ws.radius, ws.center[0] + ws.radius), (ws.center[1] - ws.radius, ws.center[1] + ws.radius),
                  tuple(ws.axes[names[2]])] + [tuple(ws.axes[a]) for a in names[3:]]
    else:
        ranges = [tuple(ws.axes[a]) for a in names]
    free = [i for i, (lo, hi) in enumerate(ranges) if hi > lo]
    if len(free) != 2:
        return None
    g = [np.linspace(*ranges[i], n) for i in free]
    A, B = np.meshgrid(g[0], g[1], indexing="xy")          # rows: second axis, columns: first
    X = np.tile(np.array([0.5 * (lo + hi) for lo, hi in ranges], float), (A.size, 1))
    X[:, free[0]], X[:, free[1]] = A.ravel(), B.ravel()
    inside = np.ones(len(X), bool)
    if ws.type == "cylinder":
        inside = (X[:, 0] - ws.center[0]) ** 2 + (X[:, 1] - ws.center[1]) ** 2 <= ws.radius ** 2 * (1 + 1e-9)
    return free, g, X, inside


def _surface_figure(run: RunData, params: dict, grid) -> Figure:
    """A 2-D W: one surface per local index over W, its height and colour the index."""
    names = list(run.model.mechanism.pose_names)
    free, g, X, inside = grid
    vals = _local_values(run, params, X[inside])
    disp = [pose_display(run.units, names[i]) for i in free]
    fig = Figure()
    keys = list(run.units.indices)
    for j, k in enumerate(keys):
        v = np.full(len(X), np.nan)
        v[inside] = vals[k]
        Z = v.reshape(len(g[1]), len(g[0]))
        lab = esc(index_label(run.units, k))
        fig.add_trace(dict(type="surface", x=g[0] * disp[0][1], y=g[1] * disp[1][1], z=Z, surfacecolor=Z,
                           colorscale=colorscale("Viridis"), visible=j == 0, name=esc(k),
                           colorbar=dict(title=dict(text=lab, side="right")),
                           hovertemplate=f"{esc(names[free[0]])} = %{{x:.4g}}, {esc(names[free[1]])} = %{{y:.4g}}<br>"
                                         f"{esc(k)} = %{{z:.5g}}<extra></extra>"))
    fixed = ", ".join(f"{a} = {X[0, i] * pose_display(run.units, a)[1]:.4g} {pose_display(run.units, a)[0]}"
                      for i, a in enumerate(names) if i not in free)
    buttons = [dict(label=esc(k), method="update",
                    args=[{"visible": [i == j for i in range(len(keys))]},
                          {"scene.zaxis.title.text": esc(index_label(run.units, k))}])
               for j, k in enumerate(keys)]
    fig.update_layout(template=TEMPLATE, height=560, margin=dict(l=10, r=10, t=60, b=10),
                      title=dict(text=esc("The workspace W as a surface: height and colour a local index of the "
                                          "weighted-sum optimum" + (f" ({fixed})" if fixed else "")), x=0.01, y=0.98),
                      scene=dict(xaxis=dict(title=dict(text=f"{names[free[0]]} [{disp[0][0]}]")),
                                 yaxis=dict(title=dict(text=f"{names[free[1]]} [{disp[1][0]}]")),
                                 zaxis=dict(title=dict(text=esc(index_label(run.units, keys[0])))), aspectmode="manual",
                                 aspectratio=dict(x=1, y=1, z=0.6)),
                      updatemenus=[dict(buttons=buttons, x=0.0, y=1.0, xanchor="left", yanchor="top")])
    return fig


def workspace_figure(run: RunData, params: dict) -> Figure | None:
    """W coloured by each local index of the design (a menu picks the index):
    a W with two free axes as a surface over it (height and colour the index),
    otherwise W in 3-D at the sample grid's points."""
    names = list(run.model.mechanism.pose_names)
    grid = _surface_grid(run)
    if grid is not None:
        return _surface_figure(run, params, grid)
    X = _sample(run, slice_extra=True)
    if len(X) < 2:
        return None
    held = [a for i, a in enumerate(names) if i >= 3 and np.ptp(X[:, i]) == 0 and np.ptp(_sample(run, 2)[:, i]) > 0]
    parts = [f"{a} = {X[0, names.index(a)] * pose_display(run.units, a)[1]:.4g} {pose_display(run.units, a)[0]}" for a in held]
    cut = "a 3-D slice of W: " + ", ".join(parts) if held else ""
    vals = _local_values(run, params, X)
    disp = [pose_display(run.units, a) for a in names[:3]]
    C = [X[:, i] * disp[i][1] for i in range(min(3, len(names)))]
    while len(C) < 3:
        C.append(np.zeros(len(X)))
        disp.append(("", 1.0))
    fig = Figure()
    keys = list(run.units.indices)
    for j, k in enumerate(keys):
        v = vals[k]
        good = np.isfinite(v)
        fig.add_trace(dict(type="scatter3d", x=C[0][good], y=C[1][good], z=C[2][good], mode="markers", visible=j == 0,
                           name=esc(k),
                           marker=dict(size=3 if len(X) > 2000 else 4, color=v[good], colorscale=colorscale("Viridis"),
                                       colorbar=dict(title=dict(text=esc(index_label(run.units, k)), side="right"))),
                           hovertemplate=f"{esc(k)} = %{{marker.color:.5g}}<extra></extra>"))
    axes = [f"{names[i]} [{disp[i][0]}]" if i < len(names) else "(plane)" for i in range(3)]
    buttons = [dict(label=esc(k), method="update", args=[{"visible": [i == j for i in range(len(keys))]}])
               for j, k in enumerate(keys)]
    fig.update_layout(template=TEMPLATE, height=560, margin=dict(l=10, r=10, t=80, b=10),
                      title=dict(text=esc("The workspace W coloured by a local index (weighted-sum optimum)")
                                 + (f"<br><sup>{esc(cut)}</sup>" if cut else ""), x=0.01, y=0.99, yanchor="top"),
                      scene=dict(xaxis=dict(title=dict(text=axes[0])), yaxis=dict(title=dict(text=axes[1])),
                                 zaxis=dict(title=dict(text=axes[2]))),
                      updatemenus=[dict(buttons=buttons, x=0.0, y=1.0, xanchor="left", yanchor="top")])
    return fig


def _snippet(run: RunData, name: str, d: dict) -> str:
    lines = [f"{name}:"]
    for k, dv in run.units.variables.items():
        u = variable_unit(run.units, k)
        lines.append(f"  {k}: {dv.display(float(d.get(k, dv.value))):.12g}   # {u}")
    return "\n".join(lines) + "\n"


def copy_table(run: RunData, front: Front, max_rows: int = 200) -> str:
    """A table of the front's designs (config units) with a copy button each for
    its ``designs:`` snippet (every string escaped, the snippet in an attribute)."""
    free = [k for k, dv in run.units.variables.items() if dv.free and k in front.designs]
    head = "".join(f"<th class=num>{esc(k)} [{esc(variable_unit(run.units, k))}]</th>" for k in free)
    rows = []
    for i in range(min(front.size, max_rows)):
        d = {k: float(a[i]) for k, a in front.designs.items()}
        snip = _snippet(run, f"{front.name}_{i + 1}", d)
        cells = "".join(f"<td class=num>{run.units.variables[k].display(d[k]):.6g}</td>" for k in free)
        rows.append(f"<tr><td>{i + 1}</td>{cells}<td><button type=button class=copy "
                    f"data-snippet=\"{html.escape(snip, quote=True)}\">copy designs: snippet</button></td></tr>")
    more = "" if front.size <= max_rows else f"<p class=note>The first {max_rows} of {front.size} designs.</p>"
    return (f"<details><summary>{'The one design' if front.size == 1 else f'The {front.size} designs'} of this front, "
            "each with its <code>designs:</code> "
            "snippet to copy</summary><div class=tablewrap style=\"max-height:360px;overflow-y:auto\"><table>"
            f"<tr><th>#</th>{head}<th></th></tr>{''.join(rows)}</table></div>{more}</details>")


#: the copy handler: reads the button's data attribute (never evaluated), clipboard API with a textarea fallback
COPY_SCRIPT = """
document.addEventListener('click', function (e) {
  var b = e.target.closest ? e.target.closest('button.copy') : null;
  if (!b) { return; }
  var text = b.getAttribute('data-snippet') || '';
  function said(ok) { var t = b.textContent; b.textContent = ok ? 'copied' : 'copy failed'; setTimeout(function () { b.textContent = t; }, 1200); }
  function fallback() {
    var ta = document.createElement('textarea'); ta.value = text; ta.setAttribute('readonly', '');
    ta.style.position = 'fixed'; ta.style.left = '-9999px'; document.body.appendChild(ta); ta.select();
    var ok = false; try { ok = document.execCommand('copy'); } catch (err) { ok = false; }
    document.body.removeChild(ta); said(ok);
  }
  if (navigator.clipboard && navigator.clipboard.writeText) {
    navigator.clipboard.writeText(text).then(function () { said(true); }, fallback);
  } else { fallback(); }
});
"""
