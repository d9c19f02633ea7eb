"""optdesign batch CONFIG... --seeds N --jobs 2: configs × seeds in parallel, one summary table."""
from __future__ import annotations

import sys

COMMAND = "batch"


def register(sub):
    p = sub.add_parser(COMMAND, help="run configs × seeds in parallel (joblib) and tabulate them")
    p.add_argument("configs", nargs="+", metavar="CONFIG", help="YAML config files")
    p.add_argument("--seeds", type=int, default=1, metavar="N",
                   help="seeds per config: the config's optimizer.seed and the N-1 after it (default 1)")
    p.add_argument("--seed-list", default=None, metavar="S1,S2,...", help="explicit seeds (overrides --seeds)")
    p.add_argument("--jobs", type=int, default=2, metavar="J", help="parallel workers (default 2)")
    p.add_argument("--out", default="runs", metavar="DIR", help="parent folder of the run folders (default runs)")
    p.add_argument("--pareto", action="store_true", help="also run the NSGA-II/III fronts in each run")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..batch import plan, run_batch, summarize
    from ..cli import UsageError
    from ..runs import RunFolderError

    if args.seeds < 1:
        raise UsageError(f"--seeds: expected a positive integer, got {args.seeds}")
    if args.jobs < 1:
        raise UsageError(f"--jobs: expected a positive integer, got {args.jobs}")
    seeds = None
    if args.seed_list:
        try:
            seeds = [int(s) for s in args.seed_list.split(",") if s.strip()]
        except ValueError:
            raise UsageError(f"--seed-list: expected integers separated by commas, got {args.seed_list!r}") from None
        if any(s < 0 for s in seeds):
            raise UsageError("--seed-list: expected non-negative seeds")
    tasks = plan(args.configs, args.seeds, seeds, pareto=args.pareto)
    print(f"batch: {len(tasks)} runs ({len(args.configs)} configs) on {args.jobs} workers -> {args.out}/", file=sys.stderr)

    def show(row):
        opt = ", ".join(f"{k[4:]}={v:.6g}" for k, v in row.items() if k.startswith("opt_"))
        print(f"{row['folder']}: {row['this_batch']} seed={row['seed']} objective={row['objective']:.6g} at {opt}", flush=True)

    try:
        rows = run_batch(tasks, args.out, args.jobs, on_result=show)
    except RunFolderError as exc:
        raise UsageError(str(exc)) from None
    csv_path, md_path = summarize(rows, args.out)
    print(md_path.read_text())
    print(f"summary: {csv_path}, {md_path}")
    return 0
