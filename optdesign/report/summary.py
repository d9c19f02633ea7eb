"""The summary of a batch: one row per run folder, statistics across seeds,
the tables (CSV and Markdown) and the plot of the spread.

Rows are read back from the run folders (never from the workers' memory), so
``optdesign summarize`` gives the same table for any set of folders, whoever
wrote them.

Seeds are compared on one scale: each run normalizes its weighted sum by the
extremes its own stages found, so a run whose extreme search fell short
scores differently for the same design.  The runs that share a design space
(same mechanism, parameters, design variables and bounds, workspace, indices
and constraints: the ``design_space`` column) pool their extremes (the
smallest minimum and the largest maximum of each index over their
``normalization`` records and their optima), and every run's optimum is
re-expressed on them (``objective_pooled``, with the run's own weights).  The
best seed and the spread across seeds are those of ``objective_pooled``.
"""
from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np

from ..io import atomic_write_bytes, atomic_write_text
from ..runs import RunFolder, RunFolderError
from ..tables import fmt_g, table
from .folders import config_key, config_of_folder, sweep_label

__all__ = ["row_from_folder", "collect_folders", "group_stats", "summary_tables", "summary_plot", "summarize",
           "pooled_rows", "design_space_key"]

_FIXED_COLS = ["config", "sweep", "config_key", "design_space", "run_key", "seed", "status", "objective_pooled",
               "objective"]
_TAIL_COLS = ["wall_time_s", "evaluations", "this_batch", "error", "folder"]


def row_from_folder(path: str | os.PathLike) -> dict:
    """The summary row of one run folder (complete or not).

    Columns: config (name), sweep (swept values), config_key (hash of the
    resolved config), run_key (config and seed), seed, status, objective,
    ``opt_<parameter>`` for each design parameter of the optimum, each global
    index, wall_time_s, evaluations, folder.  An unfinished run has its
    status and empty result columns.
    """
    folder = RunFolder(path)
    m = folder.read_manifest(strict=False)
    try:
        text = folder.config_text()
    except RunFolderError:
        text = ""
    row: dict[str, Any] = {"config": m.get("name"), "sweep": sweep_label(m.get("sweep")),
                           "config_key": config_key(text) if text else None,
                           "design_space": design_space_key(text) if text else None, "run_key": m.get("run_key"),
                           "seed": m.get("seed"), "status": m.get("status"), "objective": None}
    res_path = folder.path / "results.json"
    if m.get("status") == "complete" and res_path.exists():
        try:
            r = json.loads(folder.read_recorded("results.json", None, "the run completed").decode("utf-8"))  # no link
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise RunFolderError(f"{res_path}: corrupted (not valid JSON)") from None
        row["config"] = row["config"] or r.get("config")
        row["status"] = r.get("status", row["status"])
        row["objective"] = r.get("objective")
        for k, v in (r.get("optimum") or {}).items():
            row[f"opt_{k}"] = v
        for k, v in (r.get("global_indices") or {}).items():
            row[k] = v
        norm = _normalization(r.get("normalization"))
        if norm:
            row["_normalization"] = norm
    row["wall_time_s"] = m.get("wall_time_s")
    row["evaluations"] = m.get("evaluations")
    if m.get("error"):
        row["error"] = m["error"]
    row["folder"] = str(folder.path)
    return row


