"""One GA stage, run by pymoo's own loop (``algorithm.run()``) with a Callback.

The algorithm runs to its Termination (``("n_gen", generations)``); after
each generation :class:`StageCallback` calls the algorithm's own callbacks
(the paper GA's adaptive mutation), appends the history row, feeds the
progress bar, writes a data-only checkpoint once ``checkpoint_interval``
seconds have passed since the last one (and always before a stop), and ends
the run with :class:`Interrupted` when a stop is requested or the test budget
``stop_after`` is spent.  pymoo's loop expresses the whole budget: the stop
is raised from the callback at a generation boundary, so no loop of our own
is needed.  A resumed stage builds its algorithm as a new one does, restores
the checkpoint's state into it and runs on.
"""
from __future__ import annotations

import signal
import time

import numpy as np
from pymoo.core.callback import Callback

from ..runs import RunFolder, RunFolderError
from .refine import front_population
from .checkpoint import CheckpointError, capture, restore
from .workers import Interrupted

__all__ = ["StageCallback", "history_row", "history_columns", "run_stage"]


def history_columns(problem, index_names, free) -> list[str]:
    """The columns of a stage's history.csv."""
    if problem.n_obj == 1:
        return (["generation", "evaluations", "feasible", "best_objective", "mean_objective"]
                + [f"best_{k}" for k in index_names] + [f"best_{n}" for n in free])
    return ["generation", "evaluations", "feasible", "front_size"] + [f"best_{t.label()}" for t in problem.terms]


def history_row(algorithm, generation: int, index_names, free) -> dict:
    """One row of a stage's history: the generation just finished."""
    pop, problem = algorithm.pop, algorithm.problem
    F, CV = pop.get("F", "CV")
    feas = CV[:, 0] <= 0
    rec = {"generation": generation, "evaluations": int(algorithm.evaluator.n_eval), "feasible": int(feas.sum())}
    if problem.n_obj == 1:
        best = algorithm.opt[0]
        rec["best_objective"] = float(best.F[0]) if best.CV[0] <= 0 else float("nan")
        rec["mean_objective"] = float(np.mean(F[feas, 0])) if feas.any() else float("nan")
        for k in index_names:
            v = best.get(f"index_{k}")
            rec[f"best_{k}"] = float(v) if v is not None else float("nan")
        for j, name in enumerate(free):
            rec[f"best_{name}"] = float(best.X[j])
    else:
        # the front the stage reports (its feasible non-dominated designs, before the
        # polish), so that the count during the run is the one its result names
        rec["front_size"] = int(len(front_population(algorithm)))
        for j, t in enumerate(problem.terms):
            rec[f"best_{t.label()}"] = float(np.min(F[feas, j])) if feas.any() else float("nan")
    return rec


class StageCallback(Callback):
    """History rows, progress, checkpoints and stop requests of one stage."""

    def __init__(self, inner, row, save, progress, interval: float, stop=None, budget=None):
        super().__init__()
        self.inner, self.row, self.save = list(inner), row, save
        self.progress, self.interval = progress, float(interval)
        self.stop, self.budget = stop, budget if budget is not None else {}
        self.history: list[dict] = []
        self.last_save = time.perf_counter()

    def notify(self, algorithm):
        for cb in self.inner:
            cb(algorithm)
        rec = self.row(algorithm, len(self.history) + 1)
        self.history.append(rec)
        last = algorithm.termination.has_terminated()
        stopping = self.stop is not None and not last and self.stop.requested()
        if self.budget.get("left") is not None:
            self.budget["left"] -= 1
            stopping = stopping or self.budget["left"] <= 0
        if stopping or time.perf_counter() - self.last_save >= self.interval:
            # pymoo counts this generation up after the callback: the next one runs n_iter + 1
            self.save(algorithm, self.history, algorithm.n_iter + 1)
            self.last_save = time.perf_counter()
        self.progress.update(rec["generation"], rec)
        if stopping:
            self.progress.finish()
            if self.stop is not None:
                self.stop.check()
            raise Interrupted(signal.SIGTERM)


def describe_best(rec: dict) -> str:
    """The progress text of a history row (without the config: no units)."""
    if "front_size" in rec:
        return f"{rec['front_size']} non-dominated"
    b = rec.get("best_objective")
    return "" if b is None else f"best {b:.6g}"


def run_stage(folder: RunFolder, name: str, problem, factory, generations: int, seed: int, progress,
              interval: float, index_names, free, value_names, stop=None, budget=None, describe=None):
    """Run (or resume from its checkpoint) one stage; returns the finished
    algorithm and the history rows.  ``describe(row)``: the progress text of
    a generation's history row."""
    algorithm, inner = factory()
    callbacks = [inner] if inner is not None else []
    columns = history_columns(problem, index_names, free)

    def save(alg, history, n_iter):
        folder.save_checkpoint(name, *capture(alg, callbacks, history, n_iter))

    cb = StageCallback(callbacks, lambda alg, g: history_row(alg, g, index_names, free), save, progress, interval,
                       stop, budget)
    algorithm.setup(problem, termination=("n_gen", generations), seed=seed, verbose=False, callback=cb)
    state = folder.load_checkpoint(name)
    if state is not None:
        try:
            cb.history = restore(algorithm, callbacks, state[0], state[1], value_names, columns)
        except CheckpointError as exc:
            p = folder.checkpoint_path(name)
            raise RunFolderError(f"{p}: corrupted checkpoint ({exc}); delete {p.parent} to restart that stage") from None
    progress.start(name, generations, len(cb.history), describe or describe_best)
    algorithm.run()
    progress.finish()
    return algorithm, cb.history
