"""Task planning: one task per resolved config × seed, keyed by a hash of both.

A task holds everything a worker needs (the resolved config text, the seed,
the run key), so running it needs no access to the files it came from.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

from ..config import ConfigError, load_config, parse_config
from ..runs import run_key
from .schema import is_batch_file, load_batch_file

__all__ = ["Task", "plan", "MAX_RUNS"]

#: the most runs one batch may plan (configs x sweep combinations x seeds)
MAX_RUNS = 100_000


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
        if len(tasks) + len(seed_list) > MAX_RUNS:      # before the tasks are made
            raise ConfigError(source, "seeds", f"the batch would hold more than {MAX_RUNS:,} runs (configs x seeds); "
                                               "split it")
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
                cfg.check_optimizable(pareto=par)
                add(name, text, str(path), _seeds(cfg, n_seeds, seeds, bf.seeds), par, sweep)
        else:
            cfg = load_config(path)
            cfg.check_optimizable(pareto=bool(pareto))
            add(cfg.name, cfg.text, str(path), _seeds(cfg, n_seeds, seeds, None), bool(pareto), {})
    return tasks


def _seeds(cfg, n_seeds, seeds, file_seeds) -> list[int]:
    if seeds:
        return list(seeds)
    if n_seeds:
        return [cfg.optimizer.seed + i for i in range(n_seeds)]
    if file_seeds:
        return list(file_seeds)
    return [cfg.optimizer.seed]
