"""Batches: many runs (configs × seeds) through joblib, and one table across them.

Each run is keyed by a hash of its config text and seed, and lives in
``<out>/<name>-s<seed>-<key>/``: rerunning a batch skips runs that finished and
resumes those that did not.  A run's result depends only on its config and
seed, never on the number of workers or on which worker ran it.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from .config import load_config, parse_config
from .io import atomic_write_text
from .runs import RunFolder, RunFolderError, run_key

__all__ = ["Task", "plan", "run_task", "run_batch", "summarize", "summary_tables"]


@dataclass(frozen=True)
class Task:
    """One run of a batch: everything a worker needs (no file access required)."""

    name: str
    config_text: str
    source: str
    seed: int
    key: str
    pareto: bool = False

    @property
    def folder_name(self) -> str:
        return f"{self.name}-s{self.seed}-{self.key}"


def plan(config_paths: Sequence[str], n_seeds: int = 1, seeds: Sequence[int] | None = None,
         pareto: bool = False) -> list[Task]:
    """Tasks for every config × seed.  Seeds default to the config's
    ``optimizer.seed`` and the ``n_seeds - 1`` integers after it."""
    tasks = []
    for path in config_paths:
        cfg = load_config(path)
        text = Path(path).read_text()
        ss = list(seeds) if seeds else [cfg.optimizer.seed + i for i in range(n_seeds)]
        for s in ss:
            tasks.append(Task(cfg.name, text, str(path), int(s), run_key(text, int(s), {"pareto": pareto}), pareto))
    return tasks


def run_task(task: Task, out: str, quiet: bool = True) -> dict:
    """Run (or skip, or resume) one task; returns its summary row."""
    from .optimize.pipeline import Progress, run_pipeline

    cfg = parse_config(task.config_text, source=task.source)
    folder = RunFolder(Path(out) / task.folder_name)
    state = "new"
    if folder.path.exists():
        try:
            m = folder.read_manifest()
        except RunFolderError:
            m = None
        if m is not None and m.get("status") == "complete" and (folder.path / "results.json").exists():
            return _row(task, folder, "done")
        if m is None:
            raise RunFolderError(f"{folder.path}: exists but is not a usable run folder; move it away to rerun")
        state = "resumed"
    else:
        try:
            folder = RunFolder.create(out, task.folder_name, task.config_text, task.seed, task.key, exact=True)
            folder.update_manifest(pareto=task.pareto, config_source=task.source, name=task.name)
        except FileExistsError:  # another worker created it meanwhile: resume it
            state = "resumed"
    run_pipeline(cfg, folder, task.seed, Progress(False if quiet else None), pareto=task.pareto)
    return _row(task, folder, state)


def _row(task: Task, folder: RunFolder, state: str) -> dict:
    r = json.loads((folder.path / "results.json").read_text())
    m = folder.read_manifest()
    row = {"config": task.name, "key": task.key, "seed": task.seed, "status": r["status"], "this_batch": state,
           "objective": r["objective"], "wall_time_s": m.get("wall_time_s"), "folder": str(folder.path)}
    for k, v in r["optimum"].items():
        row[f"opt_{k}"] = v
    for k, v in r["global_indices"].items():
        row[k] = v
    return row


def run_batch(tasks: Sequence[Task], out: str = "runs", jobs: int = 2, backend: str = "local",
              scheduler: str | None = None, on_result=None) -> list[dict]:
    """Run tasks through joblib (``local``: process pool on this machine)."""
    from joblib import Parallel, delayed, parallel_config

    Path(out).mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    if backend == "local":
        ctx = parallel_config(backend="loky", n_jobs=jobs)
    else:
        raise ValueError(f"unknown backend {backend!r}")
    with ctx:
        gen = Parallel(return_as="generator_unordered")(delayed(run_task)(t, str(out)) for t in tasks)
        for row in gen:
            rows.append(row)
            if on_result is not None:
                on_result(row)
    rows.sort(key=lambda r: (r["config"], r["seed"]))
    return rows


def _stats(values: Iterable[float]) -> tuple[float, float, float, float]:
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if len(v) == 0:
        return (math.nan,) * 4
    return float(v.mean()), float(v.std(ddof=1)) if len(v) > 1 else 0.0, float(v.min()), float(v.max())


def summary_tables(rows: Sequence[dict]) -> tuple[str, str]:
    """(CSV of every run, Markdown table per config: mean, spread, best)."""
    keys: list[str] = []
    for r in rows:
        for k in r:
            if k not in keys:
                keys.append(k)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    from .commands._common import table

    md = []
    by_cfg: dict[str, list[dict]] = {}
    for r in rows:
        by_cfg.setdefault(r["config"], []).append(r)
    for name, rs in by_cfg.items():
        best = min(rs, key=lambda r: r["objective"] if r["objective"] is not None else math.inf)
        cols = ["objective"] + [k for k in keys if k.startswith("opt_")] + \
               [k for k in keys if k not in ("config", "key", "seed", "status", "this_batch", "objective", "wall_time_s", "folder") and not k.startswith("opt_")] + \
               ["wall_time_s"]
        trows = []
        for c in cols:
            mean, sd, lo, hi = _stats(r.get(c) for r in rs)
            trows.append([c, f"{mean:.6g}", f"{sd:.3g}", f"{lo:.6g}", f"{hi:.6g}", f"{best.get(c, math.nan):.6g}"])
        md.append(f"### {name}: {len(rs)} runs (seeds {', '.join(str(r['seed']) for r in rs)}); best seed {best['seed']}\n")
        md.append(table(["quantity", "mean", "std", "min", "max", "best run"], trows))
        md.append("")
    return buf.getvalue(), "\n".join(md) + "\n"


def summarize(rows: Sequence[dict], out_dir: str | os.PathLike) -> tuple[Path, Path]:
    csv_text, md_text = summary_tables(rows)
    out = Path(out_dir)
    atomic_write_text(out / "summary.csv", csv_text)
    atomic_write_text(out / "summary.md", "# Batch summary\n\n" + md_text)
    return out / "summary.csv", out / "summary.md"
