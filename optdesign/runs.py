"""Run folders: everything a run leaves on disk, written atomically, bound to its inputs.

Layout of ``runs/<name>/``::

    config.yaml          the config as run (the file's text)
    manifest.json        status (running | complete | interrupted | failed), seed, run key,
                         run id, SHA-256 of config.yaml, package versions, start/end time,
                         wall time, evaluations, stages done with the SHA-256 of their files
    stages/<stage>/      one folder per GA run: checkpoint.npz (data only: JSON and arrays),
                         history.csv (per generation), population.csv (final), result.json
    results.json         the optimum and its global indices, the normalization, the paper's values
    results.md           Table 3 and the index table beside the paper's
    pareto_<alg>.csv     Pareto fronts (NSGA-II / NSGA-III)
    run.lock             flock of the process running in the folder (its pid and host)
    convergence.png, pareto.png

Every file is written to a temporary name and renamed, so an interrupted run
never leaves a half file; ``manifest.json`` says whether the run finished.

Nothing read from a run folder is executed: checkpoints are JSON and numpy
arrays read without pickle (:mod:`optdesign.datafile`).  A resume checks the
folder against its manifest first (:meth:`RunFolder.verify_inputs`) and
refuses, naming the file, a config.yaml that changed, a seed that changed, a
file of a finished stage that changed and a checkpoint of another stage or run.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import math
import os
import platform
import secrets
import sys
from pathlib import Path
from typing import Any

from . import datafile
from .io import FileLock, LockHeld, UnsafeSource, atomic_write_bytes, atomic_write_json, atomic_write_text, read_no_links

__all__ = ["RunFolder", "RunFolderError", "FORMAT_VERSION", "run_key", "package_versions"]

#: version of the run-folder layout; a folder written by another version is refused on resume
FORMAT_VERSION = 2
#: largest JSON file (manifest, results) and config.yaml read from a run folder (bytes)
MAX_JSON = 64 * 2 ** 20
MAX_CONFIG = 4 * 2 ** 20
CHECKPOINT = "checkpoint.npz"
STATUSES = ("running", "complete", "interrupted", "failed")


class RunFolderError(RuntimeError):
    """A run folder that cannot be used (missing, corrupted, changed, from another version)."""


def package_versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    out = {"python": platform.python_version()}
    for pkg in ("optdesign", "numpy", "scipy", "pymoo", "casadi", "joblib", "pyyaml", "numba", "matplotlib"):
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            pass
    return out


def run_key(config_text: str, seed: int, extra: dict | None = None) -> str:
    """A short hash of the resolved config and the seed: the identity of a run."""
    h = hashlib.sha256()
    h.update(config_text.encode("utf-8"))
    h.update(f"\nseed={seed}".encode())
    if extra:
        h.update(json.dumps(extra, sort_keys=True, default=str).encode())
    return h.hexdigest()[:12]


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _binding(run_id: str, config_sha: str, seed: int, pareto: bool) -> str:
    return _sha256(json.dumps([run_id, config_sha, int(seed), bool(pareto)]).encode())[:32]


def _read_bytes(path: Path, limit: int, root: Path | None = None) -> bytes:
    """A regular file's bytes (at most ``limit``), never through a symbolic link (io.read_no_links)."""
    try:
        return read_no_links(path, limit, root)
    except UnsafeSource as exc:
        raise RunFolderError(str(exc)) from None
    except OSError as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise RunFolderError(f"{path}: cannot be read ({exc.strerror})") from None


