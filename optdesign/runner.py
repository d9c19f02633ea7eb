"""Start and resume optimization runs with their reports (used by the commands
and by batches).

Above the optimizer (:mod:`optdesign.optimize`, which knows design vectors and
writes results.json, the stages and their checkpoints) and the reports
(:mod:`optdesign.report`), below the commands: here the two meet, and here a
run's :class:`~optdesign.config.Config` stops.  :func:`run_spec` makes of it
the plain pieces the optimizer reads (:class:`optdesign.optimize.spec.RunSpec`),
:func:`run_outputs` the reports it is handed, bound to what they read (the
config's units; a study's note on the results, ``reference_note``, e.g.
:func:`optdesign.studies.p4s_paper.table3_note`, given by the caller, with
the config).  The run folder gets results.md, its plots, optimum.yaml and
report.html.
"""
from __future__ import annotations

import functools
import os
from pathlib import Path

from .config import Config, parse_config
from .evaluate import Evaluator, workspace_of
from .optimize.outputs import NO_OUTPUTS, RunOutputs
from .optimize.pipeline import PipelineResult, run_pipeline
from .optimize.progress import Progress
from .optimize.spec import RunSpec, RunSubject
from .optimize.workers import StopRequest
from .runs import RunFolder, RunFolderError, run_key
from .units import Units

__all__ = ["start_run", "resume_run", "run_in_folder", "run_spec", "run_outputs", "write_report", "write_html",
           "config_text"]


def run_spec(cfg: Config) -> RunSpec:
    """The plain pieces of a config's run (:class:`~optdesign.optimize.spec.RunSpec`):
    its evaluator over the sampled workspace, its optimizer and checks
    sections, its units and what its results are about."""
    subject = RunSubject(cfg.name, cfg.mechanism, {n: cfg.design(n) for n in cfg.designs}, cfg.reference)
    return RunSpec(Evaluator.from_config(cfg, workspace_of(cfg)), cfg.optimizer, cfg.checks, cfg.units(), subject)


def run_outputs(cfg: Config, reference_note=None) -> RunOutputs:
    """The run folder's reports for :func:`optdesign.optimize.pipeline.run_pipeline`
    (results.md, its plots and CSV files, optimum.yaml, report.html) in the
    config's units, with the caller's ``reference_note(cfg) -> str | None``
    on this config."""
    note = functools.partial(reference_note, cfg) if reference_note is not None else None
    return RunOutputs(reference_note=note, write_report=functools.partial(write_report, cfg.units()),
                      write_html=write_html)


def write_report(units: Units, folder: RunFolder, results: dict, stages: dict) -> None:
    """results.md, optimum.yaml, the top-level CSV files and the plots (:mod:`optdesign.report.md`)."""
    from .report.md import write_report as write

    write(units, folder, results, stages)


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


def run_in_folder(cfg: Config, folder: RunFolder, seed: int, progress: Progress | None = None, pareto: bool = True,
                  stop_after: int | None = None, jobs: int = 1, stop: StopRequest | None = None,
                  reports: bool = True, reference_note=None) -> PipelineResult:
    """Run (or resume) a config's optimization in ``folder`` (made by
    :meth:`RunFolder.create`, or an interrupted run's): the pipeline of its
    :func:`run_spec` with the reports of :func:`run_outputs` (``reports=False``:
    the optimizer's files only).  ``jobs``, ``stop``, ``stop_after``: see
    :func:`optdesign.optimize.pipeline.run_pipeline`."""
    spec, outputs = run_spec(cfg), run_outputs(cfg, reference_note) if reports else NO_OUTPUTS
    return run_pipeline(spec, folder, seed, progress, pareto=pareto, stop_after=stop_after, jobs=jobs, stop=stop,
                        outputs=outputs)


def start_run(cfg: Config, seed: int | None = None, out: str | os.PathLike = "runs", name: str | None = None,
              progress: Progress | None = None, pareto: bool = True, exact_name: bool = False,
              stop_after: int | None = None, jobs: int = 1, stop: StopRequest | None = None,
              reference_note=None) -> PipelineResult:
    """Run a config's optimization in a new run folder under ``out`` (``jobs``:
    processes running its stages at once, see :func:`run_pipeline`;
    ``reference_note``: see :func:`run_outputs`).  The run's pieces are made
    before the folder: a config that cannot run leaves nothing on disk."""
    seed = cfg.optimizer.seed if seed is None else int(seed)
    spec, outputs = run_spec(cfg), run_outputs(cfg, reference_note)
    text = config_text(cfg)
    key = run_key(text, seed, {"pareto": pareto})
    folder = RunFolder.create(out, name or cfg.name, text, seed, key, exact=exact_name, pareto=pareto)
    with folder.lock():        # held for the run's life: a resume of this folder meanwhile is refused
        if stop is not None:
            stop.folder = folder.path
        folder.update_manifest(config_source=cfg.source, config_name=cfg.name)
        return run_pipeline(spec, folder, seed, progress, pareto=pareto, stop_after=stop_after, jobs=jobs, stop=stop,
                            outputs=outputs)


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
    return run_in_folder(cfg, folder, m["seed"], progress, pareto=m["pareto"], stop_after=stop_after,
                         jobs=jobs, stop=stop, reference_note=reference_note)
