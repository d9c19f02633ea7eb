"""The paper's optimization as a sequence of resumable GA runs (stages).

1. For every index with a positive weight, two single-objective GA runs give its
   minimum and maximum over the design bounds (section 3.4, before eq. 38).
2. The normalized weighted sum (eq. 38-40) is minimized by the same GA.  Each
   index is scaled to [0, 1] by its min and max; an index to be maximized
   (stiffness) is flipped so that 0 is its best value.  The paper's literal
   eq. 38 (no flip) is run as a separate stage so both can be compared.
3. NSGA-II and NSGA-III give the Pareto front of the indices (and of any extra
   objective the config names); the weighted-sum optimum and the named designs
   are placed against it.

Every stage checkpoints the pymoo algorithm (random state included) at a
generation boundary once ``optimizer.checkpoint_interval`` seconds (default 1)
have passed since its last checkpoint, and always when a stop is requested, so
an interrupted run resumes where it stopped (a SIGKILL loses at most that
interval of work) and ends with the same result as an uninterrupted one.
"""
from __future__ import annotations

import os
import signal
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.algorithms.moo.nsga3 import NSGA3
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.indicators.hv import HV
from pymoo.operators.sampling.rnd import FloatRandomSampling
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting
from pymoo.util.ref_dirs import get_reference_directions

from ..config import Config
from ..evaluate import mechanism_class, workspace_of
from ..runs import RunFolder
from .operators import (AdaptiveGaussianMutation, AdaptiveMutationCallback, ArithmeticCrossover,
                        ElitistGenerationalSurvival, RouletteSelection)
from .problem import DesignProblem, extra_term, index_term, weighted_sum, weighted_sum_term

__all__ = ["Interrupted", "Progress", "run_pipeline", "stage_plan", "build_algorithm", "default_jobs"]


class Interrupted(KeyboardInterrupt):
    """Raised on SIGTERM (and Ctrl-C) so the run is marked incomplete and can be resumed."""

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signum)
        self.signum = signum


