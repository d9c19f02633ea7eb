"""optdesign status RUN_DIR: the progress of a run (its progress.json), also
from another terminal while the run goes on."""
from __future__ import annotations

COMMAND = "status"


def register(sub):
    p = sub.add_parser(COMMAND, help="show a run's progress (its progress.json), also while it runs",
                       description="Print RUN_DIR/progress.json, which a run updates at most once a second: the "
                                   "stages done, the percentage, the elapsed time and the ETA, each running stage's "
                                   "generation and best value (in the config's units, unit named), the finished "
                                   "stages' results, and how the run ended. Works from another terminal while "
                                   "the run goes on.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a run folder (running, interrupted or finished)")
    p.add_argument("--json", action="store_true", help="print progress.json as it is")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._common import UsageError, json_text
    from ..optimize.watch import read_status, status_lines
    from ..runs import RunFolderError

    try:
        data = read_status(args.run_dir)
    except RunFolderError as exc:
        raise UsageError(str(exc)) from None
    if args.json:
        print(json_text(data))
    else:
        print("\n".join(status_lines(args.run_dir, data)))
    return 0
