"""Start, resume and summarize optimization runs (used by the CLI and by batches)."""
from __future__ import annotations

import os
from pathlib import Path

from ..config import Config, parse_config
from ..runs import RunFolder, RunFolderError, run_key
from .pipeline import PipelineResult, run_pipeline
from .progress import Progress
from .workers import StopRequest

__all__ = ["start_run", "resume_run", "summary_line", "config_text", "config_of_folder"]


def config_text(cfg: Config) -> str:
    """The text of the config as run (the file as given; for a config built
    from a mapping in Python, that mapping as YAML, which reads back to the same config)."""
    if cfg.text is not None:
        return cfg.text
    if cfg.source.startswith("<"):   # config_from_dict / parse_config of a text without a file
        from ..config.yamlsafe import dump

        return dump(cfg.raw, sort_keys=False)
    src = Path(cfg.source)
    if src.exists():
        return src.read_text()
    from importlib.resources import files

    return (files("optdesign") / "data" / src.name).read_text()


def start_run(cfg: Config, seed: int | None = None, out: str | os.PathLike = "runs", name: str | None = None,
              progress: Progress | None = None, pareto: bool = True, exact_name: bool = False,
              stop_after: int | None = None, jobs: int = 1, stop: StopRequest | None = None) -> PipelineResult:
    """Run a config's optimization in a new run folder under ``out`` (``jobs``:
    processes running its stages at once, see :func:`run_pipeline`)."""
    seed = cfg.optimizer.seed if seed is None else int(seed)
    text = config_text(cfg)
    key = run_key(text, seed, {"pareto": pareto})
    folder = RunFolder.create(out, name or cfg.name, text, seed, key, exact=exact_name, pareto=pareto)
    with folder.lock():        # held for the run's life: a resume of this folder meanwhile is refused
        if stop is not None:
            stop.folder = folder.path
        folder.update_manifest(config_source=cfg.source, config_name=cfg.name)
        return run_pipeline(cfg, folder, seed, progress, pareto=pareto, stop_after=stop_after, jobs=jobs, stop=stop)


def resume_run(path: str | os.PathLike, progress: Progress | None = None, stop_after: int | None = None,
               jobs: int = 1, stop: StopRequest | None = None) -> PipelineResult:
    """Finish an interrupted run in its own folder (completed stages are kept,
    once the folder is checked against its manifest)."""
    folder = RunFolder(path)
    folder.read_manifest()              # a folder that is no run folder gets no run.lock
    with folder.lock():                 # one run at a time in a folder: a second resume is refused
        return _resume_locked(folder, progress, stop_after, jobs, stop)


def _resume_locked(folder: RunFolder, progress, stop_after, jobs, stop) -> PipelineResult:
    m = folder.read_manifest()
    if stop is not None:
        stop.folder = folder.path
    if m["status"] == "complete" and (folder.path / "results.json").exists():
        folder.verify_inputs(write=False)
        res = folder.results()
        if not all(k in res for k in ("status", "seed", "objective", "optimum", "global_indices")):
            raise RunFolderError(f"{folder.path / 'results.json'}: not the results of a run")
        return PipelineResult(folder, res)
    folder.verify_inputs(write=False)   # before the config is parsed: it must be the one run
    cfg = parse_config(folder.config_text(), source=str(folder.path / "config.yaml"), run_folder=True)
    cfg.name = m.get("config_name") or m.get("name") or cfg.name
    return run_pipeline(cfg, folder, m["seed"], progress, pareto=m["pareto"], stop_after=stop_after,
                        jobs=jobs, stop=stop)


def config_of_folder(path: str | os.PathLike) -> Config:
    """The config a run folder was run with (its config.yaml, the safe loader)."""
    folder = RunFolder(path)
    cfg = parse_config(folder.config_text(), source=str(folder.path / "config.yaml"), run_folder=True)
    name = folder.read_manifest(strict=False).get("config_name")
    if isinstance(name, str) and name:
        cfg.name = name
    return cfg


def summary_line(res: PipelineResult, cfg: Config | None = None, wall: float | None = None) -> str:
    """One line: the run folder, its status, f, the global indices and the
    optimum (in the config's units with the unit named); ``wall``: the whole
    run's wall time (default: the recorded one, which ends before the report)."""
    from ..units import design_text, index_text

    r = res.results
    if cfg is None:
        cfg = config_of_folder(res.folder.path)
    opt = design_text(cfg, r["optimum"]) or "no free variable"
    idx = ", ".join(index_text(cfg, k, v) for k, v in r["global_indices"].items() if k in cfg.indices)
    f = r["objective"]
    f_txt = "0 (to round-off)" if abs(f) < 1e-12 else f"{f:.6g}"
    return (f"{res.folder.path}: {r['status']} seed={r['seed']} objective f={f_txt} "
            f"[{idx}] at {opt} ({r.get('evaluations', '?')} evaluations, "
            f"{f'{wall:.1f}' if wall is not None else r.get('wall_time_s', '?')} s)")
