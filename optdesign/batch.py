"""Batches: many runs (configs × sweeps × seeds) on local cores or a Dask cluster,
and one table across them.

Each run is keyed by a hash of its resolved config text and seed, and lives in
``<out>/<name>-s<seed>-<key>/``: rerunning a batch skips runs that finished and
resumes those that did not (from their last finished generation).  A run's
result depends only on its config and seed, never on the number of workers, on
the backend, or on which worker ran it.

Backends (both through joblib):

* ``local`` — joblib's process pool (loky) on this machine's cores;
* ``dask`` — joblib's Dask backend over a ``dask.distributed`` cluster.  The
  run folders are written by the workers, so ``out`` must be a path every
  worker sees (a shared file system, or one machine).  A worker that dies
  loses at most the generation in progress: the scheduler gives its run to
  another worker, which resumes it from the run folder's checkpoint.

A **batch file** (YAML) names a base config, the seeds and a sweep; see
:func:`load_batch_file` and ``docs/scaling.md``.
"""
from __future__ import annotations

import copy
import csv
import hashlib
import io
import itertools
import json
import math
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
import yaml

from .config import ConfigError, load_config, parse_config
from .io import atomic_write_bytes, atomic_write_text
from .runs import RunFolder, RunFolderError, run_key

__all__ = ["Task", "BackendError", "plan", "load_batch_file", "is_batch_file", "run_task", "run_batch",
           "row_from_folder", "collect_folders", "group_stats", "summary_tables", "summary_plot", "summarize",
           "config_key"]


class BackendError(RuntimeError):
    """The parallel backend cannot be used (extra not installed, scheduler unreachable, no workers)."""


@dataclass(frozen=True)
class Task:
    """One run of a batch: everything a worker needs (no file access required)."""

    name: str
    config_text: str
    source: str
    seed: int
    key: str
    pareto: bool = False
    #: the swept values of this run (dotted key -> value); empty outside sweeps
    sweep: dict = field(default_factory=dict, compare=False, hash=False)

    @property
    def folder_name(self) -> str:
        return f"{self.name}-s{self.seed}-{self.key}"


def config_key(config_text: str) -> str:
    """A short hash of a resolved config's text (the same for every seed)."""
    return hashlib.sha256(config_text.encode("utf-8")).hexdigest()[:12]


# ---------------------------------------------------------------------- batch files
_BATCH_KEYS = {"base", "name", "seeds", "mode", "sweep", "set", "pareto"}
#: sections of a config a sweep (or ``set``) may change
_SWEEPABLE = {"parameters", "design_variables", "workspace", "indices", "optimizer"}
_MAX_COMBINATIONS = 10_000


