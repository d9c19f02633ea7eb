"""Run folders: everything a run leaves on disk, written atomically.

Layout of ``runs/<name>/``::

    config.yaml          the config as run (the file's text)
    manifest.json        status (running | complete | interrupted | failed), seed, run key,
                         package versions, start/end time, wall time, evaluations, stages done
    stages/<stage>/      one folder per GA run: checkpoint.pkl (after every generation),
                         history.csv (per generation), population.csv (final), result.json
    results.json         the optimum and its global indices, the normalization, the paper's values
    results.md           Table 3 and the index table beside the paper's
    pareto_<alg>.csv     Pareto fronts (NSGA-II / NSGA-III)
    convergence.png, pareto.png

Every file is written to a temporary name and renamed, so an interrupted run
never leaves a half file; ``manifest.json`` says whether the run finished.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import pickle
import platform
import secrets
import sys
from pathlib import Path
from typing import Any

from .io import atomic_write_bytes, atomic_write_json, atomic_write_text

__all__ = ["RunFolder", "RunFolderError", "FORMAT_VERSION", "run_key", "package_versions"]

#: version of the run-folder layout; a folder written by another version is refused on resume
FORMAT_VERSION = 1


class RunFolderError(RuntimeError):
    """A run folder that cannot be used (missing, corrupted, from another version)."""


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


def _lookup(module: str, qualname: str):
    """Find a module-level object by name (used when unpickling checkpoints)."""
    import importlib

    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


class _CheckpointPickler(pickle.Pickler):
    """Pickles a pymoo algorithm whole (its random state included).

    pymoo wraps some module-level functions (for example NSGA-II's binary
    tournament) in a decorator whose wrapper is a local function, which the
    standard pickler cannot name.  Such a wrapper is saved as a reference to
    the module attribute that holds it, found through the wrapped function's
    own module and name.
    """

    def reducer_override(self, obj):
        import types

        if type(obj) is _individual_class():
            packed = _pack_individual(obj)
            if packed is not None:
                return packed

        if isinstance(obj, types.FunctionType) and "<locals>" in obj.__qualname__ and obj.__closure__:
            for cell in obj.__closure__:
                try:
                    inner = cell.cell_contents
                except ValueError:
                    continue
                if isinstance(inner, types.FunctionType) and "<locals>" not in inner.__qualname__:
                    try:
                        if _lookup(inner.__module__, inner.__qualname__) is obj:
                            return _lookup, (inner.__module__, inner.__qualname__)
                    except (ImportError, AttributeError):
                        pass
        return NotImplemented


def _individual_class():
    from pymoo.core.individual import Individual

    return Individual


def _pack_individual(ind):
    """A pymoo Individual as one float buffer plus its small dicts: pickling its
    eleven small arrays one by one costs most of a checkpoint's time."""
    import numpy as np

    d = ind.__dict__
    names, shapes, parts, rest = [], [], [], {}
    for k, v in d.items():
        if type(v) is np.ndarray and v.dtype == np.float64:
            names.append(k)
            shapes.append(v.shape)
            parts.append(v.ravel())
        else:
            rest[k] = v
    if not names:
        return None
    flat = np.concatenate(parts) if len(parts) > 1 else parts[0].copy()
    return _unpack_individual, (tuple(names), tuple(shapes), flat.tobytes(), rest)


def _unpack_individual(names, shapes, buf, rest):
    import numpy as np

    ind = _individual_class().__new__(_individual_class())
    flat = np.frombuffer(buf, dtype=np.float64)
    pos = 0
    for k, shape in zip(names, shapes):
        n = int(np.prod(shape)) if shape else 1
        ind.__dict__[k] = flat[pos:pos + n].reshape(shape).copy()
        pos += n
    ind.__dict__.update(rest)
    return ind


def dumps(obj: Any) -> bytes:
    """Pickle a checkpoint (see _CheckpointPickler)."""
    import io

    buf = io.BytesIO()
    _CheckpointPickler(buf, protocol=pickle.HIGHEST_PROTOCOL).dump(obj)
    return buf.getvalue()


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


