"""A finished run folder read from disk, as plain data (no code from the
folder is ever executed: JSON, CSV and the config's YAML through the safe loader)."""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import Config, parse_config
from ..runs import RunFolder, RunFolderError
from ..units import strip_unit

__all__ = ["RunData", "Front", "load_run", "MAX_FILE_BYTES"]

#: a file larger than this is refused (a run folder's files are far smaller)
MAX_FILE_BYTES = 200 * 1024 * 1024


@dataclass
class Front:
    """A Pareto front: its design vectors (SI), objective values in their own
    sense (a maximized index as itself), and the CSV's other columns."""

    name: str
    terms: list[str]                  # the optimizer's terms, '-name' for a maximized one
    designs: dict[str, np.ndarray]    # design variable -> (P,)
    objectives: dict[str, np.ndarray]  # objective name (no '-') -> (P,), own sense
    indices: dict[str, np.ndarray]    # global index -> (P,)

    @property
    def size(self) -> int:
        return len(next(iter(self.designs.values()))) if self.designs else 0


@dataclass
class RunData:
    path: Path
    manifest: dict
    results: dict
    cfg: Config
    stages: dict[str, dict] = field(default_factory=dict)     # name -> result.json
    history: dict[str, list[dict]] = field(default_factory=dict)  # name -> rows of floats
    fronts: dict[str, Front] = field(default_factory=dict)


def _read_text(p: Path) -> str:
    if p.stat().st_size > MAX_FILE_BYTES:
        raise RunFolderError(f"{p}: too large for a run folder file ({p.stat().st_size} bytes)")
    try:
        return p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise RunFolderError(f"{p}: not a text file") from None


def _read_json(p: Path) -> dict:
    try:
        d = json.loads(_read_text(p))
    except FileNotFoundError:
        raise RunFolderError(f"{p.parent}: not a finished run (no {p.name})") from None
    except json.JSONDecodeError:
        raise RunFolderError(f"{p}: corrupted (not valid JSON)") from None
    if not isinstance(d, dict):
        raise RunFolderError(f"{p}: corrupted (not a JSON object)")
    return d


def _num(s) -> float:
    try:
        x = float(s)
    except (TypeError, ValueError):
        return math.nan
    return x


def _read_csv(p: Path) -> tuple[list[str], np.ndarray]:
    text = _read_text(p)
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        return [], np.zeros((0, 0))
    head = rows[0]
    body = [r for r in rows[1:] if len(r) == len(head)]
    return head, np.array([[_num(c) for c in r] for r in body], dtype=float).reshape(len(body), len(head))


def _check_results(p: Path, r: dict, cfg: Config) -> None:
    for key, typ in (("optimum", dict), ("global_indices", dict), ("normalization", dict), ("designs", dict)):
        if not isinstance(r.get(key), typ):
            raise RunFolderError(f"{p}: {key}: missing or not a JSON object")
    for k in cfg.design_variables:
        if not isinstance(r["optimum"].get(k), (int, float)):
            raise RunFolderError(f"{p}: optimum.{k}: missing or not a number")
    for k in cfg.indices:
        if not isinstance(r["global_indices"].get(k), (int, float)):
            raise RunFolderError(f"{p}: global_indices.{k}: missing or not a number")


def _front(name: str, head: list[str], data: np.ndarray, cfg: Config, terms: list[str] | None) -> Front:
    col = {h: i for i, h in enumerate(head)}
    if terms is None:
        terms = [h[len("objective_"):] for h in head if h.startswith("objective_")]
    designs = {k: data[:, col[k]] for k in cfg.design_variables if k in col}
    objectives = {}
    for t in terms:
        c = col.get(f"objective_{t}")
        if c is None:
            continue
        # the optimizer minimizes; a maximized index is stored negated as objective_-name
        objectives[t.lstrip("-")] = -data[:, c] if t.startswith("-") else data[:, c].copy()
    indices = {k: data[:, col[k]] for k in cfg.indices if k in col}
    return Front(name, list(terms), designs, objectives, indices)


def load_run(path) -> RunData:
    """Read a finished run folder; RunFolderError (one line) if it is not one."""
    folder = RunFolder(Path(path))
    m = folder.read_manifest(strict=False)   # read only: the previous format too
    if m.get("status") != "complete":
        raise RunFolderError(f"{folder.path}: not a finished run (status: {m.get('status', 'unknown')})")
    root = folder.path.resolve()
    res_path = root / "results.json"
    results = _read_json(res_path)
    try:
        text = _read_text(root / "config.yaml")
    except FileNotFoundError:
        raise RunFolderError(f"{root}: not a run folder (no config.yaml)") from None
    cfg = parse_config(text, source=str(root / "config.yaml"), run_folder=True)
    name = m.get("config_name") or m.get("name")
    if isinstance(name, str) and name:
        cfg.name = name
    _check_results(res_path, results, cfg)
    data = RunData(root, m, results, cfg)
    order = [s for s in m.get("stages_done", []) if isinstance(s, str)]
    sdir = root / "stages"
    if sdir.is_dir():
        order += sorted(p.name for p in sdir.iterdir() if p.is_dir() and p.name not in order)
    for s in order:
        d = sdir / s
        if not d.is_dir() or d.is_symlink():
            continue
        if (d / "result.json").is_file():
            data.stages[s] = _read_json(d / "result.json")
        if (d / "history.csv").is_file():
            head, arr = _read_csv(d / "history.csv")
            head = [strip_unit(h) for h in head]   # 'best_stiffness [N/m]' -> 'best_stiffness'
            data.history[s] = [dict(zip(head, row)) for row in arr]
    for s, r in data.stages.items():
        if r.get("kind") != "pareto":
            continue
        p = root / f"{s}.csv"
        terms = r.get("terms") if isinstance(r.get("terms"), list) else None
        # the stage's result holds the front as the optimizer saw it (SI, minimized
        # objectives); the CSV file shows it in the config's units
        if isinstance(r.get("front"), list) and r["front"] and isinstance(r["front"][0], dict):
            head = list(r["front"][0])
            arr = np.array([[_num(row.get(h)) for h in head] for row in r["front"] if isinstance(row, dict)])
        elif p.is_file():
            head, arr = _read_csv(p)
        else:
            continue
        data.fronts[s] = _front(s, head, arr, cfg, terms)
    return data