def is_batch_file(path: str | os.PathLike) -> bool:
    """True if the YAML file is a batch file (a mapping with a ``base`` or ``sweep`` key)."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    except Exception:  # noqa: BLE001 - not readable: let load_config report it
        return False
    return isinstance(data, dict) and ("base" in data or "sweep" in data)


@dataclass
class BatchFile:
    """A parsed batch file: one resolved config text per sweep combination."""

    source: str
    name: str
    seeds: list[int] | None
    pareto: bool
    combinations: list[tuple[str, str, dict]]   # (run name, resolved config text, swept values)


def _fail(source: str, path: str, message: str):
    raise ConfigError(source, path, message)


def _resolve_path(data: dict, dotted: str, source: str, where: str, base_src: str):
    """The mapping holding the last key of ``dotted`` in ``data``, and that key."""
    parts = dotted.split(".")
    if any(p == "" for p in parts):
        _fail(source, where, f"expected a dotted key such as parameters.m_platform, got {dotted!r}")
    if parts[0] not in _SWEEPABLE:
        _fail(source, where, f"can only change keys under {', '.join(sorted(_SWEEPABLE))}; got {parts[0]!r}")
    if len(parts) < 2:
        _fail(source, where, f"expected a key inside {parts[0]} (such as {parts[0]}.<name>), not the whole section")
    if parts[:2] == ["optimizer", "seed"]:
        _fail(source, where, "the seed is not swept here: use the batch file's 'seeds' (or --seeds)")
    node: Any = data
    for i, p in enumerate(parts[:-1]):
        if not isinstance(node, dict) or p not in node:
            _fail(source, where, f"{base_src} has no key {'.'.join(parts[:i + 1])!r}")
        node = node[p]
        if node is None:
            node = {}
            _set_none(data, parts[:i + 1])
    if not isinstance(node, dict):
        _fail(source, where, f"{base_src}: {'.'.join(parts[:-1])} is not a mapping")
    return node, parts[-1]


def _set_none(data: dict, parts: list[str]) -> None:
    node = data
    for p in parts[:-1]:
        node = node[p]
    if node[parts[-1]] is None:
        node[parts[-1]] = {}


def _apply(data: dict, dotted: str, value: Any, source: str, where: str, base_src: str) -> None:
    holder, key = _resolve_path(data, dotted, source, where, base_src)
    holder[key] = copy.deepcopy(value)


def _label(dotted: str, value: Any) -> str:
    """A short label for one swept value: ``m_platform=6``, ``x=-0.05..0.05``."""
    last = dotted.split(".")[-1]
    if isinstance(value, (list, tuple)) and len(value) == 2 and all(isinstance(v, (int, float)) for v in value):
        return f"{last}={value[0]:g}..{value[1]:g}"
    if isinstance(value, float):
        return f"{last}={value:g}"
    if isinstance(value, (dict, list)):
        return f"{last}={json.dumps(value, separators=(',', ':'))}"
    return f"{last}={value}"


def load_batch_file(path: str | os.PathLike) -> BatchFile:
    """Read and validate a batch file; every mistake is a one-line ConfigError.

    Schema (YAML)::

        base: p4s_paper.yaml        # required: config to vary (relative to this file)
        name: p4s_sweep             # optional: run name prefix (default: the base config's name)
        seeds: 3                    # optional: N seeds from the base's optimizer.seed, or a list [1, 2, 5]
        mode: grid                  # grid (every combination, default) or zip (i-th values together)
        sweep:                      # dotted key in the base config -> list of values (one run per value)
          parameters.m_platform: [4.16, 6.0]
          workspace.axes.x: [[-0.03, 0.03], [-0.05, 0.05]]
        set:                        # optional: fixed changes applied to every run
          optimizer.generations: 50
        pareto: false               # optional: also run the NSGA-II/III fronts

    Keys may lie under parameters, design_variables, workspace, indices and
    optimizer (not optimizer.seed).  Each combination's resolved config is
    validated like a config file.
    """
    source = str(path)
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        _fail(source, "", "file not found")
    except (OSError, UnicodeDecodeError) as exc:
        _fail(source, "", f"cannot read file ({type(exc).__name__})")
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        _fail(source, "", f"YAML syntax error{where}: {getattr(exc, 'problem', None) or 'invalid YAML'}")
    if not isinstance(raw, dict):
        _fail(source, "", "expected a mapping with 'base' and 'sweep'")
    for k in raw:
        if k not in _BATCH_KEYS:
            _fail(source, str(k), f"unknown key; expected one of {', '.join(sorted(_BATCH_KEYS))}")
    if "base" not in raw:
        _fail(source, "base", "missing required key (the config file to vary)")
    base = raw.get("base")
    if not isinstance(base, str) or not base:
        _fail(source, "base", "expected the path of a config file")
    base_path = Path(base) if Path(base).is_absolute() else p.parent / base
    if not base_path.is_file():
        _fail(source, "base", f"config file not found: {base_path}")
    base_cfg = load_config(base_path)        # a mistake in the base names the base file
    base_src = str(base_path)
    base_data = yaml.safe_load(base_path.read_text())

    name = raw.get("name", base_cfg.name)
    if not isinstance(name, str) or not name or any(c in name for c in "/\\\0") or name.startswith("."):
        _fail(source, "name", f"expected a plain name (no slashes), got {name!r}")

    seeds = None
    if "seeds" in raw:
        s = raw["seeds"]
        if isinstance(s, bool) or not isinstance(s, (int, list)):
            _fail(source, "seeds", f"expected a count or a list of seeds, got {type(s).__name__}")
        if isinstance(s, int):
            if not 1 <= s <= 100_000:
                _fail(source, "seeds", f"expected a count between 1 and 100000, got {s}")
            seeds = [base_cfg.optimizer.seed + i for i in range(s)]
        else:
            if not s:
                _fail(source, "seeds", "expected at least one seed")
            for i, v in enumerate(s):
                if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < 2 ** 32:
                    _fail(source, f"seeds[{i}]", f"expected an integer in [0, 2^32), got {v!r}")
            seeds = [int(v) for v in s]

    pareto = raw.get("pareto", False)
    if not isinstance(pareto, bool):
        _fail(source, "pareto", "expected true or false")
    mode = raw.get("mode", "grid")
    if mode not in ("grid", "zip"):
        _fail(source, "mode", f"expected grid or zip, got {mode!r}")

    data = copy.deepcopy(base_data)
    fixed = raw.get("set") or {}
    if not isinstance(fixed, dict):
        _fail(source, "set", "expected a mapping of dotted keys to values")
    for k, v in fixed.items():
        _apply(data, str(k), v, source, f"set.{k}", base_src)

    sweep = raw.get("sweep") or {}
    if not isinstance(sweep, dict):
        _fail(source, "sweep", "expected a mapping of dotted keys to lists of values")
    keys = [str(k) for k in sweep]
    for k in keys:
        vals = sweep[k]
        if not isinstance(vals, list) or not vals:
            _fail(source, f"sweep.{k}", "expected a non-empty list of values (one run per value)")
        _resolve_path(copy.deepcopy(data), k, source, f"sweep.{k}", base_src)
    if mode == "zip" and keys:
        lens = {k: len(sweep[k]) for k in keys}
        if len(set(lens.values())) > 1:
            _fail(source, "sweep", "zip mode needs lists of equal length; got "
                  + ", ".join(f"{k}: {n}" for k, n in lens.items()))
        combos = [tuple(sweep[k][i] for k in keys) for i in range(len(sweep[keys[0]]))]
    else:
        n = math.prod(len(sweep[k]) for k in keys) if keys else 1
        if n > _MAX_COMBINATIONS:
            _fail(source, "sweep", f"grid gives {n} combinations; expected at most {_MAX_COMBINATIONS}")
        combos = list(itertools.product(*(sweep[k] for k in keys)))

    width = len(str(len(combos) - 1))
    out = []
    for i, combo in enumerate(combos):
        d = copy.deepcopy(data)
        for k, v in zip(keys, combo):
            _apply(d, k, v, source, f"sweep.{k}", base_src)
        run_name = f"{name}-c{i:0{width}d}" if keys else name
        d["name"] = run_name
        label = ", ".join(_label(k, v) for k, v in zip(keys, combo))
        header = f"# resolved from base {Path(base).name}" + (f"; sweep: {label}" if label else "") + "\n"
        text = header + yaml.safe_dump(d, sort_keys=False, default_flow_style=None, allow_unicode=True)
        try:
            parse_config(text, source=source)
        except ConfigError as exc:
            blame = next((k for k in keys if exc.path and (exc.path == k or exc.path.startswith(k + ".")
                                                            or k.startswith(exc.path + "."))), None)
            if blame is not None:
                _fail(source, f"sweep.{blame}", f"value {combo[keys.index(blame)]!r} gives {exc.path}: {exc.message}")
            what = f"combination {i} ({label})" if label else "the resolved config"
            _fail(source, "set" if fixed and not label else "sweep", f"{what} gives {exc.path or 'config'}: {exc.message}")
        out.append((run_name, text, dict(zip(keys, combo))))
    return BatchFile(source, name, seeds, pareto, out)


# ---------------------------------------------------------------------- planning
def plan(config_paths: Sequence[str], n_seeds: int | None = None, seeds: Sequence[int] | None = None,
         pareto: bool | None = None) -> list[Task]:
    """Tasks for every config (or batch-file combination) × seed.

    Seeds: ``seeds`` if given; else ``n_seeds`` seeds from the config's
    ``optimizer.seed``; else a batch file's own ``seeds``; else the config's
    seed alone.  ``pareto`` (default False) overrides a batch file's setting.
    Duplicate runs (same resolved config and seed) are planned once.
    """
    tasks: list[Task] = []
    seen: set[str] = set()

    def add(name, text, source, seed_list, par, sweep):
        for s in seed_list:
            t = Task(name, text, source, int(s), run_key(text, int(s), {"pareto": par}), par, sweep)
            if t.folder_name not in seen:
                seen.add(t.folder_name)
                tasks.append(t)

    for path in config_paths:
        if is_batch_file(path):
            bf = load_batch_file(path)
            par = bf.pareto if pareto is None else pareto
            for name, text, sweep in bf.combinations:
                cfg = parse_config(text, source=str(path))
                add(name, text, str(path), _seeds(cfg, n_seeds, seeds, bf.seeds), par, sweep)
        else:
            cfg = load_config(path)
            add(cfg.name, Path(path).read_text(), str(path), _seeds(cfg, n_seeds, seeds, None), bool(pareto), {})
    return tasks


def _seeds(cfg, n_seeds, seeds, file_seeds) -> list[int]:
    if seeds:
        return list(seeds)
    if n_seeds:
        return [cfg.optimizer.seed + i for i in range(n_seeds)]
    if file_seeds:
        return list(file_seeds)
    return [cfg.optimizer.seed]


# ---------------------------------------------------------------------- one run
def run_task(task: Task, out: str, quiet: bool = True) -> dict:
    """Run (or skip, or resume) one task; returns its summary row.

    A run that fails (for example no feasible design) or a folder that cannot
    be used gives a row with status ``failed`` and the error, so the rest of
    the batch goes on.
    """
    from .optimize.pipeline import Progress, run_pipeline

    folder = RunFolder(Path(out) / task.folder_name)
    state = "new"
    try:
        cfg = parse_config(task.config_text, source=task.source)
        if folder.path.exists():
            m = folder.read_manifest()
            if m.get("status") == "complete" and (folder.path / "results.json").exists():
                return _with_state(row_from_folder(folder.path), "done")
            state = "resumed"
        else:
            try:
                folder = RunFolder.create(out, task.folder_name, task.config_text, task.seed, task.key, exact=True)
                folder.update_manifest(pareto=task.pareto, config_source=task.source, name=task.name,
                                       sweep=task.sweep)
            except FileExistsError:  # another worker created it meanwhile: resume it
                state = "resumed"
        run_pipeline(cfg, folder, task.seed, Progress(False if quiet else None), pareto=task.pareto)
    except (RunFolderError, ConfigError, RuntimeError, ValueError, ArithmeticError, OSError) as exc:
        try:
            row = row_from_folder(folder.path)
        except RunFolderError:
            row = {}
        row = {**_empty_row(task, folder.path), **{k: v for k, v in row.items() if v is not None}}
        row.update(status="failed", error=f"{type(exc).__name__}: {exc}")
        return _with_state(row, state)
    return _with_state(row_from_folder(folder.path), state)


def _with_state(row: dict, state: str) -> dict:
    row["this_batch"] = state
    return row


def _empty_row(task: Task, path: Path) -> dict:
    return {"config": task.name, "sweep": _sweep_label(task.sweep), "config_key": config_key(task.config_text),
            "run_key": task.key, "seed": task.seed, "status": "failed", "objective": None,
            "wall_time_s": None, "folder": str(path)}


def _sweep_label(sweep: dict | None) -> str:
    return ", ".join(_label(k, v) for k, v in (sweep or {}).items())


# ---------------------------------------------------------------------- rows from folders
_FIXED_COLS = ["config", "sweep", "config_key", "run_key", "seed", "status", "objective"]
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
    m = folder.read_manifest()
    try:
        text = folder.config_text()
    except RunFolderError:
        text = ""
    row: dict[str, Any] = {"config": m.get("name"), "sweep": _sweep_label(m.get("sweep")),
                           "config_key": config_key(text) if text else None, "run_key": m.get("run_key"),
                           "seed": m.get("seed"), "status": m.get("status"), "objective": None}
    res_path = folder.path / "results.json"
    if m.get("status") == "complete" and res_path.exists():
        try:
            r = json.loads(res_path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise RunFolderError(f"{res_path}: corrupted (not valid JSON)") from None
        row["config"] = row["config"] or r.get("config")
        row["status"] = r.get("status", row["status"])
        row["objective"] = r.get("objective")
        for k, v in (r.get("optimum") or {}).items():
            row[f"opt_{k}"] = v
        for k, v in (r.get("global_indices") or {}).items():
            row[k] = v
    row["wall_time_s"] = m.get("wall_time_s")
    row["evaluations"] = m.get("evaluations")
    if m.get("error"):
        row["error"] = m["error"]
    row["folder"] = str(folder.path)
    return row


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
            if k not in keys:
                keys.append(k)
    fixed = [k for k in _FIXED_COLS if k in keys]
    tail = [k for k in _TAIL_COLS if k in keys]
    opt = [k for k in keys if k.startswith("opt_")]
    rest = [k for k in keys if k not in fixed and k not in tail and k not in opt]
    return fixed + opt + rest + tail


def _quantities(rows: Sequence[dict]) -> list[str]:
    """Numeric result columns: objective, the optimum's parameters, the indices, wall time."""
    cols = _columns(rows)
    idx = [k for k in cols if k not in _FIXED_COLS and k not in _TAIL_COLS and not k.startswith("opt_")]
    return ["objective"] + [k for k in cols if k.startswith("opt_")] + idx + ["wall_time_s"]