class RunFolder:
    """A run folder on disk."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)

    # ------------------------------------------------------------------ creation
    @classmethod
    def create(cls, parent: str | os.PathLike, name: str, config_text: str, seed: int, key: str,
               exact: bool = False, command: list[str] | None = None) -> "RunFolder":
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
        if exact:
            path = parent / name
            try:
                check_inside(parent, path)
            except OutsideRoot as exc:
                raise RunFolderError(str(exc)) from None
            path.mkdir()
        else:
            stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
            while True:
                path = parent / f"{name}-s{seed}-{stamp}-{secrets.token_hex(2)}"
                try:
                    check_inside(parent, path)
                except OutsideRoot as exc:
                    raise RunFolderError(str(exc)) from None
                try:
                    path.mkdir()
                    break
                except FileExistsError:
                    continue
        rf = cls(path)
        atomic_write_text(path / "config.yaml", config_text)
        rf.write_manifest({
            "format_version": FORMAT_VERSION,
            "status": "running",
            "seed": seed,
            "run_key": key,
            "name": name,
            "command": command or sys.argv,
            "versions": package_versions(),
            "machine": {"platform": platform.platform(), "cpus": os.cpu_count()},
            "start_time": _now(),
            "end_time": None,
            "wall_time_s": 0.0,
            "evaluations": 0,
            "stages_done": [],
        })
        return rf

    # ------------------------------------------------------------------ manifest
    @property
    def manifest_path(self) -> Path:
        return self.path / "manifest.json"

    def read_manifest(self) -> dict:
        if not self.path.is_dir():
            raise RunFolderError(f"{self.path}: not a run folder (no such directory)")
        try:
            m = json.loads(self.manifest_path.read_text())
        except FileNotFoundError:
            raise RunFolderError(f"{self.path}: not a run folder (no manifest.json)") from None
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise RunFolderError(f"{self.manifest_path}: corrupted (not valid JSON)") from None
        if not isinstance(m, dict):
            raise RunFolderError(f"{self.manifest_path}: corrupted (not a JSON object)")
        fv = m.get("format_version")
        if fv != FORMAT_VERSION:
            raise RunFolderError(f"{self.path}: run folder format version {fv!r}; this optdesign reads version {FORMAT_VERSION}")
        return m

    def write_manifest(self, m: dict) -> None:
        atomic_write_json(self.manifest_path, m)

    def update_manifest(self, **kw) -> dict:
        m = self.read_manifest()
        m.update(kw)
        self.write_manifest(m)
        return m

    def config_text(self) -> str:
        try:
            return (self.path / "config.yaml").read_text()
        except FileNotFoundError:
            raise RunFolderError(f"{self.path}: not a run folder (no config.yaml)") from None

    # ------------------------------------------------------------------ stages
    def stage_dir(self, stage: str) -> Path:
        d = self.path / "stages" / stage
        d.mkdir(parents=True, exist_ok=True)
        return d

    def save_checkpoint(self, stage: str, obj: Any) -> None:
        atomic_write_bytes(self.stage_dir(stage) / "checkpoint.pkl", dumps({"format_version": FORMAT_VERSION, "state": obj}),
                           durable=False)

    def load_checkpoint(self, stage: str) -> Any | None:
        p = self.path / "stages" / stage / "checkpoint.pkl"
        if not p.exists():
            return None
        try:
            data = pickle.loads(p.read_bytes())
        except Exception as exc:  # noqa: BLE001 - any unpickling failure means a corrupted file
            raise RunFolderError(f"{p}: corrupted checkpoint ({type(exc).__name__}); delete the stage folder to restart that stage") from None
        if not isinstance(data, dict) or data.get("format_version") != FORMAT_VERSION:
            raise RunFolderError(f"{p}: checkpoint from another optdesign version; delete the stage folder to restart that stage")
        return data["state"]

    def stage_result(self, stage: str) -> dict | None:
        p = self.path / "stages" / stage / "result.json"
        if not p.exists():
            return None
        try:
            return json.loads(p.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise RunFolderError(f"{p}: corrupted (not valid JSON)") from None

    def write_stage_result(self, stage: str, result: dict, manifest: bool = True) -> None:
        """The stage's result.json; with ``manifest`` also lists the stage as done
        in the manifest (a stage worker process leaves that to the main process,
        the manifest's only writer)."""
        atomic_write_json(self.stage_dir(stage) / "result.json", result)
        if manifest:
            self.mark_stage_done(stage)

    def mark_stage_done(self, stage: str) -> None:
        m = self.read_manifest()
        if stage not in m["stages_done"]:
            m["stages_done"].append(stage)
        self.write_manifest(m)

    def write_text(self, rel: str, text: str) -> None:
        atomic_write_text(self.path / rel, text)

    def write_json(self, rel: str, obj: Any) -> None:
        atomic_write_json(self.path / rel, obj)
