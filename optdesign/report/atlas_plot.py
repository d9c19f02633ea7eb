"""The PNG of one index's atlas (matplotlib): filled contours on the atlas's
own grid with labelled contour lines, the workspace's outline, the axes in the
workspace's units and the colorbar in the index's unit."""
from __future__ import annotations

import io

import numpy as np

from ..units import Units, index_label, label

__all__ = ["atlas_png"]


def atlas_png(units: Units, name: str, amap, k: str, design_name: str) -> bytes:
    """PNG bytes of index ``k`` of the map ``amap`` (:class:`optdesign.report.atlas.AtlasMap`) of
    a design of the config ``name``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker  # noqa: F401

    Z = amap.values[k]
    sense = units.indices[k][1]
    ylab = index_label(units, k)
    finite = np.isfinite(Z)
    if len(amap.axes) == 1:
        fig, ax = plt.subplots(figsize=(6.4, 4.2), layout="constrained")
        ax.plot(amap.coords[0], Z)
        ax.set_xlabel(label(amap.axes[0], amap.units[0]))
        ax.set_ylabel(ylab)
        ax.grid(alpha=0.3)
    else:
        ux, uy = amap.units
        span = [float(np.ptp(c)) or 1.0 for c in amap.coords]
        aspect = span[1] / span[0] if ux == uy else 1.0
        w = 6.4
        h = min(7.5, max(3.6, (w - 2.2) * aspect + 1.2))
        fig, ax = plt.subplots(figsize=(w, h), layout="constrained")
        A, B = np.meshgrid(*amap.coords, indexing="xy")
        if finite.sum() >= 4 and np.nanmax(Z) > np.nanmin(Z):
            cs = ax.contourf(A, B, Z, levels=20, cmap="viridis")
            cb = fig.colorbar(cs, ax=ax, shrink=0.9)
            cb.set_label(ylab)
            cb.ax.tick_params(labelsize=8)
            # labelled lines inside the range (a line at the extreme value traces noise)
            inner = [lv for lv in cs.levels[2:-1:4] if np.nanmin(Z) < lv < np.nanmax(Z)]
            cl = ax.contour(A, B, Z, levels=inner, colors="white", linewidths=0.7)
            ax.clabel(cl, fontsize=7, fmt="%.4g", inline=True)
        elif finite.any():
            v = float(np.nanmax(Z))
            ax.pcolormesh(A, B, np.where(finite, v, np.nan), cmap="viridis", shading="auto")
            ax.text(0.5, 0.5, f"{k} = {v:.5g} everywhere", transform=ax.transAxes, ha="center", va="center")
        else:
            ax.text(0.5, 0.5, "no reachable, non-singular point", transform=ax.transAxes, ha="center", va="center")
        if amap.outline is not None:
            ax.plot(*amap.outline, color="k", lw=1.5, label="workspace boundary")
        ax.set_xlabel(label(amap.axes[0], ux))
        ax.set_ylabel(label(amap.axes[1], uy))
        if ux == uy:
            ax.set_aspect("equal", adjustable="box")
        pad = [0.03 * s for s in span]
        ax.set_xlim(amap.coords[0][0] - pad[0], amap.coords[0][-1] + pad[0])
        ax.set_ylim(amap.coords[1][0] - pad[1], amap.coords[1][-1] + pad[1])
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(6))
        ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(6))
        ax.tick_params(labelsize=8)
    missing = amap.unreachable + amap.singular.get(k, 0)
    where = "; ".join(w for w in (amap.held, f"cut at {amap.cut}" if amap.cut else "") if w)
    note = f"{amap.points} points inside W" + (f", {missing} blank (unreachable or singular)" if missing else "")
    ax.set_title(f"{name}: {k} ({'maximized' if sense == 'max' else 'minimized'}) of {design_name}\n"
                 + (where + "; " if where else "") + note, fontsize=9, wrap=True)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()