def group_stats(rows: Sequence[dict]) -> list[dict]:
    """Statistics across seeds, one entry per resolved config (config name and
    config_key), in order of first appearance.

    Each entry: ``config``, ``sweep``, ``config_key``, ``runs``, ``complete``,
    ``seeds``, ``best_seed`` (the complete run of least objective), and
    ``stats[q] = {mean, std (ddof=1), min, max, best}`` for every quantity
    over the complete runs (``best``: the value in the best run).
    """
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r.get("config"), r.get("config_key")), []).append(r)
    qs = _quantities(rows)
    out = []
    for (name, ck), rs in groups.items():
        done = [r for r in rs if r.get("status") == "complete" and r.get("objective") is not None]
        best = min(done, key=lambda r: (r["objective"], r["seed"])) if done else None
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


def _g(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return f"{x:.6g}"


def summary_tables(rows: Sequence[dict]) -> tuple[str, str]:
    """(CSV of every run, Markdown: an overview line per resolved config, then
    per config the mean, std, min, max and best-run value of each quantity)."""
    from .commands._common import table

    rows = sorted(rows, key=lambda r: (str(r.get("config")), str(r.get("config_key")), r.get("seed") or 0))
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
                      _g(g["stats"]["objective"]["mean"]), _g(g["stats"]["objective"]["std"]),
                      _g(g["stats"]["objective"]["best"]), g["best_seed"] if g["best_seed"] is not None else "-"]
                     for g in groups]))
    md.append("")
    for g in groups:
        head = f"### {g['config']} [{g['config_key']}]" + (f": {g['sweep']}" if g["sweep"] else "")
        md.append(f"{head}\n\n{g['runs']} runs (seeds {', '.join(str(s) for s in g['seeds'])}), "
                  f"{g['complete']} complete; best seed {g['best_seed']}\n")
        md.append(table(["quantity", "mean", "std", "min", "max", "best run"],
                        [[q, _g(s["mean"]), _g(s["std"]), _g(s["min"]), _g(s["max"]), _g(s["best"])]
                         for q, s in g["stats"].items()]))
        md.append("")
    bad = [r for r in rows if r.get("status") != "complete"]
    if bad:
        md.append("### Runs not complete\n")
        md.append(table(["folder", "status", "error"], [[r.get("folder"), r.get("status"), r.get("error") or "-"]
                                                         for r in bad]))
        md.append("")
    return buf.getvalue(), "\n".join(md) + "\n"


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
    rows = [r for r in rows if r.get("status") == "complete" and r.get("objective") is not None]
    qs = [q for q in _quantities(rows) if not q.startswith("opt_") and q != "wall_time_s"]
    ncol = 2 if len(qs) > 3 else len(qs)
    nrow = math.ceil(len(qs) / ncol)
    panel_w = max(4.0, 1.1 * len(groups) + 1.0)
    fig, axes = plt.subplots(nrow, ncol, figsize=(panel_w * ncol, 3.4 * nrow + 0.6), squeeze=False)
    # a sweep's runs are told apart by their swept values, other configs by name
    labels = [g["sweep"].replace(", ", "\n") if g["sweep"] else str(g["config"]) for g in groups]
    if len(set(labels)) < len(labels):
        labels = [f"{g['config']}" + (f"\n{g['sweep']}" if g["sweep"] else "") for g in groups]
    rotate = 30 if len(groups) > 6 else 0
    for ax in axes.flat[len(qs):]:
        ax.set_visible(False)
    for ax, q in zip(axes.flat, qs):
        for i, g in enumerate(groups):
            vals = _finite(r.get(q) for r in rows if (r.get("config"), r.get("config_key")) == (g["config"], g["config_key"]))
            if len(vals) == 0:
                continue
            jitter = np.linspace(-0.12, 0.12, len(vals)) if len(vals) > 1 else np.zeros(1)
            ax.plot(i + jitter, vals, "o", ms=4, alpha=0.6, color="tab:blue")
            s = g["stats"][q]
            ax.errorbar([i + 0.3], [s["mean"]], yerr=[[s["std"]], [s["std"]]], fmt="s", color="tab:red", ms=5, capsize=3)
        ax.set_title(q)
        ax.set_xticks(range(len(groups)))
        ax.set_xticklabels(labels, rotation=rotate, ha="right" if rotate else "center", fontsize=7)
        ax.set_xlim(-0.6, len(groups) - 0.4)
        ax.grid(alpha=0.3)
    fig.suptitle("spread across seeds (points: runs; square and bar: mean ± std)", fontsize=9)
    fig.tight_layout()
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


