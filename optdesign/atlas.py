"""Index atlases: local index maps over a plane of the workspace (the paper's
figures 15-26), as CSV data and contour plots."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .config import Config, ConfigError
from .evaluate import evaluate, mechanism_class
from .io import atomic_write_text
from .names import check_inside
from .workspace import MAX_POINTS, WorkspaceSpec, point_count, sample

__all__ = ["atlas_plane", "write_atlas"]


def atlas_plane(cfg: Config, resolution: int | None = None, fixed: dict[str, float] | None = None):
    """The grid of the atlas: the config's workspace if it is a plane grid,
    otherwise its bounding box cut at the middle (or ``fixed``) of the extra axes."""
    names = mechanism_class(cfg).pose_names
    ws = cfg.workspace
    axes = dict(ws.axes)
    if ws.type == "cylinder":
        cx, cy = ws.center
        axes[names[0]] = (cx - ws.radius, cx + ws.radius)
        axes[names[1]] = (cy - ws.radius, cy + ws.radius)
    free = [a for a in names if axes[a][1] > axes[a][0]]
    fixed = dict(fixed or {})
    for a in free[2:]:
        if a not in fixed:
            fixed[a] = 0.5 * (axes[a][0] + axes[a][1])
    for a, v in fixed.items():
        axes[a] = (v, v)
    n = resolution or (None if (ws.sampling == "grid" and ws.type == "box" and len(free) <= 2) else 41)
    spec = WorkspaceSpec(type="box", axes=axes, sampling="grid",
                         step=ws.step if n is None else None,
                         points_per_axis=n if n is not None else ws.points_per_axis)
    count = point_count(spec, names)
    if count > MAX_POINTS:      # before anything is allocated
        raise ConfigError(cfg.source, "workspace" if resolution is None else "--resolution",
                          f"the atlas plane would have {count:,} points; expected at most {MAX_POINTS:,}")
    return sample(spec, names)


def write_atlas(cfg: Config, design: str, out_dir: str | os.PathLike, resolution: int | None = None,
                fixed: dict[str, float] | None = None, plots: bool = True,
                root: str | os.PathLike | None = None) -> Path:
    """Write ``<out_dir>/local_indices.csv`` and one contour PNG per index.
    With ``root``, ``out_dir`` must lie inside it (symbolic links resolved);
    nothing is written before the atlas is computed."""
    out = Path(out_dir)
    ws = atlas_plane(cfg, resolution, fixed)
    ev = evaluate(cfg, [cfg.design(design)], ws, keep_local=True, errors=False)
    if root is not None:
        check_inside(root, out)
        for k in cfg.indices:
            check_inside(out, out / f"{k}.png")
    out.mkdir(parents=True, exist_ok=True)
    names = ws.names
    lines = [",".join(list(names) + ["reachable"] + list(cfg.indices))]
    for j in range(ws.n):
        row = [f"{x:.9g}" for x in ws.X[j]] + [str(int(ev.reachable[0, j]))]
        row += [f"{ev.local[k][0, j]:.12g}" for k in cfg.indices]
        lines.append(",".join(row))
    atomic_write_text(out / "local_indices.csv", "\n".join(lines) + "\n")
    free = [i for i, a in enumerate(names) if ws.spec.axes[a][1] > ws.spec.axes[a][0]]
    if plots and len(free) == 2 and ws.grid_shape is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        i0, i1 = free
        shape = ws.grid_shape
        A = ws.X[:, i0].reshape(shape)
        B = ws.X[:, i1].reshape(shape)
        for k, spec in cfg.indices.items():
            Zv = ev.local[k][0].reshape(shape)
            fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
            finite = np.isfinite(Zv)
            if finite.sum() >= 4:
                cs = ax1.contourf(A, B, np.where(finite, Zv, np.nan), levels=20, cmap="viridis")
                fig.colorbar(cs, ax=ax1)
                cl = ax2.contour(A, B, np.where(finite, Zv, np.nan), levels=10, colors="k", linewidths=0.8)
                ax2.clabel(cl, fontsize=7)
            for ax in (ax1, ax2):
                ax.set_xlabel(f"{names[i0]}")
                ax.set_ylabel(f"{names[i1]}")
                ax.set_aspect("equal", adjustable="box")
            fixed_txt = ", ".join(f"{names[i]} = {ws.X[0, i]:g}" for i in range(len(names)) if i not in free)
            ax1.set_title(f"{k} ({spec.kind}) atlas")
            ax2.set_title(f"{k} contours" + (f" at {fixed_txt}" if fixed_txt else ""))
            fig.suptitle(f"{cfg.name}: {design} design")
            fig.tight_layout()
            tmp = out / f".{k}.png.tmp"
            fig.savefig(tmp, dpi=110, format="png")
            plt.close(fig)
            os.replace(tmp, out / f"{k}.png")
    return out