def design_space_key(config_text: str) -> str | None:
    """A short hash of what defines a config's design space and its indices
    (mechanism, parameters, design variables and bounds, workspace, indices,
    constraints), or None if the text is not a valid config.  Runs with the
    same key have the same feasible designs and the same index values."""
    from ..config import ConfigError, parse_config

    try:
        cfg = parse_config(config_text, source="config.yaml", run_folder=True)
    except (ConfigError, ValueError, TypeError):
        return None
    opt = cfg.optimizer
    space = {"mechanism": cfg.raw.get("mechanism"), "parameters": cfg.parameters,
             "design_variables": {k: [dv.value, dv.bounds] for k, dv in cfg.design_variables.items()},
             "workspace": repr(cfg.workspace),
             "indices": {k: [s.kind, s.convention, sorted((s.options or {}).items())] for k, s in cfg.indices.items()},
             "constraints": [opt.singularity_threshold, opt.stroke_limits]
             + ([opt.constraint_singularity] if opt.constraint_singularity is not None else [])}
    text = json.dumps(space, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def _normalization(norm) -> dict:
    """The numeric part of a results.json normalization record (index -> min,
    max, sense, weight); entries that are not well-formed are left out."""
    out = {}
    if not isinstance(norm, dict):
        return out
    for k, v in norm.items():
        if (isinstance(v, dict) and all(isinstance(v.get(x), (int, float)) and not isinstance(v.get(x), bool)
                                        and math.isfinite(v[x]) for x in ("min", "max", "weight"))
                and v.get("sense") in ("min", "max")):
            out[k] = {"min": float(v["min"]), "max": float(v["max"]), "weight": float(v["weight"]), "sense": v["sense"]}
    return out


def pooled_rows(rows: Sequence[dict]) -> list[dict]:
    """Copies of the rows with ``objective_pooled``: the run's optimum on the
    extremes pooled over the complete runs of its design space (None where a
    run has no normalization or index values)."""
    pool: dict = {}
    for r in rows:
        norm, ds = r.get("_normalization"), r.get("design_space")
        if r.get("status") != "complete" or not norm or ds is None:
            continue
        p = pool.setdefault(ds, {})
        for k, v in norm.items():
            vals = [v["min"], v["max"]] + ([float(r[k])] if isinstance(r.get(k), (int, float)) and math.isfinite(r[k]) else [])
            lo, hi = p.get(k, (math.inf, -math.inf))
            p[k] = (min([lo] + vals), max([hi] + vals))
    out = []
    for r in rows:
        r = dict(r)
        r["objective_pooled"] = None
        norm, p = r.get("_normalization"), pool.get(r.get("design_space"))
        if r.get("status") == "complete" and norm and p:
            f = 0.0
            for k, v in norm.items():
                x = r.get(k)
                if not isinstance(x, (int, float)) or not math.isfinite(x):
                    f = None
                    break
                lo, hi = p[k]
                t = (x - lo) / (hi - lo) if hi > lo else 0.0
                f += v["weight"] * (1.0 - t if v["sense"] == "max" else t)
            r["objective_pooled"] = f
        out.append(r)
    return out


def collect_folders(paths: Sequence[str | os.PathLike]) -> list[Path]:
    """Run folders among ``paths``: a path with a manifest.json is a run
    folder; otherwise its subfolders that have one are (sorted by name)."""
    found: list[Path] = []
    for p in map(Path, paths):
        if not p.is_dir():
            raise RunFolderError(f"{p}: no such directory")
        if (p / "manifest.json").is_file():
            found.append(p)
            continue
        found.extend(sorted(c for c in p.iterdir() if c.is_dir() and (c / "manifest.json").is_file()))
    seen, out = set(), []
    for f in found:
        r = f.resolve()
        if r not in seen:
            seen.add(r)
            out.append(f)
    return out


# ---------------------------------------------------------------------- one table
def _finite(values: Iterable) -> np.ndarray:
    return np.array([float(x) for x in values if isinstance(x, (int, float)) and not isinstance(x, bool)
                     and math.isfinite(x)], dtype=float)


def _stats(values: Iterable) -> tuple[float, float, float, float]:
    v = _finite(values)
    if len(v) == 0:
        return (math.nan,) * 4
    return float(v.mean()), float(v.std(ddof=1)) if len(v) > 1 else 0.0, float(v.min()), float(v.max())


def _columns(rows: Sequence[dict]) -> list[str]:
    keys: list[str] = []
    for r in rows:
        for k in r:
            if k not in keys and not k.startswith("_"):
                keys.append(k)
    fixed = [k for k in _FIXED_COLS if k in keys]
    tail = [k for k in _TAIL_COLS if k in keys]
    opt = [k for k in keys if k.startswith("opt_")]
    rest = [k for k in keys if k not in fixed and k not in tail and k not in opt]
    return fixed + opt + rest + tail


def _quantities(rows: Sequence[dict]) -> list[str]:
    """Numeric result columns: the objective on the pooled scale and the run's
    own, the optimum's parameters, the indices, wall time."""
    cols = _columns(rows)
    idx = [k for k in cols if k not in _FIXED_COLS and k not in _TAIL_COLS and not k.startswith("opt_")]
    return ["objective_pooled", "objective"] + [k for k in cols if k.startswith("opt_")] + idx + ["wall_time_s"]


def group_stats(rows: Sequence[dict]) -> list[dict]:
    """Statistics across seeds, one entry per resolved config (config name and
    config_key), in order of first appearance.

    Each entry: ``config``, ``sweep``, ``config_key``, ``runs``, ``complete``,
    ``seeds``, ``best_seed`` (the complete run of least objective on the
    pooled scale, see :func:`pooled_rows`), and ``stats[q] = {mean, std
    (ddof=1), min, max, best}`` for every quantity over the complete runs
    (``best``: the value in the best run).
    """
    rows = pooled_rows(rows)
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r.get("config"), r.get("config_key")), []).append(r)
    qs = _quantities(rows)
    out = []
    for (name, ck), rs in groups.items():
        done = [r for r in rs if r.get("status") == "complete" and r.get("objective") is not None]
        score = lambda r: r["objective_pooled"] if r.get("objective_pooled") is not None else r["objective"]  # noqa: E731
        best = min(done, key=lambda r: (score(r), r["seed"])) if done else None
        stats = {}
        for q in qs:
            mean, sd, lo, hi = _stats(r.get(q) for r in done)
            b = best.get(q) if best is not None else None
            stats[q] = {"mean": mean, "std": sd, "min": lo, "max": hi,
                        "best": float(b) if isinstance(b, (int, float)) else math.nan}
        out.append({"config": name, "sweep": rs[0].get("sweep", ""), "config_key": ck, "runs": len(rs),
                    "complete": len(done), "seeds": [r.get("seed") for r in rs],
                    "best_seed": best["seed"] if best else None, "stats": stats})
    return out


