"""optdesign run CONFIG | --resume RUN_DIR: run (or finish) an optimization."""
from __future__ import annotations

import signal
import sys
import time

COMMAND = "run"


def register(sub):
    p = sub.add_parser(COMMAND, help="run a config's optimization into a new run folder (or --resume one)")
    p.add_argument("config", nargs="?", help="YAML config file")
    p.add_argument("--resume", metavar="RUN_DIR", help="finish an interrupted run in its folder")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: the config's optimizer.seed)")
    p.add_argument("--out", default="runs", metavar="DIR", help="parent folder of run folders (default: runs)")
    p.add_argument("--name", default=None, help="run folder name prefix (default: the config's name)")
    p.add_argument("--no-pareto", action="store_true", help="skip the NSGA-II/III Pareto runs")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object (the optimum in the config's units and SI, the global indices, "
                        "the files) instead of the summary line")
    p.add_argument("--open", action="store_true",
                   help="open the run's report.html in the web browser at the end (a line says so where none is available)")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="processes running the GA stages at once (default: the CPUs available); results do not depend on it")
    p.set_defaults(func=run)


def run_json(res, cfg=None, wall: float | None = None) -> dict:
    """A finished run as JSON: what a script reads from it."""
    from ..report.folders import config_of_folder
    from ..units import index_unit, variable_unit

    cfg = cfg or config_of_folder(res.folder.path)
    units = cfg.units()
    r, path = res.results, res.folder.path.resolve()
    out = {"folder": str(path), "status": r["status"], "config": cfg.name, "mechanism": cfg.mechanism,
           "seed": r["seed"], "objective": r["objective"],
           "optimum": {k: {"value": dv.display(r["optimum"][k]), "unit": variable_unit(units, k), "si": r["optimum"][k],
                           "free": dv.free} for k, dv in cfg.design_variables.items()},
           "global_indices": {k: {"mean": v, "unit": index_unit(units, k), "sense": cfg.indices[k].sense}
                              for k, v in r["global_indices"].items() if k in cfg.indices},
           "evaluations": r.get("evaluations"), "wall_time_s": r.get("wall_time_s"),
           "files": {n: str(path / n) for n in ("results.json", "results.md", "report.html", "optimum.yaml")
                     if (path / n).exists()}}
    if wall is not None:
        out["wall_time_total_s"] = round(wall, 3)   # the whole run, the report's writing included
    if r.get("pareto"):
        out["pareto"] = {k: {"front_size": p["front_size"], "hypervolume": p["hypervolume"]} for k, p in r["pareto"].items()}
    return out


def summary_line(res, cfg=None, wall: float | None = None) -> str:
    """One line: the run folder, its status, f, the global indices and the
    optimum (in the config's units with the unit named); ``wall``: the whole
    run's wall time (default: the recorded one, which ends before the report)."""
    from ..report.folders import config_of_folder
    from ..units import design_text, index_text

    r = res.results
    if cfg is None:
        cfg = config_of_folder(res.folder.path)
    units = cfg.units()
    opt = design_text(units, r["optimum"]) or "no free variable"
    idx = ", ".join(index_text(units, k, v) for k, v in r["global_indices"].items() if k in cfg.indices)
    f = r["objective"]
    f_txt = "0 (to round-off)" if abs(f) < 1e-12 else f"{f:.6g}"
    return (f"{res.folder.path}: {r['status']} seed={r['seed']} objective f={f_txt} "
            f"[{idx}] at {opt} ({r.get('evaluations', '?')} evaluations, "
            f"{f'{wall:.1f}' if wall is not None else r.get('wall_time_s', '?')} s)")


