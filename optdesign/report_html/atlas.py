"""Local indices of one design over the workspace, on a grid of the atlas's own
(finer than the optimization's sample), clipped to the workspace's true shape:
a box is its rectangle, a cylinder its disc (with the outline); a region with
a third free axis is cut through the middle of that axis, and the cut is named."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..config import Config
from ..evaluate import evaluate, mechanism_class
from ..workspace import Workspace, WorkspaceSpec
from ..units import pose_display

__all__ = ["AtlasMap", "atlas_map", "DEFAULT_RESOLUTION"]

#: grid points per plotted axis
DEFAULT_RESOLUTION = 81


@dataclass
class AtlasMap:
    axes: list[str]                     # plotted pose axes (1 or 2)
    units: list[str]                    # their display units
    coords: list[np.ndarray]            # display values along each plotted axis
    values: dict[str, np.ndarray]       # index -> (n_b, n_a) (or (n_a,)), NaN outside W / unreachable / singular
    outline: tuple[np.ndarray, np.ndarray] | None  # the region's boundary (display units), None for a box
    shape: str                          # "rectangle", "disc", "segment"
    cut: str                            # the slice through a third free axis, in words ("" if none)
    held: str                           # axes the workspace itself fixes, in words ("" if none)
    points: int                         # grid points inside W
    unreachable: int                    # of them, not reachable by the design
    singular: dict[str, int]            # index -> reachable points where its local value is not finite


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def atlas_map(cfg: Config, design: dict, resolution: int = DEFAULT_RESOLUTION) -> AtlasMap | None:
    """The atlas of ``design`` (SI parameters), or None for a workspace of one point."""
    names = tuple(mechanism_class(cfg).pose_names)
    ws = cfg.workspace
    fixed: dict[str, float] = {}
    cut = []
    if ws.type == "cylinder":
        plotted = list(names[:2])
        lo3, hi3 = ws.axes[names[2]]
        fixed[names[2]] = 0.5 * (lo3 + hi3)
        if hi3 > lo3:
            cut.append((names[2], fixed[names[2]], "the middle of its range"))
        ranges = {names[0]: (ws.center[0] - ws.radius, ws.center[0] + ws.radius),
                  names[1]: (ws.center[1] - ws.radius, ws.center[1] + ws.radius)}
    else:
        free = [a for a in names if ws.axes[a][1] > ws.axes[a][0]]
        if not free:
            return None
        plotted = free[:2]
        ranges = {a: ws.axes[a] for a in plotted}
        for a in names:
            if a in plotted:
                continue
            lo, hi = ws.axes[a]
            fixed[a] = 0.5 * (lo + hi)
            if hi > lo:
                cut.append((a, fixed[a], "the middle of its range"))
    grids = [np.linspace(*ranges[a], resolution) for a in plotted]
    mesh = np.meshgrid(*grids, indexing="xy")  # (n_b, n_a) for two axes
    inside = np.ones(mesh[0].shape, dtype=bool)
    outline = None
    shape = "segment" if len(plotted) == 1 else "rectangle"
    if ws.type == "cylinder":
        da, db = mesh[0] - ws.center[0], mesh[1] - ws.center[1]
        inside = da * da + db * db <= ws.radius ** 2 * (1 + 1e-9)
        shape = "disc"
    X = np.empty((int(inside.sum()), len(names)))
    for i, a in enumerate(names):
        if a in plotted:
            X[:, i] = mesh[plotted.index(a)][inside]
        else:
            X[:, i] = fixed[a]
    spec = WorkspaceSpec(type="box", axes={a: (float(X[:, i].min()), float(X[:, i].max())) for i, a in enumerate(names)},
                         sampling="grid", points_per_axis=resolution)
    with np.errstate(all="ignore"):
        ev = evaluate(cfg, [design], Workspace(spec, names, X, None), keep_local=True)
    reach = np.asarray(ev.reachable[0], dtype=bool)
    values, singular = {}, {}
    for k in cfg.indices:
        v = np.asarray(ev.local[k][0], dtype=float)
        good = reach & np.isfinite(v)
        singular[k] = int((reach & ~np.isfinite(v)).sum())
        full = np.full(inside.shape, np.nan)
        full[inside] = np.where(good, v, np.nan)
        values[k] = full
    disp = [pose_display(cfg, a) for a in plotted]
    coords = [g * f for g, (_, f) in zip(grids, disp)]
    if ws.type == "cylinder":
        t = np.linspace(0, 2 * np.pi, 181)
        fa, fb = disp[0][1], disp[1][1]
        outline = ((ws.center[0] + ws.radius * np.cos(t)) * fa, (ws.center[1] + ws.radius * np.sin(t)) * fb)
    words, held = [], []
    for a, v, why in cut:
        u, f = pose_display(cfg, a)
        words.append(f"{a} = {_fmt(v * f)} {u} ({why})")
    for a in names:
        if a not in plotted and not any(c[0] == a for c in cut):
            u, f = pose_display(cfg, a)
            held.append(f"{a} = {_fmt(fixed[a] * f)} {u}")
    return AtlasMap(axes=list(plotted), units=[d[0] for d in disp], coords=coords, values=values, outline=outline,
                    shape=shape, cut=", ".join(words), held=", ".join(held), points=int(inside.sum()), unreachable=int((~reach).sum()),
                    singular=singular)