def _read_json(path: Path, root: Path | None = None, data: bytes | None = None) -> Any:
    """The JSON value of a file (or of its ``data`` already read)."""
    try:
        return json.loads((_read_bytes(path, MAX_JSON, root) if data is None else data).decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise RunFolderError(f"{path}: corrupted (not valid JSON)") from None


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _check_manifest(m: Any, path: Path) -> dict:
    if not isinstance(m, dict):
        raise RunFolderError(f"{path}: corrupted (not a JSON object)")
    fv = m.get("format_version")
    if fv != FORMAT_VERSION:
        shown = fv if _is_int(fv) and abs(fv) < 10 ** 6 else type(fv).__name__
        raise RunFolderError(f"{path.parent}: run folder format version {shown!r}; this optdesign reads version {FORMAT_VERSION}")
    checks = {
        "status": (lambda v: v in STATUSES, f"one of {', '.join(STATUSES)}"),
        "seed": (lambda v: _is_int(v) and 0 <= v < 2 ** 32, "an integer in [0, 2^32)"),
        "run_id": (lambda v: isinstance(v, str) and len(v) == 16, "a run id"),
        "config_sha256": (lambda v: isinstance(v, str) and len(v) == 64, "a SHA-256"),
        "binding": (lambda v: isinstance(v, str) and len(v) == 32, "a binding hash"),
        "wall_time_s": (lambda v: (_is_int(v) or isinstance(v, float)) and math.isfinite(v) and v >= 0,
                        "a number of seconds"),
        "evaluations": (lambda v: _is_int(v) and v >= 0, "a non-negative integer"),
        "stages_done": (lambda v: isinstance(v, list) and all(isinstance(s, str) for s in v), "a list of stage names"),
        "stages": (lambda v: isinstance(v, dict) and all(isinstance(r, dict) and isinstance(r.get("files"), dict)
                                                         for r in v.values()), "stage records"),
        "checkpoints": (lambda v: isinstance(v, dict) and all(isinstance(h, str) for h in v.values()), "checkpoint hashes"),
        "pareto": (lambda v: isinstance(v, bool), "true or false"),
    }
    for key, (ok, what) in checks.items():
        if key not in m:
            raise RunFolderError(f"{path}: corrupted (no {key!r})")
        if not ok(m[key]):
            raise RunFolderError(f"{path}: {key}: expected {what}")
    return m


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


class RunFolder:
    """A run folder on disk."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self._binding: dict | None = None

    # ------------------------------------------------------------------ creation
    @classmethod
    def create(cls, parent: str | os.PathLike, name: str, config_text: str, seed: int, key: str,
               exact: bool = False, command: list[str] | None = None, pareto: bool = True) -> "RunFolder":
        """Make a new folder under ``parent``.  The folder is created with an
        exclusive ``mkdir``: two runs started at the same moment never share one.
        With ``exact`` the name is used as is (and must not exist).  The name
        must be a safe folder name (optdesign.names) and the folder must lie
        inside ``parent`` once symbolic links are resolved (RunFolderError)."""
        from .names import OutsideRoot, check_inside, name_problem

        problem = name_problem(name, max_len=200)
        if problem:
            raise RunFolderError(f"run folder name: {problem}")
        parent = Path(parent)
        parent.mkdir(parents=True, exist_ok=True)
        stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
        while True:
            path = parent / (name if exact else f"{name}-s{seed}-{stamp}-{secrets.token_hex(2)}")
            try:
                check_inside(parent, path)
            except OutsideRoot as exc:
                raise RunFolderError(str(exc)) from None
            try:
                path.mkdir()
                break
            except FileExistsError:
                if exact:       # the exact name must not exist
                    raise
        rf = cls(path)
        atomic_write_text(path / "config.yaml", config_text)
        run_id, sha = secrets.token_hex(8), _sha256(config_text.encode("utf-8"))
        rf.write_manifest({
            "format_version": FORMAT_VERSION, "status": "running", "seed": seed, "run_key": key, "run_id": run_id,
            "config_sha256": sha, "binding": _binding(run_id, sha, seed, pareto), "pareto": bool(pareto), "name": name,
            "command": command or sys.argv, "versions": package_versions(),
            "machine": {"platform": platform.platform(), "cpus": os.cpu_count()},
            "start_time": _now(), "end_time": None, "wall_time_s": 0.0, "evaluations": 0,
            "stages_done": [], "stages": {}, "checkpoints": {},
        })
        return rf

    def lock(self) -> FileLock:
        """The folder's exclusive lock (io.FileLock on ``run.lock``: a flock, the file holding the holder's pid
        and host), held for a run's whole life; RunFolderError naming the holder if another process has it."""
        try:
            return FileLock(self.path / "run.lock")
        except LockHeld as exc:
            raise RunFolderError(f"{self.path}: already running ({exc}); wait for that run to end or stop it") from None
        except UnsafeSource as exc:
            raise RunFolderError(f"{exc}; the run folder cannot be locked") from None

    # ------------------------------------------------------------------ manifest
    @property
    def manifest_path(self) -> Path:
        return self.path / "manifest.json"

    def read_manifest(self, strict: bool = True) -> dict:
        """The manifest, checked key by key; ``strict=False`` (summaries, read
        only) also takes one of the previous format version as it is."""
        if not self.path.is_dir():
            raise RunFolderError(f"{self.path}: not a run folder (no such directory)")
        try:
            m = _read_json(self.manifest_path, self.path)
        except FileNotFoundError:
            raise RunFolderError(f"{self.path}: not a run folder (no manifest.json)") from None
        if not strict and isinstance(m, dict) and m.get("format_version") == FORMAT_VERSION - 1:
            return m
        return _check_manifest(m, self.manifest_path)

    def write_manifest(self, m: dict) -> None:
        atomic_write_json(self.manifest_path, m)

    def update_manifest(self, **kw) -> dict:
        """Change manifest fields (a new seed or ``pareto`` is bound anew)."""
        m = self.read_manifest()
        m.update(kw)
        if {"seed", "pareto"} & set(kw):
            m["binding"] = _binding(m["run_id"], m["config_sha256"], m["seed"], m["pareto"])
        self.write_manifest(m)
        return m

    def config_text(self) -> str:
        p = self.path / "config.yaml"
        try:
            return _read_bytes(p, MAX_CONFIG, self.path).decode("utf-8")
        except FileNotFoundError:
            raise RunFolderError(f"{self.path}: not a run folder (no config.yaml)") from None
        except UnicodeDecodeError:
            raise RunFolderError(f"{p}: not UTF-8 text") from None

    # ------------------------------------------------------------------ binding
    def verify_inputs(self, seed: int | None = None, write: bool = True) -> dict:
        """Check the folder against its manifest before a run (re)starts in it
        (or a finished one is reported): config.yaml as run, the binding of run
        id, config, seed and ``pareto`` (and ``seed``, if given, is the run's),
        every file of a finished stage and every checkpoint recorded at an
        interruption.  Returns the manifest (with ``write``, its record of
        interrupted checkpoints cleared: the run goes on from them)."""
        m, cp = self.read_manifest(), self.path / "config.yaml"
        if _sha256(self.config_text().encode("utf-8")) != m["config_sha256"]:
            raise RunFolderError(f"{cp}: changed since the run started (its SHA-256 is not the manifest's "
                                 "config_sha256); put the original back or start a new run")
        if _binding(m["run_id"], m["config_sha256"], m["seed"], m["pareto"]) != m["binding"]:
            raise RunFolderError(f"{self.manifest_path}: seed or pareto changed since the run started "
                                 "(the binding does not match); start a new run instead")
        if seed is not None and seed != m["seed"]:
            raise RunFolderError(f"{self.manifest_path}: the run's seed is {m['seed']}, not {seed}")
        st = self.path / "stages"
        if st.exists() and (st.is_symlink() or not st.is_dir()):
            raise RunFolderError(f"{st}: not a directory")
        for p in [*self.path.iterdir(), *st.glob("*"), *st.glob("*/*")]:   # writes stay inside the folder
            if p.is_symlink():
                raise RunFolderError(f"{p}: a symbolic link (a run folder holds none)")
        for rec in m["stages"].values():
            self._verify_files(rec["files"], "the stage finished")
        for rel, want in m["checkpoints"].items():  # a deleted one restarts its stage
            p = self._file(rel)
            if p.exists() and self._sha(p) != want:
                raise RunFolderError(f"{p}: corrupted checkpoint (changed since the run was interrupted); "
                                     f"delete {p.parent} to restart that stage")
        if write:
            m["checkpoints"] = {}
            self.write_manifest(m)
        self._binding = {"run_id": m["run_id"], "config_sha256": m["config_sha256"], "seed": m["seed"]}
        return m

    def _file(self, rel) -> Path:
        if not isinstance(rel, str) or ".." in Path(rel).parts or Path(rel).is_absolute():
            raise RunFolderError(f"{self.manifest_path}: a file record names {str(rel)[:80]!r}")
        return self.path / rel

    def _sha(self, p: Path) -> str:
        return _sha256(_read_bytes(p, datafile.MAX_BYTES, self.path))

    def read_recorded(self, rel: str, want: str | None, since: str, limit: int = datafile.MAX_BYTES) -> bytes:
        """File ``rel``'s bytes, read once (no link) and checked against the recorded SHA-256 ``want`` (None: none)."""
        p = self._file(rel)
        try:
            data = _read_bytes(p, limit, self.path)
        except FileNotFoundError:
            raise RunFolderError(f"{p}: missing (the manifest records it)") from None
        if want is not None and _sha256(data) != want:
            raise RunFolderError(f"{p}: changed since {since} (its SHA-256 is not the manifest's)")
        return data

    def _verify_files(self, files: dict, since: str) -> None:
        for rel, want in files.items():
            self.read_recorded(rel, want if isinstance(want, str) else "", since)

    def _hashes(self, rels) -> dict[str, str]:
        return {rel: self._sha(self.path / rel) for rel in rels
                if (self.path / rel).is_file() and not (self.path / rel).is_symlink()}

    def binding(self) -> dict:
        """What a checkpoint of this folder must carry: run id, config hash, seed."""
        if self._binding is None:
            m = self.read_manifest()
            self._binding = {"run_id": m["run_id"], "config_sha256": m["config_sha256"], "seed": m["seed"]}
        return self._binding

    # ------------------------------------------------------------------ stages
    def stage_dir(self, stage: str) -> Path:
        d = self.path / "stages" / stage
        try:
            d.mkdir(parents=True, exist_ok=True)
        except (FileExistsError, NotADirectoryError):
            raise RunFolderError(f"{d}: not a directory") from None
        return d

    def checkpoint_path(self, stage: str) -> Path:
        return self.path / "stages" / stage / CHECKPOINT

    def save_checkpoint(self, stage: str, meta: dict, arrays: dict) -> None:
        meta = {"format": "optdesign-checkpoint", "format_version": FORMAT_VERSION, "stage": stage,
                **self.binding(), **meta}
        atomic_write_bytes(self.stage_dir(stage) / CHECKPOINT, datafile.dumps(meta, arrays), durable=False)

    def load_checkpoint(self, stage: str) -> tuple[dict, dict] | None:
        """``(meta, arrays)`` of a stage's checkpoint, or None if it has none.
        The file is data only; one of another format, stage or run is refused."""
        p = self.checkpoint_path(stage)
        hint = f"delete {p.parent} to restart that stage"
        try:
            meta, arrays = datafile.read(p)
        except FileNotFoundError:
            return None
        except datafile.DataFileError as exc:
            raise RunFolderError(f"{p}: corrupted checkpoint ({exc}); {hint}") from None
        if meta.get("format") != "optdesign-checkpoint" or meta.get("format_version") != FORMAT_VERSION:
            raise RunFolderError(f"{p}: checkpoint of another format or optdesign version; {hint}")
        b = self.binding()
        if meta.get("run_id") != b["run_id"] or meta.get("config_sha256") != b["config_sha256"] \
                or meta.get("seed") != b["seed"]:
            raise RunFolderError(f"{p}: checkpoint written by another run (run id, config or seed differ); {hint}")
        if meta.get("stage") != stage:
            raise RunFolderError(f"{p}: checkpoint of another stage; {hint}")
        return meta, arrays

    def stage_result(self, stage: str) -> dict | None:
        """The result of a stage the manifest records as finished (its files
        unchanged), else None: a stage not recorded is run again."""
        rec = self.read_manifest()["stages"].get(stage)
        if rec is None:
            return None
        self._verify_files(rec["files"], "the stage finished")
        p = self.path / "stages" / stage / "result.json"
        res = _read_json(p, self.path)
        if not isinstance(res, dict) or res.get("stage") != stage:
            raise RunFolderError(f"{p}: not the result of stage {stage}")
        return res

    def stage_record(self, stage: str) -> dict | None:
        """The manifest's record of a finished stage (seed, kind, file hashes)."""
        return self.read_manifest()["stages"].get(stage)

    def write_stage_result(self, stage: str, result: dict, manifest: bool = True, record: dict | None = None,
                           also: tuple[str, ...] = ()) -> None:
        """The stage's result.json; with ``manifest`` also records the stage as
        done in the manifest (a stage worker process leaves that to the main
        process, the manifest's only writer)."""
        atomic_write_json(self.stage_dir(stage) / "result.json", result)
        if manifest:
            self.mark_stage_done(stage, record, also)

    def mark_stage_done(self, stage: str, record: dict | None = None, also: tuple[str, ...] = ()) -> None:
        """Record a finished stage with the SHA-256 of its files (those in its
        folder and ``also``, paths relative to the run folder)."""
        m = self.read_manifest()
        rels = [f"stages/{stage}/{f}" for f in ("result.json", "history.csv", "population.csv", CHECKPOINT)]
        m["stages"][stage] = {**(record or {}), "files": self._hashes(rels + list(also))}
        if stage not in m["stages_done"]:
            m["stages_done"].append(stage)
        self.write_manifest(m)

    def record_checkpoints(self, stages, **fields) -> dict:
        """At an interruption: the SHA-256 of the checkpoints of the unfinished
        ``stages`` go into the manifest (a resume refuses them changed), with ``fields``."""
        m = self.read_manifest()
        m.update(fields)
        m["checkpoints"] = self._hashes(f"stages/{s}/{CHECKPOINT}" for s in stages if s not in m["stages"])
        self.write_manifest(m)
        return m

    def complete(self, **fields) -> dict:
        """Mark the run complete (after results.json is written; its SHA-256 is recorded)."""
        m = self.read_manifest()
        m.update(status="complete", end_time=_now(), **fields)
        m["results_sha256"] = self._hashes(["results.json"])["results.json"]
        self.write_manifest(m)
        return m

    def results(self) -> dict:
        """results.json of a complete run, checked against the manifest."""
        m = self.read_manifest()
        p = self.path / "results.json"
        res = _read_json(p, data=self.read_recorded("results.json", m.get("results_sha256", ""), "the run completed",
                                                    MAX_JSON))
        if not isinstance(res, dict):
            raise RunFolderError(f"{p}: not a JSON object")
        return res

    def write_text(self, rel: str, text: str) -> None:
        atomic_write_text(self.path / rel, text)

    def write_json(self, rel: str, obj: Any) -> None:
        atomic_write_json(self.path / rel, obj)
