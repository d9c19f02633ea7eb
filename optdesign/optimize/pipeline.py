"""The paper's optimization as a plan of resumable stages.

0. A quasi-random pre-scan of the design box (:mod:`.prescan`) whose best
   feasible designs seed the single-objective searches and their polish.
1. For every index with a positive weight, two single-objective runs give its
   minimum and maximum over the design bounds (section 3.4, before eq. 38),
   each ending in a gradient polish of its best designs (:mod:`.polish`).
2. The normalized weighted sum (eq. 38-40) is minimized by the same search
   and polished.  Each index is scaled to [0, 1] by its min and max (the
   extremes of the pre-scan and the single-objective stages,
   :mod:`.normalization`); an index to be maximized (stiffness) is flipped so
   that 0 is its best value.  The paper's literal eq. 38 (no flip) is run as
   a separate stage so both can be compared.
3. NSGA-II and NSGA-III give the Pareto front of the indices (and of any extra
   objective the config names), each front design polished onto the front;
   the weighted-sum optimum and the named designs are placed against it.
   An extreme a later stage goes beyond is updated and every normalized
   objective recomputed from the final extremes (:mod:`.final`).

Each stage runs in pymoo's loop with data-only checkpoints (:mod:`.stage`),
in this process or a worker process (:mod:`.workers`); every stage has its
own seed, so the results depend neither on ``jobs`` nor on interruptions.

The pipeline reads plain pieces (:class:`.spec.RunSpec`), never a config: the
evaluation callable, the optimizer's and the checks' settings, the units the
files and progress lines show, and what the results are about.
"""
from __future__ import annotations

import signal
import time

import numpy as np
from dataclasses import dataclass, field

from ..evaluate import Evaluator
from ..fast import set_compile_notice
from ..gradients import ad_available
from ..runs import RunFolder
from ..units import Units
from .algorithms import build_algorithm
from .problem import DesignProblem, extra_term, index_term, weighted_sum_term
from .progress import Progress
from .algorithms import seed_count
from .describe import describe_result, describe_row
from .final import final_results
from .normalization import bounds_of, fold_extremes
from .outputs import NO_OUTPUTS, RunOutputs
from .extremes import run_extremes, scan_size
from .prescan import best_designs, run_prescan
from .refine import front_seeds
from .results import finished_stage, rows_csv, stage_summary
from .spec import RunSpec, RunSubject
from .stage import run_stage
from .workers import Interrupted, StagePool, StopRequest, default_jobs, warm_plots

__all__ = ["Interrupted", "Progress", "Stage", "run_pipeline", "stage_plan", "stage_seed", "prescan_size", "build_algorithm",
           "default_jobs", "PipelineResult", "RunSpec", "RunSubject"]


@dataclass
class Stage:
    name: str
    kind: str                      # "prescan" | "single" | "extremes" | "weighted" | "pareto"
    index: str | None = None
    sense: str | None = None       # for single: "min" gives the index's minimum, "max" its maximum
    algorithm: str | None = None   # for pareto
    literal: bool = False


def stage_plan(opt, senses: dict[str, str]) -> list[Stage]:
    """The stages of a run with the optimizer's settings ``opt`` over the
    indices ``senses`` (name -> "min" | "max", in the config's order)."""
    names = [k for k in senses if opt.weights.get(k, 0) > 0]
    plan = [Stage("prescan", "prescan")] if prescan_size(opt) > 0 else []
    for k in names:
        plan += [Stage(f"single_{k}_min", "single", k, "min"), Stage(f"single_{k}_max", "single", k, "max")]
    if names and opt.polish > 0 and opt.extremes_starts > 0:
        plan.append(Stage("extremes", "extremes"))
    plan.append(Stage("weighted_sum", "weighted"))
    if any(senses[k] == "max" for k in names):
        plan.append(Stage("weighted_sum_literal", "weighted", literal=True))
    if len(senses) + len(opt.extra_objectives) >= 2:
        plan += [Stage(f"pareto_{a}", "pareto", algorithm=a) for a in opt.pareto_algorithms]
    return plan