def summary_tables(rows: Sequence[dict]) -> tuple[str, str]:
    """(CSV of every run, Markdown: an overview line per resolved config, then
    per config the mean, std, min, max and best-run value of each quantity)."""
    rows = sorted(pooled_rows(rows), key=lambda r: (str(r.get("config")), str(r.get("config_key")), r.get("seed") or 0))
    keys = _columns(rows)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else (repr(r[k]) if isinstance(r.get(k), float) else r[k]))
                    for k in keys})
    groups = group_stats(rows)
    md = ["## Overview", ""]
    md.append(table(["config", "sweep", "config key", "runs", "complete", "objective mean", "std", "best", "best seed"],
                    [[g["config"], g["sweep"] or "-", g["config_key"] or "-", g["runs"], g["complete"],
                      fmt_g(g["stats"]["objective_pooled"]["mean"]), fmt_g(g["stats"]["objective_pooled"]["std"]),
                      fmt_g(g["stats"]["objective_pooled"]["best"]), g["best_seed"] if g["best_seed"] is not None else "-"]
                     for g in groups]))
    md.append("")
    md.append(_pooled_note(rows))
    md.append("")
    for g in groups:
        head = f"### {g['config']} [{g['config_key']}]" + (f": {g['sweep']}" if g["sweep"] else "")
        md.append(f"{head}\n\n{g['runs']} runs (seeds {', '.join(str(s) for s in g['seeds'])}), "
                  f"{g['complete']} complete; best seed {g['best_seed']}\n")
        md.append(table(["quantity", "mean", "std", "min", "max", "best run"],
                        [[q, fmt_g(s["mean"]), fmt_g(s["std"]), fmt_g(s["min"]), fmt_g(s["max"]), fmt_g(s["best"])]
                         for q, s in g["stats"].items()]))
        md.append("")
    bad = [r for r in rows if r.get("status") != "complete"]
    if bad:
        md.append("### Runs not complete\n")
        md.append(table(["folder", "status", "error"], [[r.get("folder"), r.get("status"), r.get("error") or "-"]
                                                         for r in bad]))
        md.append("")
    return buf.getvalue(), "\n".join(md) + "\n"


#: a weighted-sum objective this close to 0 is 0 (round-off of the normalization)
ROUND_OFF = 1e-12


def _quantity_labels(rows: Sequence[dict], qs: Sequence[str]) -> dict[str, str]:
    """Each quantity with its unit, from the configs of the run folders (one
    folder read per resolved config; the name alone where none can be read).
    Runs of different mechanisms may give one index name different units (a
    stiffness in N/m for translations, N m/rad for rotations): the label then
    names each unit with its configs instead of one unit for all."""
    from ..units import index_unit, label

    out = {q: q for q in qs}
    out["objective"] = "objective f [–]"
    units: dict[str, dict[str, list[str]]] = {q: {} for q in qs}    # quantity -> unit -> configs
    seen = set()
    for r in rows:
        key = (r.get("config"), r.get("config_key"))
        if key in seen:
            continue
        try:
            cfg = config_of_folder(r["folder"])
        except Exception:  # noqa: BLE001 - a folder that cannot be read: the next one
            continue
        seen.add(key)
        for q in qs:
            if q in cfg.indices:
                names = units[q].setdefault(index_unit(cfg.units(), q) or "", [])
                if str(r.get("config")) not in names:
                    names.append(str(r.get("config")))
    for q, by in units.items():
        if len(by) == 1:
            out[q] = label(q, next(iter(by)) or None)
        elif len(by) > 1:
            out[q] = f"{q} [" + "; ".join(f"{u or '?'}: {', '.join(c)}" for u, c in by.items()) + "]"
    return out


