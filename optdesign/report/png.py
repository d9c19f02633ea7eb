"""The plots of a finished run: convergence.png and pareto.png (each objective
in its own sense, with its unit)."""
from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..runs import RunFolder
from ..units import Units

__all__ = ["plots", "convergence_figure", "pareto_figure", "ROUND_OFF"]

#: a weighted sum this close to 0 is 0 (round-off of the normalization)
ROUND_OFF = 1e-12


def _read_csv(path: Path) -> list[dict]:
    """A CSV file of the run as rows keyed by quantity name (the unit suffix dropped)."""
    from ..units import strip_unit

    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return [{strip_unit(k): v for k, v in r.items()} for r in csv.DictReader(fh)]


def _own_sense(units: Units, term: str, values) -> np.ndarray:
    """A minimized objective term's values in the objective's own sense and shown unit."""
    from ..units import objective_unit

    v = np.asarray(values, dtype=float)
    return (-v if term.startswith("-") else v) * objective_unit(units, term.lstrip("-"))[1]


def _objective_axis(units: Units, term: str) -> str:
    from ..units import index_label

    name = term.lstrip("-")
    sense = units.indices[name][1] if name in units.indices else ("max" if term.startswith("-") else "min")
    return f"{index_label(units, name)}, {'maximized' if sense == 'max' else 'minimized'}"


def plots(units: Units, folder: RunFolder, results: dict, stages: dict) -> None:
    fig = convergence_figure(results["config"], _read_csv(folder.path / "stages" / "weighted_sum" / "history.csv"))
    if fig is not None:
        _save(fig, folder.path / "convergence.png")
    fig = pareto_figure(units, results, stages)
    if fig is not None:
        _save(fig, folder.path / "pareto.png")


def convergence_figure(name: str, hist: list[dict]):
    """The weighted sum f per generation (``name``: the config's, in the title) (best and population mean) on a
    logarithmic axis: f falls by decades towards its best, 0, and a linear
    axis shows all but the first generations flat at 0.  Values within
    round-off of 0 are 0, drawn on the linear band of a symlog axis (said in
    the title); None without a history."""
    import matplotlib.ticker

    if not hist:
        return None
    g = [int(r["generation"]) for r in hist]
    best = np.array([float(r["best_objective"]) for r in hist])
    mean = np.array([float(r["mean_objective"]) for r in hist])
    vals = np.concatenate([best, mean])
    vals = vals[np.isfinite(vals)]
    zero = bool(np.any(np.abs(vals) < ROUND_OFF))
    best, mean = (np.where(np.abs(v) < ROUND_OFF, 0.0, v) for v in (best, mean))
    fig = _figure(figsize=(6.4, 4))
    ax = fig.subplots()
    ax.plot(g, best, label="best", marker="o", ms=3, clip_on=False)
    ax.plot(g, mean, label="population mean", alpha=0.7, marker="o", ms=3, clip_on=False)
    pos = vals[np.abs(vals) >= ROUND_OFF]
    title = f"{name}: convergence of the weighted sum (minimized)"
    scale = "linear"
    if len(pos) and not zero and np.all(vals > 0):   # values shown as 0 cannot sit on a log axis
        ax.set_yscale("log")
        scale = "log scale"
    elif len(pos):
        # 0 on a linear band one decade below the smallest value that is not round-off
        linthresh = float(np.min(np.abs(pos))) / 10
        ax.set_yscale("symlog", linthresh=linthresh, linscale=1.5)
        scale = "symlog"
        # no decade ticks inside the linear band: their labels would sit on top of 0's
        ticks = ax.yaxis.get_major_locator().tick_values(*ax.get_ylim())
        ax.yaxis.set_major_locator(matplotlib.ticker.FixedLocator(
            [t for t in ticks if t == 0 or abs(t) >= linthresh * (1 - 1e-9)]))
    if zero:
        title += f"\n(|f| < {ROUND_OFF:g} shown as 0: round-off)"
    ax.set_xlabel("generation")
    ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_ylabel(f"weighted sum f [–], {scale}")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    return fig


def pareto_figure(units: Units, results: dict, stages: dict):
    """The Pareto fronts, each pair of objectives in its own sense (None
    without a front).  Markers are never cut at the frame (clip_on=False)."""
    import matplotlib.ticker

    fronts = {k: v for k, v in stages.items() if v.get("kind") == "pareto" and v.get("front")}
    if not fronts:
        return None
    any_front = next(iter(fronts.values()))
    terms = any_front["terms"]
    pairs = [(i, j) for i in range(len(terms)) for j in range(i + 1, len(terms))]
    ncol = min(3, len(pairs))
    nrow = -(-len(pairs) // ncol)
    fig = _figure(figsize=(4.8 * ncol, 4.2 * nrow + 0.5))
    axes = fig.subplots(nrow, ncol, squeeze=False)
    for ax in axes.flat[len(pairs):]:
        ax.set_visible(False)
    marks = {"weighted_sum_optimum": ("*", "k", "weighted-sum optimum")}
    for n, (mk, col) in zip([n for n in results.get("designs", {})], [("s", "tab:red"), ("D", "tab:green"),
                                                                    ("^", "tab:purple"), ("v", "tab:brown")]):
        marks[n] = (mk, col, f"{n} (config)")
    sizes = {name: len(s["front"]) for name, s in fronts.items()}
    own = {name: np.array([[_own_sense(units, t, r[f"objective_{t}"]) for t in terms] for r in s["front"]])
           for name, s in fronts.items()}
    points = {}   # the weighted-sum optimum and the named designs, in the objectives' own sense
    for alg, p in results.get("pareto", {}).items():
        lo, hi = np.array(p["normalization"]["best"]), np.array(p["normalization"]["worst"])
        for n, pl in p["placement"].items():
            if n in marks:
                v = np.array(pl["normalized_objectives"]) * (hi - lo) + lo
                points[n] = np.array([_own_sense(units, t, v[k]) for k, t in enumerate(terms)])
        break
    for ax, (i, j) in zip(axes.flat, pairs):
        for n_front, (name, F) in enumerate(own.items()):
            label = f"{name} ({len(F)} design{'s' if len(F) != 1 else ''})"
            if len(F) == 1:   # a front of one design: a large ring (one size per front), seen around other marks
                ax.scatter(F[:, i], F[:, j], s=260 + 160 * n_front, facecolors="none", linewidths=2.2,
                           edgecolors=f"C{n_front}", label=label, zorder=6, clip_on=False)
            else:
                ax.scatter(F[:, i], F[:, j], s=14, alpha=0.6, color=f"C{n_front}", edgecolors="none", label=label,
                           zorder=4, clip_on=False)
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
        ax.set_xlabel(_objective_axis(units, terms[i]), fontsize=9)
        ax.set_ylabel(_objective_axis(units, terms[j]), fontsize=9)
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
    title = f"{results['config']}: Pareto fronts, each objective in its own sense"
    if one:
        title += f"\n{', '.join(one)}: the front collapsed to ONE design (no trade-off found)"
    fig.suptitle(title, fontsize=10)
    return fig


def _figure(figsize):
    """A figure of its own, not pyplot's (no pyplot to import, nothing to close;
    savefig draws it with matplotlib's Agg canvas)."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def _save(fig, path: Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    from ..io import atomic_write_bytes

    atomic_write_bytes(path, buf.getvalue())