def numbered(plan: list[Stage]) -> list[tuple[int, Stage]]:
    """(i, stage) of the plan: ``i`` the stage's number for its seed, counted
    without the seed-free extremes stage (numbered -1), so that adding it
    leaves every other stage's seed as it was."""
    out, i = [], 0
    for st in plan:
        if st.kind == "extremes":
            out.append((-1, st))
        else:
            out.append((i, st))
            i += 1
    return out


def prescan_size(opt) -> int:
    """Designs of the pre-scan: ``optimizer.prescan``, by default the smaller of
    2048 and one single-objective stage's budget (population x generations)."""
    return int(opt.prescan) if opt.prescan is not None else min(2048, opt.population * opt.generations)


def stage_seed(seed: int, i: int) -> int:
    """The seed of the ``i``-th stage of the plan."""
    return int((seed * 1_000_003 + 7919 * (i + 1)) % (2 ** 32 - 1))


def _ordered(names: list[str], d: dict) -> dict:
    return {k: d[k] for k in names if k in d}


def stage_problem(opt, st: Stage, lo: dict, hi: dict, evaluator: Evaluator, seeds=None):
    """(problem, generations, algorithm factory) of a stage with the
    optimizer's settings ``opt`` (``seeds``: the designs a single-objective
    search starts with)."""
    if st.kind == "single":
        terms = [index_term(st.index, st.sense)]
    elif st.kind == "weighted":
        # the config's index order (not the order the single runs finished in):
        # the sum is then added up in the same order whatever ``jobs`` is
        lo, hi = _ordered(evaluator.index_names, lo), _ordered(evaluator.index_names, hi)
        terms = [weighted_sum_term(lo, hi, {k: opt.weights[k] for k in lo}, evaluator.senses, literal=st.literal)]
    else:
        terms = [index_term(k, evaluator.senses[k]) for k in evaluator.index_names]
        terms += [extra_term(e, evaluator.extra[e].sense) for e in opt.extra_objectives]
        problem = DesignProblem(evaluator, terms)   # its first population: the pre-scan's best trade-offs
        first = front_seeds(problem, seeds, opt.pareto_population // 2)
        return problem, opt.pareto_generations, lambda: build_algorithm(opt, len(terms), st.algorithm, seeds=first)
    return DesignProblem(evaluator, terms), opt.generations, lambda: build_algorithm(opt, seeds=seeds)


def execute_stage(evaluator: Evaluator, opt, units: Units, folder: RunFolder, st: Stage, i: int, lo: dict, hi: dict,
                  seed: int, progress: Progress | None = None, budget: dict | None = None,
                  stop: StopRequest | None = None, manifest: bool = True, seeds=None) -> dict:
    """Run (or resume) stage ``i`` of the plan and write its files (``opt``:
    the optimizer's settings; ``units``: how its CSV files and progress line
    show the values)."""
    if st.kind == "extremes":
        return _extremes_stage(evaluator, opt, units, folder, st, i, seed, progress, manifest)
    if st.kind == "prescan":
        prog = progress or Progress(False)

        def batch(k, total):
            if k == 0:   # the stage line: designs evaluated of those scanned (the corners included)
                prog.start(st.name, total, 0, describe=lambda r: describe_result(units, st, r) if isinstance(r, dict) else "")
            else:
                prog.update(k, None)
        try:
            res, rows = run_prescan(evaluator, prescan_size(opt), stage_seed(seed, i), on_batch=batch)
            prog.update(res["evaluations"], res)
        finally:
            prog.finish()
        folder.stage_dir(st.name)
        folder.write_text(f"stages/{st.name}/population.csv", rows_csv(_display(units, rows, None)))
        folder.write_stage_result(st.name, res, manifest, *_record(st, seed, i))
        return res
    seeds = None if seeds is None else np.asarray(seeds, dtype=float).reshape(-1, len(evaluator.free))
    problem, gens, factory = stage_problem(opt, st, lo, hi, evaluator, seeds)
    alg, history = run_stage(folder, st.name, problem, factory, gens, stage_seed(seed, i), progress or Progress(False),
                             opt.checkpoint_interval, evaluator.index_names, evaluator.free,
                             evaluator.index_names + list(evaluator.extra), stop, budget,
                             describe=lambda rec: describe_row(units, st, rec))
    if progress is not None and opt.polish > 0:
        progress.note(f"{st.name}: polishing")
    res = stage_summary(folder, st, alg, problem, evaluator, history, seeds, opt.polish,
                        display=lambda rows, s: _display(units, rows, s))
    folder.write_stage_result(st.name, res, manifest, *_record(st, seed, i))
    return res


def _extremes_stage(evaluator: Evaluator, opt, units: Units, folder: RunFolder, st: Stage, i: int, seed: int,
                    progress: Progress | None, manifest: bool) -> dict:
    """The seed-free multi-start of the normalization extremes (:mod:`.extremes`)."""
    prog = progress or Progress(False)
    total = scan_size(opt.extremes_scan)
    prog.start(st.name, total, 0, describe=lambda r: describe_result(units, st, r) if isinstance(r, dict) else "")
    try:
        res = run_extremes(evaluator, [k for k in evaluator.index_names if opt.weights.get(k, 0) > 0], opt.extremes_starts,
                           opt.extremes_scan, on_batch=lambda k, n: prog.update(min(k, total), None),
                           walk=opt.extremes_walk)
        prog.update(total, res)
    finally:
        prog.finish()
    folder.stage_dir(st.name)
    folder.write_stage_result(st.name, res, manifest, *_record(st, seed, i))
    return res


def stage_work(opt, st: Stage) -> tuple[int, int]:
    """(generations, population) of a stage with the optimizer's settings
    ``opt``: its share of the run's work (the pre-scan: one generation of its designs)."""
    if st.kind == "prescan":
        return 1, prescan_size(opt)
    if st.kind == "extremes":
        return 1, scan_size(opt.extremes_scan)
    if st.kind == "pareto":
        return opt.pareto_generations, opt.pareto_population
    return opt.generations, opt.population


def _display(units: Units, rows: list, st: Stage | None) -> list:
    """A stage's rows as its CSV files show them (units, objectives in their own sense)."""
    from ..units import display_rows

    return display_rows(units, rows, (st.index, st.sense) if st is not None and st.kind == "single" else None)


def _record(st: Stage, seed: int, i: int):
    return {"seed": stage_seed(seed, i), "kind": st.kind}, ((f"{st.name}.csv",) if st.kind == "pareto" else ())


def _stage_in_worker(evaluator, opt, units, path, st, i, lo, hi, seed, seeds, stop=None) -> dict:
    """One stage in a worker process (its pieces pickled: the evaluator, whose
    copy starts with an empty memo, the optimizer's settings and the units);
    the main process records it in the manifest (and shows its progress,
    sent through the pool's queue)."""
    from .workers import worker_progress

    return execute_stage(evaluator, opt, units, RunFolder(path), st, i, lo, hi, seed, progress=worker_progress(),
                         stop=stop, manifest=False, seeds=seeds)


def stage_seeds(opt, st: Stage, stages: dict, lo: dict, hi: dict, evaluator: Evaluator):
    """The designs a single-objective stage starts from: the pre-scan's best for
    its objective (a tenth of the population) and, for a weighted sum, the
    single-objective stages' answers; None for the other stages."""
    if st.kind == "pareto":   # the pre-scan's feasible designs: the front is filtered against them
        pre = stages.get("prescan")
        return pre["designs"] if pre and pre.get("designs") else None
    if st.kind not in ("single", "weighted"):
        return None
    problem, _, _ = stage_problem(opt, st, lo, hi, evaluator)
    k = seed_count(opt.population)
    X = best_designs(stages.get("prescan"), problem.terms[0], k, xl=evaluator.xl, xu=evaluator.xu)
    if st.kind == "weighted":
        done = [evaluator.vector(r["design"]) for r in stages.values() if r.get("kind") == "single"]
        X = np.concatenate([np.array(done).reshape(-1, len(evaluator.free)), X])
    return np.clip(X, evaluator.xl, evaluator.xu).tolist()


@dataclass
class PipelineResult:
    folder: RunFolder
    results: dict
    stages: dict = field(default_factory=dict)
    wall_before_s: float = 0.0     # the run's wall time in earlier invocations (a resumed run)


def run_pipeline(spec: RunSpec, folder: RunFolder, seed: int, progress: Progress | None = None, pareto: bool = True,
                 stop_after: int | None = None, jobs: int = 1, stop: StopRequest | None = None,
                 outputs: RunOutputs = NO_OUTPUTS) -> PipelineResult:
    """Run (or resume) every stage of the optimization ``spec`` describes in
    ``folder`` (:func:`optdesign.runner.run_in_folder` makes the spec of a config).
    ``jobs``: processes running stages at once (the weighted sums wait for the
    single-index runs); ``stop``: the caller's signal state (else one is
    installed here); ``stop_after`` (tests only): interrupt after that many
    generations, as a signal would (the stages then run one by one);
    ``outputs``: the reports and notes the layers above add (:mod:`.outputs`)."""
    progress, t0 = progress or Progress(False), time.perf_counter()
    notice = set_compile_notice(progress.compiling if progress.enabled else None)
    wall_before = float(folder.verify_inputs(seed)["wall_time_s"])   # the folder is what it says it is
    folder.update_manifest(status="running")
    progress.watch(folder.path)      # progress.json: optdesign status RUN
    ended = "failed"
    own, stop, pool = stop is None, stop or StopRequest(), None
    if own:
        stop.install()
    stop.deferred = True
    evaluator, opt, units = spec.evaluator, spec.optimizer, spec.units
    plan = [s for s in stage_plan(opt, evaluator.senses) if pareto or s.kind != "pareto"]
    budget = {"left": stop_after}
    jobs = 1 if stop_after is not None else max(1, int(jobs))
    stages = {}
    singles = [st.name for st in plan if st.kind == "single"]
    first = [st.name for st in plan if st.kind == "prescan"]
    extremes = [st.name for st in plan if st.kind == "extremes"]
    weighted_names = [k for k in evaluator.index_names if opt.weights.get(k, 0) > 0]
    try:
        def record(st: Stage, res: dict) -> None:
            stages[st.name] = res
            if st.kind == "single":
                if not res["feasible"]:
                    raise RuntimeError(f"no feasible design found for {st.index} ({st.sense}); widen the bounds or relax the constraints")

        def inputs(st: Stage):
            """(lo, hi, seeds) a stage starts with: the extremes of the pre-scan and the
            single-objective stages (folded in the plan's order) and its seeds."""
            ordered = {s.name: stages[s.name] for s in plan if s.name in stages}
            lo, hi = bounds_of(fold_extremes(ordered, upto_singles=True)[0], weighted_names)
            return lo, hi, stage_seeds(opt, st, ordered, lo, hi, evaluator)

        todo = []   # in the plan's order; finished stages (a resumed run) are taken as they are
        for i, st in numbered(plan):
            done = finished_stage(folder, st, stage_seed(seed, i))
            todo.append((i, st)) if done is None else record(st, done)
        progress.plan([(st.name, *stage_work(opt, st)) for st in plan], done=list(stages))

        def take():
            """The next stage that can start (every stage after the pre-scan, the
            weighted sums once the single runs are done), or None."""
            for n, (i, st) in enumerate(todo):
                if st.kind not in ("prescan", "extremes") and not all(s in stages for s in first):
                    continue
                if st.kind != "weighted" or all(s in stages for s in singles + extremes):
                    return todo.pop(n)
            return None

        def warm():
            evaluator(evaluator.vector(evaluator.defaults)[None, :])    # the initial design
            if opt.polish > 0:
                ad_available(evaluator)     # builds the CasADi derivatives once per process

        pool = StagePool(min(jobs - 1, len(todo) - 1), folder.path, warm=warm, events=progress.tracking)
        progress.poll = pool.poll_progress
        report_warm = outputs.write_report is None   # matplotlib is loaded for the plots only
        while todo or pool.running:
            while pool.free() and (nxt := take()) is not None:
                i, st = nxt
                lo, hi, seeds = inputs(st)
                pool.submit((i, st), st.name, _stage_in_worker, evaluator, opt, units, str(folder.path), st, i, lo, hi,
                            seed, seeds)
            nxt = take()
            if nxt is not None:
                i, st = nxt
                lo, hi, seeds = inputs(st)
                record(st, execute_stage(evaluator, opt, units, folder, st, i, lo, hi, seed, progress, budget, stop,
                                         seeds=seeds))
            elif pool.running:
                report_warm = report_warm or warm_plots()   # idle until a worker finishes
                pool.wait_any(stop, progress)
            for (i, st), res in pool.finished():
                record(st, res)
                folder.mark_stage_done(st.name, *_record(st, seed, i))
                progress.stage_done(st.name, describe_result(units, st, res))
            stop.check()
        pool.release()   # the workers exit while the results and the report are written
        stages = {st.name: stages[st.name] for st in plan}
        progress.phase("final results: the optimum and the extremes checked and polished ...", "final results …")
        results = final_results(spec.subject, opt.weights, seed, stages, evaluator, opt.polish, outputs.reference_note)
        progress.phase("integrals: every reported design's indices by adaptive cubature ...", "integrals …")
        from .integrals import integrals_of_reported

        integrals = integrals_of_reported(spec.checks, evaluator, units, results)
        if integrals is not None:
            results["integrals"] = integrals
        progress.phase("certificates: every reported design over the continuous workspace ...", "certificates …")
        from ..certify.reported import certify_reported

        results["certificates"] = certify_reported(evaluator, results, stages, base=spec.checks.certificate_budget)
        wall = round(wall_before + time.perf_counter() - t0, 3)
        evals = sum(int(s.get("evaluations", 0)) for s in stages.values())
        results.update(wall_time_s=wall, evaluations=evals)
        folder.write_json("results.json", results)
        if outputs.write_report is not None:
            progress.phase("writing report: results.md and its plots ...", "writing report …")
            outputs.write_report(folder, results, stages)
        stop.completed = True   # from here a signal changes nothing: the manifest is about to say complete
        folder.complete(wall_time_s=wall, evaluations=evals)
        if outputs.write_html is not None:
            progress.phase("writing report: report.html ...", "writing report.html …")
            outputs.write_html(folder)
        ended = "complete"
        return PipelineResult(folder, results, stages, wall_before_s=wall_before)
    except KeyboardInterrupt as exc:
        if not isinstance(exc, Interrupted):
            exc = Interrupted(signal.SIGINT)
        waited = pool is None or not stop.insisted
        if pool is not None:
            pool.stop(exc.signum, wait=waited)
        # the checkpoints on disk are final once the workers have stopped: record them
        folder.record_checkpoints([st.name for st in plan] if waited else [], status="interrupted",
                                  wall_time_s=round(wall_before + time.perf_counter() - t0, 3))
        exc.folder = folder.path
        ended = "interrupted"
        raise exc from None
    except Exception as exc:
        if pool is not None:
            pool.stop(signal.SIGTERM, wait=True)
        folder.update_manifest(status="failed", error=f"{type(exc).__name__}: {exc}",
                               wall_time_s=round(wall_before + time.perf_counter() - t0, 3))
        raise
    finally:
        progress.end(ended)
        progress.close()
        set_compile_notice(notice)
        if pool is not None:
            pool.close()
        if own:
            stop.restore()