def _pooled_note(rows: Sequence[dict]) -> str:
    """The Markdown line that says on which scale the objectives are compared."""
    spaces: dict = {}
    for r in rows:
        if r.get("objective_pooled") is not None:
            spaces.setdefault(r["design_space"], set()).add(r.get("config_key"))
    n = sum(1 for r in rows if r.get("objective_pooled") is not None)
    if not n:
        return "Objectives: each run's own (no run records its normalization)."
    return (f"Objectives on one scale: each index normalized by its extremes pooled over the {n} complete runs of "
            f"its design space ({len(spaces)} design space(s), column `design_space`), every run's optimum "
            "re-expressed on them with its own weights (`objective_pooled`; the best seed and the spread are "
            "those of this column). `objective` is each run's own, on the extremes its own stages found.")


def summary_plot(rows: Sequence[dict], path: str | os.PathLike) -> Path | None:
    """PNG of the spread across seeds: one panel per quantity (objective and
    each global index), one column of points per resolved config (one point
    per seed), with the mean and ±1 standard deviation."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = group_stats(rows)
    if not any(g["complete"] for g in groups):
        return None
    rows = [r for r in pooled_rows(rows) if r.get("status") == "complete" and r.get("objective") is not None]
    qs = [q for q in _quantities(rows) if not q.startswith("opt_") and q != "wall_time_s"]
    ncol = 2 if len(qs) > 3 else len(qs)
    nrow = math.ceil(len(qs) / ncol)
    panel_w = max(4.0, 1.1 * len(groups) + 1.0)
    fig, axes = plt.subplots(nrow, ncol, figsize=(panel_w * ncol, 3.4 * nrow + 0.6), squeeze=False,
                             layout="constrained")
    # a sweep's runs are told apart by their swept values, other configs by name
    labels = [g["sweep"].replace(", ", "\n") if g["sweep"] else str(g["config"]) for g in groups]
    if len(set(labels)) < len(labels):
        labels = [f"{g['config']}" + (f"\n{g['sweep']}" if g["sweep"] else "") for g in groups]
    rotate = 30 if len(groups) > 6 else 0
    names = _quantity_labels(rows, qs)
    for ax in axes.flat[len(qs):]:
        ax.set_visible(False)
    for ax, q in zip(axes.flat, qs):
        # the weighted sum is >= 0 with 0 its best: values within round-off of 0 are 0
        # (an axis scaled to 1e-18 would show noise as a spread)
        tiny = q == "objective"
        clean = (lambda v: np.where(np.abs(v) < ROUND_OFF, 0.0, v)) if tiny else (lambda v: v)
        rounded = False
        for i, g in enumerate(groups):
            raw = _finite(r.get(q) for r in rows if (r.get("config"), r.get("config_key")) == (g["config"], g["config_key"]))
            if len(raw) == 0:
                continue
            vals = clean(raw)
            rounded = rounded or bool(np.any(vals != raw))
            jitter = np.linspace(-0.12, 0.12, len(vals)) if len(vals) > 1 else np.zeros(1)
            ax.plot(i + jitter, vals, "o", ms=4, alpha=0.6, color="tab:blue")
            mean, sd = float(np.mean(vals)), float(np.std(vals, ddof=1)) if len(vals) > 1 else 0.0
            ax.errorbar([i + 0.3], [mean], yerr=[[sd], [sd]], fmt="s", color="tab:red", ms=5, capsize=3)
        ax.set_title(names[q] + (f"\n(|values| < {ROUND_OFF:g} shown as 0: round-off)" if rounded else ""), fontsize=9)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4), useOffset=False)
        ax.set_xticks(range(len(groups)))
        ax.set_xticklabels(labels, rotation=rotate, ha="right" if rotate else "center", fontsize=7)
        ax.set_xlim(-0.6, len(groups) - 0.4)
        ax.grid(alpha=0.3)
    fig.suptitle("spread across seeds (points: runs; square and bar: mean ± std)", fontsize=9)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def summarize(rows: Sequence[dict], out_dir: str | os.PathLike, plot: bool = True) -> tuple[Path, Path]:
    """Write ``summary.csv``, ``summary.md`` (and ``summary.png``) in ``out_dir``."""
    csv_text, md_text = summary_tables(rows)
    out = Path(out_dir)
    atomic_write_text(out / "summary.csv", csv_text)
    atomic_write_text(out / "summary.md", "# Batch summary\n\n" + md_text)
    if plot:
        summary_plot(rows, out / "summary.png")
    return out / "summary.csv", out / "summary.md"
