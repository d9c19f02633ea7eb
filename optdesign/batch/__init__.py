"""Batches: many runs (configs × sweeps × seeds) on local cores or a Dask cluster,
whose table across them is :mod:`optdesign.report.summary`.

Each run is keyed by a hash of its resolved config text and seed, and lives in
``<out>/<name>-s<seed>-<key>/``: rerunning a batch skips runs that finished and
resumes those that did not (from their last finished generation).

The package, by concern (each layer imports only those before it):

* :mod:`.schema` — batch files (a base config, seeds, a sweep; see
  :func:`load_batch_file` and ``docs/scaling.md``);
* :mod:`.tasks` — planning: one :class:`Task` per resolved config × seed;
* :mod:`.execute` — one task in a worker, many through joblib (loky) or Dask.
"""
from __future__ import annotations

from .execute import BackendError, BatchInterrupted, connect_dask, run_batch, run_task, stop_on_signals
from .schema import BatchFile, is_batch_file, load_batch_file
from .tasks import Task, plan

__all__ = ["Task", "BackendError", "BatchInterrupted", "stop_on_signals", "plan", "load_batch_file", "is_batch_file", "run_task", "run_batch",
           "BatchFile", "connect_dask"]
