"""optdesign batch CONFIG... --seeds N [--backend local|dask]: configs × sweeps × seeds, one summary table."""
from __future__ import annotations

import re
import sys

COMMAND = "batch"

#: a Dask scheduler address: [tcp:// or tls://]HOST:PORT (HOST may be [IPv6])
_ADDRESS = re.compile(r"^(?:(?:tcp|tls)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):\d{1,5}$")


def register(sub):
    p = sub.add_parser(COMMAND, help="run configs (or batch files with sweeps) × seeds in parallel and tabulate them",
                       description="Run configs or batch files (base config + sweep, see docs/scaling.md) × seeds, "
                                   "on the local cores or a Dask cluster. Each run lands in OUT/<name>-s<seed>-<key>/; "
                                   "rerunning skips finished runs and resumes unfinished ones.")
    p.add_argument("configs", nargs="+", metavar="CONFIG", help="YAML config files or batch files")
    p.add_argument("--seeds", type=int, default=None, metavar="N",
                   help="seeds per config: the config's optimizer.seed and the N-1 after it "
                        "(default: a batch file's seeds, else 1)")
    p.add_argument("--seed-list", default=None, metavar="S1,S2,...", help="explicit seeds (overrides --seeds)")
    p.add_argument("--jobs", type=int, default=None, metavar="J",
                   help="local worker processes (default 2); with --backend dask the cluster's worker threads decide")
    p.add_argument("--out", default="runs", metavar="DIR",
                   help="parent folder of the run folders (default runs; with dask, a path every worker sees)")
    p.add_argument("--pareto", action="store_true", default=None, help="also run the NSGA-II/III fronts in each run")
    p.add_argument("--backend", choices=("local", "dask"), default="local",
                   help="local: joblib's process pool on this machine (default); dask: a Dask cluster")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT", help="Dask scheduler address (--backend dask)")
    p.add_argument("--timeout", type=float, default=10.0, metavar="S",
                   help="seconds to wait for the Dask scheduler and its first worker (default 10)")
    p.add_argument("--dry-run", action="store_true",
                   help="validate the files and list the planned runs (new, resume or done) without running them")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object (every run's row and the statistics per config) instead of tables")
    p.add_argument("--retries", type=int, default=2, metavar="R",
                   help="resubmissions of runs lost with a dead worker or failed on it (default 2)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..batch import BatchInterrupted, stop_on_signals

    try:
        with stop_on_signals():
            return _run(args)
    except BatchInterrupted as exc:
        print(f"optdesign: batch interrupted ({'SIGINT' if exc.signum == 2 else 'SIGTERM'}); its workers are "
              "stopped, finished runs are kept and a rerun of the same command resumes the others", file=sys.stderr)
        return 128 + exc.signum


def _seed_list(text: str) -> list[int]:
    from ..config.reader import shorten
    from ._common import UsageError

    parts = [s.strip() for s in text.split(",")]
    if not any(parts):
        raise UsageError(f"--seed-list: expected at least one seed (integers separated by commas), got {shorten(text)}")
    if any(not p for p in parts):
        raise UsageError(f"--seed-list: an empty entry in {shorten(text)}; expected integers separated by commas")
    import re

    try:
        if not all(re.fullmatch(r"[+-]?[0-9]{1,20}", p) for p in parts):  # ASCII digits only ('٣' is not 3)
            raise ValueError(text)
        seeds = [int(p) for p in parts]
    except ValueError:
        raise UsageError(f"--seed-list: expected integers separated by commas, got {shorten(text)}") from None
    if any(not 0 <= s < 2 ** 32 for s in seeds):
        raise UsageError("--seed-list: expected seeds in [0, 2^32)")
    return seeds


def _run(args) -> int:
    from ..batch import BackendError, connect_dask, plan, run_batch
    from ..report.summary import summarize
    from ..studies.p4s_paper import table3_note
    from ._common import UsageError, check_out_root, make_out_root

    if args.seeds is not None and not 1 <= args.seeds <= 100_000:
        raise UsageError(f"--seeds: expected a positive integer (at most 100000), got {args.seeds}")
    if args.jobs is not None and not 1 <= args.jobs <= 1024:
        raise UsageError(f"--jobs: expected a positive integer (at most 1024), got {args.jobs}")
    if not 0 <= args.retries <= 100:
        raise UsageError(f"--retries: expected a non-negative integer (at most 100), got {args.retries}")
    if not 0 < args.timeout <= 86_400:
        raise UsageError(f"--timeout: expected a positive number of seconds (at most 86400), got {args.timeout:g}")
    if args.backend == "dask" and not args.scheduler:
        raise UsageError("--backend dask needs --scheduler tcp://HOST:PORT (the address of a running Dask scheduler)")
    if args.scheduler and not _ADDRESS.match(args.scheduler):
        from ..config.reader import shorten

        raise UsageError(f"--scheduler: expected an address such as tcp://HOST:PORT, got {shorten(args.scheduler)}")
    if args.backend == "dask" and args.jobs is not None:
        raise UsageError("--jobs is for --backend local; with dask every worker thread of the cluster takes runs "
                         "(start fewer workers or threads to run fewer at once)")
    if args.backend == "local" and args.scheduler:
        raise UsageError("--scheduler is only used with --backend dask")
    seeds = _seed_list(args.seed_list) if args.seed_list is not None else None
    check_out_root(args.out)
    tasks = plan(args.configs, args.seeds, seeds, pareto=args.pareto)
    if args.dry_run:
        from pathlib import Path

        for t in tasks:
            d = Path(args.out) / t.folder_name
            state = "new"
            if (d / "manifest.json").is_file():
                state = "done" if (d / "results.json").is_file() else "resume"
            sweep = ", ".join(f"{k}={v}" for k, v in t.sweep.items())
            print(f"{state:6} {d}" + (f"  [{sweep}]" if sweep else ""))
        print(f"batch: {len(tasks)} runs planned (dry run: nothing was run)", file=sys.stderr)
        return 0
    client = None
    try:
        if args.backend == "dask":     # connected (or refused, one line) before anything is said or written
            try:
                client = connect_dask(args.scheduler, args.timeout)
            except BackendError as exc:
                raise UsageError(str(exc)) from None
        make_out_root(args.out)
        if client is not None:
            from pathlib import Path

            from ..batch.execute import check_shared_folder

            try:
                check_shared_folder(client, str(Path(args.out).resolve()))
            except BackendError as exc:
                raise UsageError(str(exc)) from None
        where = f"{args.jobs or 2} local workers" if args.backend == "local" else f"Dask cluster {args.scheduler}"
        print(f"batch: {len(tasks)} runs ({len(args.configs)} files) on {where} -> {args.out}/", file=sys.stderr)
        from ..optimize.progress import COMPILE_NOTICE, CountProgress

        progress = CountProgress(len(tasks), enabled=None if not args.json else False)
        if progress.enabled and _cold_kernels():
            progress.say(f"batch: the first runs may be slow: {COMPILE_NOTICE}", file=sys.stderr)

        def show(row):
            progress.done(counted=row.get("this_batch") != "done")
            if args.json:
                return
            progress.say(_row_line(row))

        try:
            rows = run_batch(tasks, args.out, args.jobs, backend=args.backend, scheduler=args.scheduler,
                             on_result=show, retries=args.retries, timeout=args.timeout, client=client,
                             reference_note=table3_note)
        except BackendError as exc:
            raise UsageError(str(exc)) from None
        finally:
            progress.close()
    finally:
        if client is not None:
            client.close()
    csv_path, md_path = summarize(rows, args.out)
    if args.json:
        _print_json(rows, tasks, csv_path, md_path)
    else:
        from ..tables import print_text

        print_text(md_path.read_text())
        print(f"summary: {csv_path}, {md_path}, {md_path.with_suffix('.png')}")
    failed = [r for r in rows if r.get("status") != "complete"]
    if failed:
        print(f"optdesign: {len(failed)} of {len(rows)} runs did not complete (see the table)", file=sys.stderr)
        return 1
    return 0


def _cold_kernels() -> bool:
    """Whether a compiled kernel module the mechanisms registered has no cache yet."""
    from ..fast import KernelModule, kernel_cache_present

    return any(not kernel_cache_present(k.name) for k in KernelModule.instances)


def _row_line(row: dict) -> str:
    """A finished run in one line: the optimum in its config's units."""
    if row.get("status") != "complete":
        return f"{row['folder']}: {row.get('status')} seed={row['seed']} ({row.get('error', '')})"
    opt = ", ".join(f"{k[4:]}={v:.6g}" for k, v in row.items() if k.startswith("opt_"))
    try:
        from pathlib import Path

        from ..report.folders import config_of_folder
        from ..units import design_text

        cfg = config_of_folder(Path(row["folder"]))
        opt = design_text(cfg.units(), {k[4:]: v for k, v in row.items() if k.startswith("opt_")})
    except Exception:  # noqa: BLE001 - the SI values then, named as such
        opt += " (SI)"
    f = row["objective"]
    f_txt = "0 (to round-off)" if abs(f) < 1e-12 else f"{f:.6g}"
    return f"{row['folder']}: {row['this_batch']} seed={row['seed']} objective f={f_txt} at {opt}"


def _print_json(rows, tasks, csv_path, md_path) -> None:
    from ..report.summary import group_stats
    from ._common import json_text

    out = {"runs": len(rows), "complete": sum(1 for r in rows if r.get("status") == "complete"),
           "summary": {"csv": str(csv_path), "markdown": str(md_path), "plot": str(md_path.with_suffix(".png"))},
           "rows": rows, "groups": group_stats(rows)}
    print(json_text(out))