# ---------------------------------------------------------------------- progress
class Progress:
    """A one-line progress bar per GA run on a terminal; silent otherwise."""

    def __init__(self, enabled: bool | None = None, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self._t0 = 0.0

    def start(self, label: str, total: int, done: int = 0):
        self.label, self.total = label, total
        self._t0 = time.perf_counter()
        if done:
            self.update(done, None)

    def update(self, gen: int, best: float | None):
        if not self.enabled:
            return
        width = 24
        k = int(width * gen / max(self.total, 1))
        best_txt = "" if best is None else f" best {best:.6g}"
        el = time.perf_counter() - self._t0
        self.stream.write(f"\r{self.label:<24} [{'#' * k}{'.' * (width - k)}] {gen}/{self.total}{best_txt} {el:5.1f}s ")
        self.stream.flush()

    def waiting(self, names, since: float):
        """A status line while this process waits for stages running in worker processes."""
        if self.enabled:
            self.stream.write(f"\r{', '.join(names)} (worker process) {time.perf_counter() - since:5.1f}s ")
            self.stream.flush()

    def note(self, text: str):
        """A line of its own (e.g. a stage a worker process finished)."""
        if self.enabled:
            self.stream.write(f"{text}\n")
            self.stream.flush()

    def finish(self):
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


# ---------------------------------------------------------------------- stages
@dataclass
class Stage:
    name: str
    kind: str                      # "single" | "weighted" | "pareto"
    index: str | None = None
    sense: str | None = None       # for single: "min" gives the index's minimum, "max" its maximum
    algorithm: str | None = None   # for pareto
    literal: bool = False


def stage_plan(cfg: Config) -> list[Stage]:
    opt = cfg.optimizer
    names = [k for k in cfg.indices if opt.weights.get(k, 0) > 0]
    plan = []
    for k in names:
        plan.append(Stage(f"single_{k}_min", "single", k, "min"))
        plan.append(Stage(f"single_{k}_max", "single", k, "max"))
    plan.append(Stage("weighted_sum", "weighted"))
    if any(cfg.indices[k].sense == "max" for k in names):
        plan.append(Stage("weighted_sum_literal", "weighted", literal=True))
    n_obj = len(cfg.indices) + len(opt.extra_objectives)
    if n_obj >= 2:
        for a in opt.pareto_algorithms:
            plan.append(Stage(f"pareto_{a}", "pareto", algorithm=a))
    return plan


def build_algorithm(cfg: Config, n_obj: int = 1, which: str | None = None):
    """The GA of the config (``paper_ga`` or ``pymoo_ga``), or NSGA-II/III."""
    opt = cfg.optimizer
    if which == "nsga2":
        return NSGA2(pop_size=opt.pareto_population), None
    if which == "nsga3":
        parts = {2: 40, 3: 12, 4: 7}.get(n_obj, 5)
        ref = get_reference_directions("das-dennis", n_obj, n_partitions=parts)
        return NSGA3(ref_dirs=ref, pop_size=max(opt.pareto_population, len(ref))), None
    if opt.algorithm == "pymoo_ga":
        return GA(pop_size=opt.population, eliminate_duplicates=True), None
    mutation = AdaptiveGaussianMutation(prob=opt.mutation_probability)
    alg = GA(pop_size=opt.population, sampling=FloatRandomSampling(), selection=RouletteSelection(opt.fitness_scaling),
             crossover=ArithmeticCrossover(prob=opt.crossover_probability), mutation=mutation,
             survival=ElitistGenerationalSurvival(opt.elites), n_offsprings=opt.population - opt.elites,
             eliminate_duplicates=False)
    return alg, AdaptiveMutationCallback(mutation)


def _stage_seed(seed: int, i: int) -> int:
    return int((seed * 1_000_003 + 7919 * (i + 1)) % (2 ** 32 - 1))


# ---------------------------------------------------------------------- one GA run
def _run_stage(folder: RunFolder, stage: Stage, problem: DesignProblem, factory: Callable, generations: int,
               seed: int, progress: Progress, budget: dict) -> dict:
    done = folder.stage_result(stage.name)
    if done is not None:
        return done
    state = folder.load_checkpoint(stage.name)
    if state is not None:
        algorithm, history = state["algorithm"], state["history"]
        problem = algorithm.problem
    else:
        algorithm, callback = factory()
        extra = {"callback": callback} if callback is not None else {}
        algorithm.setup(problem, termination=("n_gen", generations), seed=seed, verbose=False, **extra)
        history = []
    progress.start(stage.name, generations, len(history))
    single = problem.n_obj == 1
    interval = problem.config.optimizer.checkpoint_interval
    last_save = time.perf_counter()
    while algorithm.has_next():
        algorithm.next()
        pop = algorithm.pop
        F, CV = pop.get("F", "CV")
        feas = CV[:, 0] <= 0
        rec = {"generation": len(history) + 1, "evaluations": int(algorithm.evaluator.n_eval),
               "feasible": int(feas.sum())}
        if single:
            best = algorithm.opt[0]
            rec["best_objective"] = float(best.F[0]) if best.CV[0] <= 0 else float("nan")
            rec["mean_objective"] = float(np.mean(F[feas, 0])) if feas.any() else float("nan")
            for k in problem.config.indices:
                v = best.get(f"index_{k}")
                rec[f"best_{k}"] = float(v) if v is not None else float("nan")
            for j, name in enumerate(problem.free):
                rec[f"best_{name}"] = float(best.X[j])
        else:
            nds = NonDominatedSorting().do(F[feas], only_non_dominated_front=True) if feas.any() else []
            rec["front_size"] = int(len(nds))
            for j, t in enumerate(problem.terms):
                rec[f"best_{t.label()}"] = float(np.min(F[feas, j])) if feas.any() else float("nan")
        history.append(rec)
        stopping = budget.get("stop") is not None and algorithm.has_next() and budget["stop"].requested()
        if budget.get("left") is not None:
            budget["left"] -= 1
            stopping = stopping or budget["left"] <= 0
        now = time.perf_counter()
        if stopping or now - last_save >= interval:
            # the offspring of the finished generation are already merged into the
            # population and never read again: leave them out of the checkpoint (half its size)
            off, algorithm.off = algorithm.off, None
            try:
                folder.save_checkpoint(stage.name, {"algorithm": algorithm, "history": history})
            finally:
                algorithm.off = off
            last_save = time.perf_counter()
        progress.update(rec["generation"], rec.get("best_objective"))
        if stopping:
            progress.finish()
            if budget.get("stop") is not None:
                budget["stop"].check()
            raise Interrupted(signal.SIGTERM)
    progress.finish()
    return _stage_summary(folder, stage, algorithm, problem, history, manifest=budget.get("manifest", True))


def _rows_csv(rows: list[dict]) -> str:
    if not rows:
        return ""
    keys = list(rows[0])
    for r in rows[1:]:
        for k in r:
            if k not in keys:
                keys.append(k)
    out = [",".join(keys)]
    for r in rows:
        out.append(",".join(_csv_val(r.get(k)) for k in keys))
    return "\n".join(out) + "\n"


def _csv_val(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _population_rows(problem: DesignProblem, pop) -> list[dict]:
    X, F, CV, G = pop.get("X", "F", "CV", "G")
    designs = problem.designs(X)
    rows = []
    for i in range(len(pop)):
        r = {k: float(designs[k][i]) for k in problem.config.design_variables}
        for j, t in enumerate(problem.terms):
            r[f"objective_{t.label()}"] = float(F[i, j])
        for k in problem.config.indices:
            v = pop[i].get(f"index_{k}")
            r[k] = float(v) if v is not None else float("nan")
        r["cv"] = float(CV[i, 0])
        for j, c in enumerate(problem.constraint_names):
            r[f"g_{c}"] = float(G[i, j])
        rows.append(r)
    return rows


def _stage_summary(folder: RunFolder, stage: Stage, algorithm, problem: DesignProblem, history: list,
                   manifest: bool = True) -> dict:
    pop = algorithm.pop
    d = folder.stage_dir(stage.name)
    from ..io import atomic_write_text

    atomic_write_text(d / "history.csv", _rows_csv(history))
    atomic_write_text(d / "population.csv", _rows_csv(_population_rows(problem, pop)))
    res = {"stage": stage.name, "kind": stage.kind, "generations": len(history),
           "evaluations": int(algorithm.evaluator.n_eval)}
    if stage.kind in ("single", "weighted"):
        best = algorithm.opt[0]
        feasible = bool(best.CV[0] <= 0)
        design = {k: float(v[0]) for k, v in problem.designs(best.X[None, :]).items()}
        res.update({"feasible": feasible, "objective": float(best.F[0]) if feasible else None,
                    "design": design,
                    "indices": {k: float(best.get(f"index_{k}")) for k in problem.config.indices}})
        if stage.kind == "single":
            res["index"] = stage.index
            res["sense"] = stage.sense
            res["value"] = res["indices"][stage.index] if feasible else None
    else:
        opt = algorithm.opt
        feas = opt.get("CV")[:, 0] <= 0
        opt = opt[feas]
        rows = _population_rows(problem, opt)
        atomic_write_text(folder.path / f"{stage.name}.csv", _rows_csv(rows))
        res.update({"front_size": len(opt), "front": rows, "terms": [t.label() for t in problem.terms]})
    folder.write_stage_result(stage.name, res, manifest=manifest)
    return res


# ---------------------------------------------------------------------- the pipeline
@dataclass
class PipelineResult:
    folder: RunFolder
    results: dict
    stages: dict = field(default_factory=dict)


class _StopRequest:
    """SIGINT/SIGTERM during a run: the first signal asks the GA to stop after the
    generation in progress (its checkpoint is then on disk); a second one stops
    at once.  Stopping at a generation boundary never interrupts a compiled
    kernel or a file write half-way.

    In a stage worker process (``jobs > 1``) a stop is also requested by the
    main process through ``stop_file`` (it holds the signal number), and when
    the main process has gone (``parent``: its pid)."""

    def __init__(self, stop_file: Path | None = None, parent: int | None = None):
        self.signum: int | None = None
        self.previous: dict[int, object] = {}
        self.stop_file = stop_file
        self.parent = parent
        self.insisted = False   # a second signal: stop now, do not wait for stage workers

    def handler(self, signum, frame):
        if self.signum is not None:
            self.insisted = True
            raise Interrupted(signum)
        self.signum = signum

    def install(self) -> None:
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                self.previous[sig] = signal.signal(sig, self.handler)
            except ValueError:  # not in the main thread (e.g. a worker thread)
                return

    def restore(self) -> None:
        for sig, old in self.previous.items():
            try:
                signal.signal(sig, old)
            except (ValueError, TypeError):
                pass

    def requested(self) -> bool:
        if self.signum is None and self.stop_file is not None:
            try:
                self.signum = int(self.stop_file.read_text() or signal.SIGTERM)
            except (FileNotFoundError, ValueError):
                pass
        if self.signum is None and self.parent is not None and os.getppid() != self.parent:
            self.signum = signal.SIGTERM
        return self.signum is not None

    def check(self) -> None:
        if self.requested():
            raise Interrupted(self.signum)


def _stage_terms(cfg: Config, st: Stage, lo: dict, hi: dict):
    """(objective terms, generations, algorithm factory) of a stage."""
    if st.kind == "single":
        return [index_term(st.index, st.sense)], cfg.optimizer.generations, lambda: build_algorithm(cfg)
    if st.kind == "weighted":
        senses = {k: s.sense for k, s in cfg.indices.items()}
        # the config's index order (not the order the single runs finished in):
        # the sum is then added up in the same order whatever ``jobs`` is
        lo, hi = _ordered(cfg, lo), _ordered(cfg, hi)
        w = {k: cfg.optimizer.weights[k] for k in lo}
        term = weighted_sum_term(lo, hi, w, senses, literal=st.literal)
        return [term], cfg.optimizer.generations, lambda: build_algorithm(cfg)
    terms = [index_term(k, s.sense) for k, s in cfg.indices.items()]
    extras = mechanism_class(cfg).extra_objectives
    terms += [extra_term(e, extras[e].sense) for e in cfg.optimizer.extra_objectives]
    return terms, cfg.optimizer.pareto_generations, lambda a=st.algorithm, n=len(terms): build_algorithm(cfg, n, a)


def _ordered(cfg: Config, d: dict) -> dict:
    return {k: d[k] for k in cfg.indices if k in d}


def _execute_stage(cfg: Config, folder: RunFolder, st: Stage, i: int, lo: dict, hi: dict, seed: int, ws,
                   progress: Progress, budget: dict) -> dict:
    terms, gens, factory = _stage_terms(cfg, st, lo, hi)
    return _run_stage(folder, st, DesignProblem(cfg, terms, ws), factory, gens, _stage_seed(seed, i), progress, budget)


_busy = False


def _worker_init(parent: int) -> None:
    # a Ctrl-C on the terminal reaches every process of the group: an idle
    # worker ignores it, a busy one stops at its generation boundary (its
    # task installs a _StopRequest)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _set_kernel_threads(1)
    import threading

    # the parent's pid comes from the parent: it may have died while this
    # worker was starting, and os.getppid() would then already name another process
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _watch_parent(parent: int, poll: float = 0.2, grace: float = 10.0) -> None:
    """End this worker when the main process is gone (e.g. SIGKILLed): at once
    when idle; a busy one stops at its next generation boundary by itself
    (its _StopRequest sees the new parent) and is ended after ``grace`` s if not."""
    while os.getppid() == parent:
        time.sleep(poll)
    t = time.monotonic()
    while _busy and time.monotonic() - t < grace:
        time.sleep(poll)
    os._exit(1)


def _set_kernel_threads(n: int | None) -> int | None:
    """Set the compiled kernels' thread count (None: numba's default); returns the old one."""
    try:
        import numba
    except Exception:  # noqa: BLE001 - no numba: the numpy path, nothing to set
        return None
    old = numba.get_num_threads()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS if n is None else max(1, min(n, numba.config.NUMBA_NUM_THREADS)))
    return old


def _stage_task(cfg: Config, path: str, st: Stage, i: int, lo: dict, hi: dict, seed: int, ws, parent: int) -> dict:
    """One stage in a worker process; the main process records it in the manifest."""
    global _busy
    folder = RunFolder(path)
    stop = _StopRequest(folder.path / STOP_FILE, parent)
    stop.install()
    _busy = True
    try:
        return _execute_stage(cfg, folder, st, i, lo, hi, seed, ws, Progress(False),
                              {"stop": stop, "left": None, "manifest": False})
    finally:
        _busy = False
        stop.restore()


#: written into the run folder by the main process to stop its stage workers
STOP_FILE = ".stop"


def default_jobs() -> int:
    """Processes for a run's stages: the CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def run_pipeline(cfg: Config, folder: RunFolder, seed: int, progress: Progress | None = None,
                 pareto: bool = True, stop_after: int | None = None, jobs: int = 1) -> PipelineResult:
    """Run (or resume) every stage of the config's optimization in ``folder``.

    ``jobs``: processes running stages at once.  The single-index GA runs and
    the Pareto runs are independent; the weighted sums wait for the single-index
    runs.  With ``jobs > 1`` this process runs stages itself and hands others
    to ``jobs - 1`` worker processes; every stage has its own seed, so the
    results do not depend on ``jobs``.

    ``stop_after`` (tests only) interrupts the run after that many generations,
    as a signal would (it runs the stages one by one).
    """
    progress = progress or Progress(False)
    t0 = time.perf_counter()
    m0 = folder.read_manifest()
    wall_before = float(m0.get("wall_time_s") or 0.0)
    folder.update_manifest(status="running")
    stop = _StopRequest()
    stop.install()
    ws = workspace_of(cfg)
    stages: dict[str, dict] = {}
    budget = {"left": stop_after, "stop": stop}
    jobs = 1 if stop_after is not None else max(1, int(jobs))
    pool = None
    threads = None
    try:
        plan = stage_plan(cfg)
        if not pareto:
            plan = [s for s in plan if s.kind != "pareto"]
        lo, hi = {}, {}
        singles = [st.name for st in plan if st.kind == "single"]

        def record(st: Stage, res: dict) -> None:
            stages[st.name] = res
            if st.kind == "single":
                if not res["feasible"]:
                    raise RuntimeError(f"no feasible design found for {st.index} ({st.sense}); widen the bounds or relax the constraints")
                (lo if st.sense == "min" else hi)[st.index] = res["value"]

        # finished stages (a resumed run) are taken as they are
        todo = []
        for i, st in enumerate(plan):
            done = folder.stage_result(st.name)
            if done is not None:
                record(st, done)
            else:
                todo.append((i, st))
        todo.sort(key=lambda t: {"single": 0, "weighted": 1, "pareto": 2}[t[1].kind])

        def take():
            """The next stage that can start (single runs first, then the weighted sums once the
            single runs are done, then the Pareto runs), or None."""
            for n, (i, st) in enumerate(todo):
                if st.kind != "weighted" or all(s in stages for s in singles):
                    return todo.pop(n)
            return None

        workers = min(jobs - 1, len(todo) - 1)
        running: dict = {}
        if workers > 0:
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            threads = _set_kernel_threads(1)
            pool = ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"), initializer=_worker_init,
                                       initargs=(os.getpid(),))
            for _ in range(workers):  # start the workers (their imports) now
                pool.submit(_worker_ready)
            # load (on a fresh installation: compile and cache) the kernels here
            # first, so that the workers load them from the cache instead of
            # compiling them too
            _warm_kernels(cfg, ws)
        report_warm = False
        while todo or running:
            while pool is not None and len(running) < workers:
                nxt = take()
                if nxt is None:
                    break
                i, st = nxt
                running[pool.submit(_stage_task, cfg, str(folder.path), st, i, dict(lo), dict(hi), seed, ws,
                                    os.getpid())] = st
            nxt = take()
            if nxt is not None:
                i, st = nxt
                record(st, _execute_stage(cfg, folder, st, i, lo, hi, seed, ws, progress, budget))
            elif running:
                if not report_warm:  # idle until a worker finishes: load the plotting library meanwhile
                    report_warm = _warm_report()
                _wait_any(running, stop, progress)
            for fut in [f for f in running if f.done()]:
                st = running.pop(fut)
                record(st, fut.result())
                folder.mark_stage_done(st.name)
                progress.note(f"{st.name} done (worker process)")
            stop.check()
        if pool is not None:  # let the workers exit while the results and the report are written
            pool.shutdown(wait=False)
        stages = {st.name: stages[st.name] for st in plan}
        results = _final_results(cfg, folder, seed, stages, _ordered(cfg, lo), _ordered(cfg, hi), ws)
        wall = wall_before + time.perf_counter() - t0
        m = folder.read_manifest()
        evals = sum(int(s.get("evaluations", 0)) for s in stages.values())
        m.update(status="complete", end_time=_now_iso(), wall_time_s=round(wall, 3), evaluations=evals)
        folder.write_manifest(m)
        results["wall_time_s"] = round(wall, 3)
        results["evaluations"] = evals
        folder.write_json("results.json", results)
        from .report import write_report

        write_report(cfg, folder, results, stages)
        return PipelineResult(folder, results, stages)
    except KeyboardInterrupt as exc:
        if not isinstance(exc, Interrupted):
            exc = Interrupted(signal.SIGINT)
        _stop_workers(folder, pool, exc.signum, wait=not stop.insisted)
        folder.update_manifest(status="interrupted", wall_time_s=round(wall_before + time.perf_counter() - t0, 3))
        exc.folder = folder.path
        raise exc from None
    except Exception as exc:
        _stop_workers(folder, pool, signal.SIGTERM, wait=True)
        folder.update_manifest(status="failed", error=f"{type(exc).__name__}: {exc}",
                               wall_time_s=round(wall_before + time.perf_counter() - t0, 3))
        raise
    finally:
        if pool is not None:
            pool.shutdown(wait=False, cancel_futures=True)
        if threads is not None:
            _set_kernel_threads(threads)
        try:
            (folder.path / STOP_FILE).unlink()
        except FileNotFoundError:
            pass
        stop.restore()


def _worker_ready() -> bool:
    return True


def _warm_kernels(cfg: Config, ws) -> None:
    """One evaluation of the config's initial design: loads (or compiles) the
    compiled kernels the run will use.  Only a warm-up: a failure here is left
    for the stages to report."""
    from ..evaluate import evaluate

    try:
        with np.errstate(all="ignore"):
            evaluate(cfg, [cfg.initial_design()], ws)
    except Exception:  # noqa: BLE001
        pass


def _warm_report() -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401
    except Exception:  # noqa: BLE001 - the report says why plots are missing
        pass
    return True


def _wait_any(running: dict, stop: _StopRequest, progress: Progress) -> None:
    """Wait until a worker's stage ends or a stop is requested (checked every 50 ms)."""
    from concurrent.futures import FIRST_COMPLETED, wait

    t0 = time.perf_counter()
    names = [st.name for st in running.values()]
    shown = False
    while not stop.requested():
        done, _ = wait(list(running), timeout=0.05, return_when=FIRST_COMPLETED)
        if done:
            break
        progress.waiting(names, t0)
        shown = True
    if shown:
        progress.finish()


def _stop_workers(folder: RunFolder, pool, signum: int, wait: bool) -> None:
    """Ask the stage workers to stop at their next generation boundary (after
    their checkpoint) and, unless the user insisted (a second signal), wait for them."""
    if pool is None:
        return
    from ..io import atomic_write_text

    atomic_write_text(folder.path / STOP_FILE, str(int(signum)))
    if wait:
        try:
            pool.shutdown(wait=True, cancel_futures=True)
        except KeyboardInterrupt:
            pass


def _now_iso() -> str:
    import datetime as dt

    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


# ---------------------------------------------------------------------- results
def _final_results(cfg: Config, folder: RunFolder, seed: int, stages: dict, lo: dict, hi: dict, ws) -> dict:
    from ..evaluate import evaluate

    ws_res = stages["weighted_sum"]
    if not ws_res["feasible"]:
        raise RuntimeError("the weighted-sum GA found no feasible design")
    opt_design = ws_res["design"]
    names = [n for n in cfg.designs if n != "initial" or len(cfg.designs) == 1]
    all_designs = [opt_design] + [cfg.design(n) for n in names]
    ev = evaluate(cfg, all_designs, ws)
    senses = {k: s.sense for k, s in cfg.indices.items()}
    weights = {k: cfg.optimizer.weights[k] for k in lo}

    def summ(i):
        return {k: {s: float(ev.summary[k][s][i]) for s in ("mean", "min", "max", "std")} for k in cfg.indices}

    vals = {k: ev.summary[k]["mean"] for k in cfg.indices}
    ours = weighted_sum(vals, weighted_sum_term(lo, hi, weights, senses))
    literal = weighted_sum(vals, weighted_sum_term(lo, hi, weights, senses, literal=True))
    designs = {}
    for j, n in enumerate(names):
        designs[n] = {"parameters": cfg.design(n), "global_indices": summ(j + 1),
                      "reachable_fraction": float(ev.reachable_fraction[j + 1]),
                      "objective": float(ours[j + 1]), "objective_paper_literal": float(literal[j + 1])}
    results = {
        "status": "complete",
        "seed": seed,
        "config": cfg.name,
        "mechanism": cfg.mechanism,
        "optimum": {k: float(v) for k, v in opt_design.items()},
        "objective": float(ws_res["objective"]),
        "objective_paper_literal": float(literal[0]),
        "global_indices": {k: float(vals[k][0]) for k in cfg.indices},
        "global_index_summary": summ(0),
        "reachable_fraction": float(ev.reachable_fraction[0]),
        "normalization": {k: {"min": lo[k], "max": hi[k], "sense": senses[k], "weight": weights[k]} for k in lo},
        "designs": designs,
        "reference": cfg.reference,
        "workspace_points": int(ws.n),
    }
    if "weighted_sum_literal" in stages and stages["weighted_sum_literal"]["feasible"]:
        s = stages["weighted_sum_literal"]
        results["paper_literal_optimum"] = {"design": s["design"], "objective": s["objective"], "global_indices": s["indices"]}
    pareto = {}
    for name, s in stages.items():
        if s["kind"] != "pareto":
            continue
        pareto[name] = _place_against_front(cfg, s, results, lo, hi, ev, names)
    if pareto:
        results["pareto"] = pareto
    return results


def _place_against_front(cfg: Config, s: dict, results: dict, lo: dict, hi: dict, ev, names: list[str]) -> dict:
    """Hypervolume of the front and the additive-epsilon placement of the
    weighted-sum optimum and the named designs (normalized objective space)."""
    terms = s["terms"]
    extras = mechanism_class(cfg).extra_objectives
    front = np.array([[row[f"objective_{t}"] for t in terms] for row in s["front"]]) if s["front"] else np.zeros((0, len(terms)))
    # normalization: indices by their single-objective extremes (best -> 0, worst -> 1)
    scale_lo, scale_hi = [], []
    for t in terms:
        k = t.lstrip("-")
        col = front[:, terms.index(t)] if len(front) else np.array([0.0, 1.0])
        if k in lo:
            a, b = (lo[k], hi[k]) if cfg.indices[k].sense == "min" else (-hi[k], -lo[k])
        elif k in extras:  # the range over its parameters' bounds and the front
            a, b = float(np.min(col)), float(np.max(col))
            e = extras[k]
            corners = {p: np.array(cfg.design_variables[p].bounds or (cfg.design_variables[p].value,) * 2) for p in e.parameters}
            vals = np.asarray(e.func(corners), dtype=float) * (1 if t == k else -1)
            a, b = min(a, float(vals.min())), max(b, float(vals.max()))
        else:  # an index with weight 0 (no single-objective runs): the front's own range
            a, b = float(np.min(col)), float(np.max(col))
        scale_lo.append(a)
        scale_hi.append(b if b > a else a + 1.0)
    scale_lo, scale_hi = np.array(scale_lo), np.array(scale_hi)
    norm = lambda F: (np.asarray(F) - scale_lo) / (scale_hi - scale_lo)  # noqa: E731
    Fn = norm(front) if len(front) else front
    hv = float(HV(ref_point=np.full(len(terms), 1.1))(Fn)) if len(Fn) else 0.0

    def point(values: dict) -> np.ndarray:
        out = []
        for t in terms:
            k = t.lstrip("-")
            v = values[k]
            out.append(-v if t.startswith("-") else v)
        return np.array(out)

    def extra_vals(design: dict) -> dict:
        out = {}
        for e in cfg.optimizer.extra_objectives:
            out[e] = float(np.asarray(extras[e].func({k: np.array([v]) for k, v in design.items()}))[0])
        return out

    placed = {}
    cands = {"weighted_sum_optimum": ({**results["global_indices"], **extra_vals(results["optimum"])})}
    for j, n in enumerate(names):
        cands[n] = {**{k: float(ev.summary[k]["mean"][j + 1]) for k in cfg.indices}, **extra_vals(cfg.design(n))}
    spread = float(np.max(Fn.max(axis=0) - Fn.min(axis=0))) if len(Fn) else 0.0
    for n, vals in cands.items():
        p = norm(point(vals))
        if len(Fn):
            eps = float(np.min(np.max(Fn - p, axis=1)))
            dominated_by = int(np.sum(np.all(Fn <= p, axis=1) & np.any(Fn < p, axis=1)))
        else:
            eps, dominated_by = float("nan"), 0
        placed[n] = {"normalized_objectives": p.tolist(), "epsilon": eps, "dominated": eps < 0,
                     "dominated_by_points": dominated_by}
    return {"front_size": int(len(front)), "hypervolume": hv, "hypervolume_reference": [1.1] * len(terms),
            "normalization": {"terms": terms, "best": scale_lo.tolist(), "worst": scale_hi.tolist()},
            "front_spread": spread, "placement": placed}
