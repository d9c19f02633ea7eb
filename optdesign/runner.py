"""Start and resume optimization runs with their reports (used by the commands
and by batches).

Above the optimizer (:mod:`optdesign.optimize`, which knows design vectors and
writes results.json, the stages and their checkpoints) and the reports
(:mod:`optdesign.report`), below the commands: here the two meet.  The run
folder gets results.md, its plots, optimum.yaml and report.html; a study's
note on the results (``reference_note``, e.g.
:func:`optdesign.studies.p4s_paper.table3_note`) is given by the caller.
"""
from __future__ import annotations

import os
from pathlib import Path

from .config import Config, parse_config
from .optimize.outputs import RunOutputs
from .optimize.pipeline import PipelineResult, run_pipeline
from .optimize.progress import Progress
from .optimize.workers import StopRequest
from .runs import RunFolder, RunFolderError, run_key

__all__ = ["start_run", "resume_run", "run_outputs", "write_report", "write_html", "config_text"]


def run_outputs(reference_note=None) -> RunOutputs:
    """The run folder's reports for :func:`optdesign.optimize.pipeline.run_pipeline`
    (results.md, its plots and CSV files, optimum.yaml, report.html), with the
    caller's ``reference_note(cfg) -> str | None``."""
    return RunOutputs(reference_note=reference_note, write_report=write_report, write_html=write_html)


def write_report(cfg: Config, folder: RunFolder, results: dict, stages: dict) -> None:
    """results.md, optimum.yaml, the top-level CSV files and the plots (:mod:`optdesign.report.md`)."""
    from .report.md import write_report as write

    write(cfg, folder, results, stages)


def write_html(folder: RunFolder) -> None:
    """report.html of the finished run; a failure is written down, never loses the run."""
    try:
        from .report.html import write_report_html

        write_report_html(folder.path)
    except Exception as exc:  # noqa: BLE001
        folder.write_text("report-error.txt", f"{type(exc).__name__}: {exc}\n")


def config_text(cfg: Config) -> str:
    """The text of the config as run (the file as given; for a config built
    from a mapping in Python, that mapping as YAML, which reads back to the same config)."""
    if cfg.text is not None:
        return cfg.text
    if cfg.source.startswith("<"):   # config_from_dict / parse_config of a text without a file
        from .config.yamlsafe import dump

        return dump(cfg.raw, sort_keys=False)
    src = Path(cfg.source)
    if src.exists():
        return src.read_text()
    from importlib.resources import files

    return (files("optdesign") / "data" / src.name).read_text()


def start_run(cfg: Config, seed: int | None = None, out: str | os.PathLike = "runs", name: str | None = None,
              progress: Progress | None = None, pareto: bool = True, exact_name: bool = False,
              stop_after: int | None = None, jobs: int = 1, stop: StopRequest | None = None,
              reference_note=None) -> PipelineResult:
    """Run a config's optimization in a new run folder under ``out`` (``jobs``:
    processes running its stages at once, see :func:`run_pipeline`;
    ``reference_note``: see :func:`run_outputs`)."""
    seed = cfg.optimizer.seed if seed is None else int(seed)
    text = config_text(cfg)
    key = run_key(text, seed, {"pareto": pareto})
    folder = RunFolder.create(out, name or cfg.name, text, seed, key, exact=exact_name, pareto=pareto)
    with folder.lock():        # held for the run's life: a resume of this folder meanwhile is refused
        if stop is not None:
            stop.folder = folder.path
        folder.update_manifest(config_source=cfg.source, config_name=cfg.name)
        return run_pipeline(cfg, folder, seed, progress, pareto=pareto, stop_after=stop_after, jobs=jobs, stop=stop,
                            outputs=run_outputs(reference_note))


def resume_run(path: str | os.PathLike, progress: Progress | None = None, stop_after: int | None = None,
               jobs: int = 1, stop: StopRequest | None = None, reference_note=None) -> PipelineResult:
    """Finish an interrupted run in its own folder (completed stages are kept,
    once the folder is checked against its manifest)."""
    folder = RunFolder(path)
    folder.read_manifest()              # a folder that is no run folder gets no run.lock
    with folder.lock():                 # one run at a time in a folder: a second resume is refused
        return _resume_locked(folder, progress, stop_after, jobs, stop, reference_note)


def _resume_locked(folder: RunFolder, progress, stop_after, jobs, stop, reference_note) -> PipelineResult:
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
                        jobs=jobs, stop=stop, outputs=run_outputs(reference_note))