def execute(args, after=None, cfg=None) -> int:
    """Run or resume; SIGINT/SIGTERM stop the run at a generation boundary (exit
    130/143, the folder resumable).  A signal that arrives once the run is
    complete changes nothing: the exit status is 0, as the manifest says."""
    from ._common import UsageError, check_name_option, check_out_root, make_out_root, open_config
    from ..optimize.progress import Progress
    from ..runner import resume_run, start_run
    from ..studies.p4s_paper import table3_note
    from ..optimize.workers import Interrupted, StopRequest, default_jobs
    from ..runs import RunFolderError

    t_start = time.perf_counter()
    progress = Progress(False if args.quiet else None)
    if args.resume and args.config:
        raise UsageError("run: give a CONFIG or --resume RUN_DIR, not both")
    if args.seed is not None and not 0 <= args.seed < 2 ** 32:
        raise UsageError(f"--seed: expected an integer in [0, 2^32), got {args.seed}")
    if args.jobs is not None and args.jobs < 1:
        raise UsageError(f"--jobs: expected a positive integer, got {args.jobs}")
    jobs = default_jobs() if args.jobs is None else args.jobs
    if not args.resume:
        # everything that can be checked is checked before the run folder is made:
        # a rejected run leaves nothing on disk
        check_name_option(args.name, "--name")
        check_out_root(args.out)
        cfg = cfg if cfg is not None else open_config(args.config)
        cfg.check_optimizable(pareto=not args.no_pareto)
        make_out_root(args.out)
    stop = StopRequest(deferred=False).install()   # until the run starts, a signal stops at once
    done = False
    try:
        try:
            if args.resume:
                res = resume_run(args.resume, progress, jobs=jobs, stop=stop, reference_note=table3_note)
            else:
                res = start_run(cfg, args.seed, args.out, args.name, progress, pareto=not args.no_pareto, jobs=jobs,
                                stop=stop, reference_note=table3_note)
        except RunFolderError as exc:
            raise UsageError(str(exc)) from None
        except Interrupted as exc:
            where = getattr(exc, "folder", None) or stop.folder
            if where is None:
                print("optdesign: interrupted before the run started", file=sys.stderr)
            else:
                print(f"optdesign: run interrupted; its last checkpoint is saved. "
                      f"Finish it with: optdesign run --resume {where}", file=sys.stderr)
            return 130 if exc.signum == 2 else 143
        except RuntimeError as exc:
            print(f"optdesign: run failed: {exc}", file=sys.stderr)
            return 1
        stop.completed = done = True
        wall = getattr(res, "wall_before_s", 0.0) + time.perf_counter() - t_start
        if getattr(args, "json", False):
            from ._common import json_text

            print(json_text(run_json(res, cfg, wall)))
        else:
            print(summary_line(res, cfg, wall))
            for what, name in (("report", "report.html"), ("results", "results.md")):
                if (res.folder.path / name).exists():
                    print(f"{what}: {res.folder.path / name}")
        if getattr(args, "open", False):
            open_report(res.folder.path / "report.html", sys.stderr if getattr(args, "json", False) else sys.stdout)
        if after is not None:
            after(res)
        return 0
    finally:
        stop.restore()
        if done and getattr(args, "process_entry", False):
            # the process that is the command ignores them until it has exited
            # (Python's own handlers are reset while the interpreter shuts down;
            # an ignored signal stays ignored), so its status stays the manifest's
            for sig in (signal.SIGINT, signal.SIGTERM):
                signal.signal(sig, signal.SIG_IGN)


def open_report(path, out) -> bool:
    """Open report.html in the web browser (Python's webbrowser); a line says
    what happened, also where no browser is available."""
    import webbrowser

    if not path.exists():
        print(f"--open: no report.html in {path.parent}", file=out)
        return False
    try:
        opened = webbrowser.open(path.resolve().as_uri())
    except webbrowser.Error:
        opened = False
    print(f"opened {path} in the web browser" if opened else
          f"--open: no web browser available; open {path} yourself", file=out)
    return opened


def run(args) -> int:
    if not args.config and not args.resume:
        from ._common import UsageError

        raise UsageError("run: expected a CONFIG file or --resume RUN_DIR")
    return execute(args)
