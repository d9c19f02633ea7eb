"""A finished run folder read from disk, as plain data (no code from the
folder is ever executed: JSON, CSV and the config's YAML through the safe loader).

The folder's config.yaml is read here and nowhere else in the HTML report:
:class:`RunData` holds the plain pieces the pages read of it (the units
table, the design model, the workspace's region, the names), never the config."""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...config import Config, parse_config
from ...evaluate import DesignModel
from ...runs import FORMAT_VERSION, MAX_CONFIG, MAX_JSON, RunFolder, RunFolderError
from ...units import Units, strip_unit
from ...workspace import WorkspaceSpec

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
    name: str                     # the config's name (the manifest's, for a run of a batch)
    mechanism: str                # the mechanism's name
    description: Any              # the config's description (None without one)
    reference: dict               # the config's reference values of named designs
    units: Units                  # the design-variable table, the indices' senses, what each is shown in
    model: DesignModel            # a design's mechanism and its indices over any workspace
    workspace: WorkspaceSpec      # the region W
    stages: dict[str, dict] = field(default_factory=dict)     # name -> result.json
    history: dict[str, list[dict]] = field(default_factory=dict)  # name -> rows of floats
    fronts: dict[str, Front] = field(default_factory=dict)

    @classmethod
    def of(cls, path: Path, manifest: dict, results: dict, cfg: Config) -> "RunData":
        """The run's data with the pieces of its config (and no stage yet)."""
        return cls(path, manifest, results, cfg.name, cfg.mechanism, cfg.raw.get("description"), cfg.reference,
                   cfg.units(), DesignModel.from_config(cfg), cfg.workspace)


def _text(data: bytes, p: Path) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise RunFolderError(f"{p}: not a text file") from None


def _json_object(data: bytes, p: Path) -> dict:
    try:
        d = json.loads(_text(data, p))
    except (json.JSONDecodeError, RecursionError):
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


def _read_csv(text: str) -> tuple[list[str], np.ndarray]:
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        return [], np.zeros((0, 0))
    head = rows[0]
    body = [r for r in rows[1:] if len(r) == len(head)]
    return head, np.array([[_num(c) for c in r] for r in body], dtype=float).reshape(len(body), len(head))


def _check_results(p: Path, r: dict, units: Units) -> None:
    for key, typ in (("optimum", dict), ("global_indices", dict), ("normalization", dict), ("designs", dict)):
        if not isinstance(r.get(key), typ):
            raise RunFolderError(f"{p}: {key}: missing or not a JSON object")
    for k in units.variables:
        if not isinstance(r["optimum"].get(k), (int, float)):
            raise RunFolderError(f"{p}: optimum.{k}: missing or not a number")
    for k in units.indices:
        if not isinstance(r["global_indices"].get(k), (int, float)):
            raise RunFolderError(f"{p}: global_indices.{k}: missing or not a number")


def _front(name: str, head: list[str], data: np.ndarray, units: Units, terms: list[str] | None) -> Front:
    col = {h: i for i, h in enumerate(head)}
    if terms is None:
        terms = [h[len("objective_"):] for h in head if h.startswith("objective_")]
    designs = {k: data[:, col[k]] for k in units.variables if k in col}
    objectives = {}
    for t in terms:
        c = col.get(f"objective_{t}")
        if c is None:
            continue
        # the optimizer minimizes; a maximized index is stored negated as objective_-name
        objectives[t.lstrip("-")] = -data[:, c] if t.startswith("-") else data[:, c].copy()
    indices = {k: data[:, col[k]] for k in units.indices if k in col}
    return Front(name, list(terms), designs, objectives, indices)


