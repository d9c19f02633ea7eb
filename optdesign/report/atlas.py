"""Index atlases: local index maps of one design over the workspace (the
paper's figures 15-26), as CSV data and contour plots.

The map has a grid of its own (``resolution`` points per plotted axis, finer
than the optimization's sample) clipped to the workspace's true shape: a box
is its rectangle, a cylinder its disc (the outline drawn); a region with a
third free axis is cut through the middle of that axis, and the cut is named.
Pose coordinates are shown in the workspace's units, indices in SI with their
unit named.

An atlas reads plain pieces of a config, never the config: its design model
(:class:`optdesign.evaluate.DesignModel`: the mechanism and its indices), its
units (:class:`optdesign.units.Units`) and its region W (the workspace spec)."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..evaluate import DesignModel
from ..io import atomic_write_bytes, atomic_write_text
from ..names import check_inside
from ..units import Units, index_label, label, pose_display
from ..workspace import MAX_POINTS, Workspace, WorkspaceSpec, WorkspaceTooLarge

__all__ = ["AtlasMap", "atlas_map", "atlas_size", "write_atlas", "DEFAULT_RESOLUTION"]

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
    inside: np.ndarray | None = None    # (n_b, n_a) (or (n_a,)) grid points inside W
    X: np.ndarray | None = None         # (points, dof) the poses inside W (SI)
    reachable: np.ndarray | None = None  # (points,) whether the design reaches each
    local: dict[str, np.ndarray] | None = None  # index -> (points,) local values (NaN where unreachable/singular)


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def atlas_map(model: DesignModel, units: Units, region: WorkspaceSpec, design: dict,
              resolution: int = DEFAULT_RESOLUTION) -> AtlasMap | None:
    """The atlas of ``design`` (SI parameters) over the region W, or None for a workspace of one point."""
    names = tuple(model.mechanism.pose_names)
    ws = region
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
        ev = model.evaluate([design], Workspace(spec, names, X, None), keep_local=True)
    reach = np.asarray(ev.reachable[0], dtype=bool)
    values, singular = {}, {}
    for k in units.indices:
        v = np.asarray(ev.local[k][0], dtype=float)
        good = reach & np.isfinite(v)
        singular[k] = int((reach & ~np.isfinite(v)).sum())
        full = np.full(inside.shape, np.nan)
        full[inside] = np.where(good, v, np.nan)
        values[k] = full
    disp = [pose_display(units, a) for a in plotted]
    coords = [g * f for g, (_, f) in zip(grids, disp)]
    if ws.type == "cylinder":
        t = np.linspace(0, 2 * np.pi, 181)
        fa, fb = disp[0][1], disp[1][1]
        outline = ((ws.center[0] + ws.radius * np.cos(t)) * fa, (ws.center[1] + ws.radius * np.sin(t)) * fb)
    words, held = [], []
    for a, v, why in cut:
        u, f = pose_display(units, a)
        words.append(f"{a} = {_fmt(v * f)} {u} ({why})")
    for a in names:
        if a not in plotted and not any(c[0] == a for c in cut):
            u, f = pose_display(units, a)
            held.append(f"{a} = {_fmt(fixed[a] * f)} {u}")
    return AtlasMap(axes=list(plotted), units=[d[0] for d in disp], coords=coords, values=values, outline=outline,
                    shape=shape, cut=", ".join(words), held=", ".join(held), points=int(inside.sum()),
                    unreachable=int((~reach).sum()), singular=singular, inside=inside, X=X, reachable=reach,
                    local={k: v[inside] for k, v in values.items()})


def atlas_size(region: WorkspaceSpec, names, resolution: int | None) -> int:
    """The grid points per plotted axis of an atlas of the region W over the
    pose axes ``names``; WorkspaceTooLarge (before anything is allocated) if
    the map would exceed the one limit on points."""
    n = int(resolution or DEFAULT_RESOLUTION)
    free = 2 if region.type == "cylinder" else sum(1 for a in names if region.axes[a][1] > region.axes[a][0])
    count = n ** min(free, 2)
    if count > MAX_POINTS:
        raise WorkspaceTooLarge(f"the atlas would have {count:,} points; expected at most {MAX_POINTS:,}")
    return n


def _csv(model: DesignModel, units: Units, X: np.ndarray, reach: np.ndarray, local: dict) -> str:
    """local_indices.csv: the poses (workspace units), reachable (0/1), the local indices (SI)."""
    names = model.mechanism.pose_names
    disp = [pose_display(units, a) for a in names]
    head = [label(a, u) for a, (u, _) in zip(names, disp)] + ["reachable"] + [index_label(units, k) for k in units.indices]
    lines = [",".join(head)]
    for j in range(len(X)):
        row = [f"{X[j, i] * f:.9g}" for i, (_, f) in enumerate(disp)] + [str(int(reach[j]))]
        row += [f"{local[k][j]:.12g}" for k in units.indices]
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def _single_pose(model: DesignModel, units: Units, region: WorkspaceSpec, design: dict):
    """The one pose of a workspace with no free axis: (X, reachable, local)."""
    names = tuple(model.mechanism.pose_names)
    X = np.array([[region.axes[a][0] for a in names]], dtype=float)
    spec = WorkspaceSpec(type="box", axes={a: (float(X[0, i]),) * 2 for i, a in enumerate(names)}, sampling="grid",
                         points_per_axis=1)
    with np.errstate(all="ignore"):
        ev = model.evaluate([design], Workspace(spec, names, X, None), keep_local=True)
    return X, np.asarray(ev.reachable[0], dtype=bool), {k: np.asarray(ev.local[k][0], dtype=float) for k in units.indices}


def write_atlas(model: DesignModel, units: Units, region: WorkspaceSpec, design: dict, out_dir: str | os.PathLike,
                resolution: int | None = None, plots: bool = True, root: str | os.PathLike | None = None,
                config_name: str = "", design_name: str = "the design") -> Path:
    """Write ``<out_dir>/local_indices.csv`` and one map PNG per index of
    ``design`` (SI parameters; the plots' titles name ``config_name`` and
    ``design_name``, e.g. "the after design").  With ``root``, ``out_dir``
    must lie inside it (symbolic links resolved); nothing is written before
    the atlas is computed."""
    out = Path(out_dir)
    n = atlas_size(region, model.mechanism.pose_names, resolution)
    amap = atlas_map(model, units, region, design, n)
    if amap is None:
        X, reach, local = _single_pose(model, units, region, design)
    else:
        X, reach, local = amap.X, amap.reachable, amap.local
    if root is not None:
        check_inside(root, out)
        for k in units.indices:
            check_inside(out, out / f"{k}.png")
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "local_indices.csv", _csv(model, units, X, reach, local))
    if plots and amap is not None:
        from .atlas_plot import atlas_png

        for k in units.indices:
            atomic_write_bytes(out / f"{k}.png", atlas_png(units, config_name, amap, k, design_name))
    return out
