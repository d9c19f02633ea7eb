"""Start, resume and summarize optimization runs (used by the CLI and by batches)."""
from __future__ import annotations

import os
from pathlib import Path

from ..config import Config, parse_config
from ..runs import RunFolder, RunFolderError, run_key
from .pipeline import PipelineResult, Progress, run_pipeline

__all__ = ["start_run", "resume_run", "summary_line", "config_text"]


def config_text(cfg: Config) -> str:
    """The text of the config as run (the file as given)."""
    src = Path(cfg.source)
    if src.exists():
        return src.read_text()
    from importlib.resources import files

    return (files("optdesign") / "data" / src.name).read_text()


def start_run(cfg: Config, seed: int | None = None, out: str | os.PathLike = "runs", name: str | None = None,
              progress: Progress | None = None, pareto: bool = True, exact_name: bool = False,
              stop_after: int | None = None, jobs: int = 1) -> PipelineResult:
    """Run a config's optimization in a new run folder under ``out`` (``jobs``:
    processes running its stages at once, see :func:`run_pipeline`)."""
    seed = cfg.optimizer.seed if seed is None else int(seed)
    text = config_text(cfg)
    key = run_key(text, seed, {"pareto": pareto})
    folder = RunFolder.create(out, name or cfg.name, text, seed, key, exact=exact_name)
    folder.update_manifest(pareto=pareto, config_source=cfg.source, config_name=cfg.name)
    return run_pipeline(cfg, folder, seed, progress, pareto=pareto, stop_after=stop_after, jobs=jobs)


def resume_run(path: str | os.PathLike, progress: Progress | None = None, stop_after: int | None = None,
               jobs: int = 1) -> PipelineResult:
    """Finish an interrupted run in its own folder (completed stages are kept)."""
    folder = RunFolder(path)
    m = folder.read_manifest()
    text = folder.config_text()
    cfg = parse_config(text, source=str(folder.path / "config.yaml"))
    cfg.name = m.get("config_name") or m.get("name") or cfg.name
    if m.get("status") == "complete" and (folder.path / "results.json").exists():
        import json

        return PipelineResult(folder, json.loads((folder.path / "results.json").read_text()))
    if "seed" not in m or not isinstance(m["seed"], int):
        raise RunFolderError(f"{folder.manifest_path}: corrupted (no integer 'seed')")
    return run_pipeline(cfg, folder, m["seed"], progress, pareto=bool(m.get("pareto", True)), stop_after=stop_after,
                        jobs=jobs)


def summary_line(res: PipelineResult) -> str:
    r = res.results
    opt = ", ".join(f"{k}={v:.6g}" for k, v in r["optimum"].items())
    idx = ", ".join(f"{k}={v:.5g}" for k, v in r["global_indices"].items())
    return (f"{res.folder.path}: {r['status']} seed={r['seed']} objective={r['objective']:.6g} "
            f"[{idx}] at {opt} ({r.get('evaluations', '?')} evaluations, {r.get('wall_time_s', '?')} s)")