# ---------------------------------------------------------------------- backends
def connect_dask(scheduler: str, timeout: float = 10.0, check_version: bool = True):
    """A ``distributed.Client`` on ``scheduler`` with at least one worker.

    Raises BackendError (one line) if the ``dask`` extra is missing, the
    scheduler cannot be reached within ``timeout`` seconds, no worker joins
    within ``timeout`` seconds, or a worker cannot import this optdesign.
    """
    try:
        from distributed import Client
    except ImportError:
        raise BackendError("--backend dask needs the dask extra: pip install 'optdesign[dask]'") from None
    import logging

    logging.getLogger("distributed").setLevel(logging.CRITICAL)   # our one-line error says it all
    try:
        client = Client(scheduler, timeout=timeout, set_as_default=False)
    except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError, ValueError for a bad address
        raise BackendError(f"cannot reach the Dask scheduler at {scheduler} within {timeout:g} s "
                           f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no answer'})") from None
    logging.getLogger("distributed").setLevel(logging.WARNING)
    try:
        client.wait_for_workers(1, timeout=timeout)
    except Exception:  # noqa: BLE001 - TimeoutError
        client.close()
        raise BackendError(f"the Dask scheduler at {scheduler} has no workers (none joined within {timeout:g} s)") from None
    if check_version:
        from importlib.metadata import version

        try:
            versions = client.run(version, "optdesign")
        except Exception as exc:  # noqa: BLE001 - PackageNotFoundError on a worker
            client.close()
            raise BackendError(f"a Dask worker cannot import optdesign ({type(exc).__name__}); install it on every worker") from None
        mine = version("optdesign")
        wrong = {w: v for w, v in versions.items() if v != mine}
        if wrong:
            client.close()
            w, v = next(iter(wrong.items()))
            raise BackendError(f"Dask worker {w} has optdesign {v}, this client {mine}; install the same version everywhere")
    return client


def _check_shared_folder(client, out_abs: str) -> None:
    """Every Dask worker must see the run folders' parent (a shared file system)."""
    marker = Path(out_abs) / f".optdesign-batch-{os.getpid()}-{os.urandom(4).hex()}"
    marker.write_text("")
    try:
        seen = client.run(os.path.exists, str(marker))
    finally:
        marker.unlink()
    blind = [w for w, ok in seen.items() if not ok]
    if blind:
        raise BackendError(f"Dask worker {blind[0]} does not see {out_abs}; with --backend dask, --out must be "
                           "a folder on a file system shared by this machine and every worker")


def run_batch(tasks: Sequence[Task], out: str = "runs", jobs: int | None = 2, backend: str = "local",
              scheduler: str | None = None, on_result=None, retries: int = 2, timeout: float = 10.0,
              client=None) -> list[dict]:
    """Run tasks through joblib and return their rows (sorted by config and seed).

    ``local``: joblib's process pool (loky) with ``jobs`` workers.  If a
    worker process dies, the tasks without a result are submitted again (up
    to ``retries`` times); finished runs are then skipped and interrupted ones
    resumed.  ``dask``: joblib's Dask backend on the cluster at ``scheduler``
    (or the given ``client``); every worker thread takes runs (``jobs`` is
    not used: the cluster's size decides), each run is one Dask task, and a task lost with its worker is
    rescheduled by Dask on another worker (``retries`` more times if the task
    itself raises).
    """
    from joblib import Parallel, delayed, parallel_config

    out_abs = str(Path(out).resolve())    # workers may have another working directory
    rows: dict[str, dict] = {}

    def collect(gen):
        for row in gen:
            rows[Path(row["folder"]).name] = row
            if on_result is not None:
                on_result(row)

    if backend == "local":
        from joblib.externals.loky.process_executor import TerminatedWorkerError

        Path(out_abs).mkdir(parents=True, exist_ok=True)
        attempt = 0
        while True:
            todo = [t for t in tasks if t.folder_name not in rows]
            if not todo:
                break
            try:
                with parallel_config(backend="loky", n_jobs=jobs or 2):
                    collect(Parallel(return_as="generator_unordered", batch_size=1)(
                        delayed(run_task)(t, out_abs) for t in todo))
                break
            except TerminatedWorkerError as exc:
                attempt += 1
                if attempt > retries:
                    raise
                left = len([t for t in tasks if t.folder_name not in rows])
                print(f"batch: a worker process died ({type(exc).__name__}); resubmitting the {left} runs without "
                      "a result (finished ones are skipped, interrupted ones resumed)", file=sys.stderr)
    elif backend == "dask":
        own = client is None
        if own:
            if not scheduler:
                raise BackendError("--backend dask needs --scheduler tcp://HOST:PORT")
            client = connect_dask(scheduler, timeout)
        try:
            Path(out_abs).mkdir(parents=True, exist_ok=True)
            _check_shared_folder(client, out_abs)
            # every run at once: Dask balances them over the worker threads (joblib's Dask
            # backend always uses all of them, whatever n_jobs says)
            with parallel_config(backend="dask", client=client, retries=retries, n_jobs=-1,
                                 wait_for_workers_timeout=timeout):
                collect(Parallel(return_as="generator_unordered", batch_size=1, pre_dispatch="all")(
                    delayed(run_task)(t, out_abs) for t in tasks))
        finally:
            if own:
                client.close()
    else:
        raise ValueError(f"unknown backend {backend!r}; expected local or dask")
    return sorted(rows.values(), key=lambda r: (str(r["config"]), r["seed"]))