def load_run(path) -> RunData:
    """Read a finished run folder; RunFolderError (one line) if it is not one.

    Every file is opened without following a symbolic link (nor one of the
    folders below the run folder) and checked against the SHA-256 the
    manifest records for it before it is used: config.yaml, results.json,
    each finished stage's files and the Pareto CSV files.  A stage file the
    manifest does not record is not read (in a folder of the previous format,
    which records no hashes of some files, those are read unchecked)."""
    folder = RunFolder(Path(path))
    m = folder.read_manifest(strict=False)   # read only: the previous format too
    if m.get("status") != "complete":
        raise RunFolderError(f"{folder.path}: not a finished run (status: {m.get('status', 'unknown')})")
    root = folder.path.resolve()
    folder = RunFolder(root)
    current = m.get("format_version") == FORMAT_VERSION

    def want(key: str):
        v = m.get(key)
        return v if isinstance(v, str) else ("" if current else None)   # "": matches no file

    def read(rel: str, sha, since: str, limit: int = MAX_FILE_BYTES) -> bytes:
        try:
            return folder.read_recorded(rel, sha, since, limit)
        except RunFolderError as exc:
            if sha is None and "missing" in str(exc):
                raise FileNotFoundError(rel) from None
            raise

    cfg_path, res_path = root / "config.yaml", root / "results.json"
    try:
        text = _text(read("config.yaml", want("config_sha256"), "the run started", MAX_CONFIG), cfg_path)
    except FileNotFoundError:
        raise RunFolderError(f"{root}: not a run folder (no config.yaml)") from None
    try:
        results = _json_object(read("results.json", want("results_sha256"), "the run completed", MAX_JSON), res_path)
    except FileNotFoundError:
        raise RunFolderError(f"{root}: not a finished run (no results.json)") from None
    cfg = parse_config(text, source=str(cfg_path), run_folder=True)
    name = m.get("config_name") or m.get("name")
    if isinstance(name, str) and name:
        cfg.name = name
    data = RunData.of(root, m, results, cfg)
    _check_results(res_path, results, data.units)
    records = m.get("stages") if isinstance(m.get("stages"), dict) else {}
    order = [s for s in m.get("stages_done", []) if isinstance(s, str)]
    sdir = root / "stages"
    if current:
        _check_stages(root, order, records)
    elif sdir.is_dir() and not sdir.is_symlink():
        order += sorted(p.name for p in sdir.iterdir() if p.is_dir() and not p.is_symlink() and p.name not in order)
    files: dict[str, str | None] = {}
    for s in order:
        rec = records.get(s)
        rec_files = rec.get("files") if isinstance(rec, dict) and isinstance(rec.get("files"), dict) else None
        if current:
            for rel, sha in rec_files.items():   # every file of the stage, unchanged
                files[rel] = read(rel, sha, "the stage finished")
        for f in ("result.json", "history.csv"):
            rel = f"stages/{s}/{f}"
            if rel in files or current:
                continue
            try:
                files[rel] = read(rel, None, "the stage finished")
            except FileNotFoundError:
                pass
        if f"stages/{s}/result.json" in files:
            data.stages[s] = _json_object(files[f"stages/{s}/result.json"], root / f"stages/{s}/result.json")
        if f"stages/{s}/history.csv" in files:
            head, arr = _read_csv(_text(files[f"stages/{s}/history.csv"], root / f"stages/{s}/history.csv"))
            head = [strip_unit(h) for h in head]   # 'best_stiffness [N/m]' -> 'best_stiffness'
            data.history[s] = [dict(zip(head, row)) for row in arr]
    for s, r in data.stages.items():
        if r.get("kind") != "pareto":
            continue
        terms = r.get("terms") if isinstance(r.get("terms"), list) else None
        # the stage's result holds the front as the optimizer saw it (SI, minimized
        # objectives); the CSV file shows it in the config's units
        if isinstance(r.get("front"), list) and r["front"] and isinstance(r["front"][0], dict):
            head = list(r["front"][0])
            arr = np.array([[_num(row.get(h)) for h in head] for row in r["front"] if isinstance(row, dict)])
        elif f"{s}.csv" in files:
            head, arr = _read_csv(_text(files[f"{s}.csv"], root / f"{s}.csv"))
        elif not current:
            try:
                head, arr = _read_csv(_text(read(f"{s}.csv", None, "the stage finished"), root / f"{s}.csv"))
            except FileNotFoundError:
                continue
        else:
            continue
        data.fronts[s] = _front(s, head, arr, data.units, terms)
    return data


def _check_stages(root: Path, order: list[str], records: dict) -> None:
    """A finished run of the current format records its stages and their
    files; say what is missing (one line) before anything is drawn."""
    sdir = root / "stages"
    if not order:
        raise RunFolderError(f"{root / 'manifest.json'}: records no finished stage; the run folder is incomplete")
    if sdir.is_symlink() or (sdir.exists() and not sdir.is_dir()):
        raise RunFolderError(f"{sdir}: a symbolic link or not a folder; refusing to read through it")
    present = sorted(p.name for p in sdir.iterdir()) if sdir.is_dir() else []
    lost = [s for s in order if s not in present]
    if lost:
        where = f"{sdir} is empty" if sdir.is_dir() and not present else \
            f"{sdir} is missing" if not sdir.is_dir() else f"{sdir} lacks {len(lost)} of them"
        raise RunFolderError(f"{root}: the manifest records {len(order)} finished stage(s) ({', '.join(lost[:4])}"
                             f"{', ...' if len(lost) > 4 else ''}) but {where}; the run folder is incomplete")
    for s in order:
        rec = records.get(s)
        if not isinstance(rec, dict) or not isinstance(rec.get("files"), dict) or not rec["files"]:
            raise RunFolderError(f"{root / 'manifest.json'}: stage {s}: no record of its files")
