"""optdesign report RUN_DIR: (re)write the interactive report.html of a finished run."""
from __future__ import annotations

COMMAND = "report"


def register(sub):
    p = sub.add_parser(COMMAND, help="write report.html (interactive, self-contained) in a finished run folder",
                       description="Write RUN_DIR/report.html from the run folder's files: the optimum in the "
                                   "config's units, the global indices, the normalization, convergence per stage, "
                                   "the Pareto fronts (scatter matrix, parallel coordinates), atlases of the "
                                   "optimum's local indices and the manifest. The page works offline.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a finished run folder (manifest.json status: complete)")
    p.add_argument("--resolution", type=int, default=None, metavar="N",
                   help="atlas grid points per axis (default: 81)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._common import UsageError
    from ..report.html.atlas import DEFAULT_RESOLUTION
    from ..report.html import write_report_html
    from ..runs import RunFolderError

    n = DEFAULT_RESOLUTION if args.resolution is None else args.resolution
    if not 2 <= n <= 1000:
        raise UsageError(f"--resolution: expected an integer in [2, 1000], got {n}")
    try:
        out = write_report_html(args.run_dir, atlas_resolution=n)
    except RunFolderError as exc:
        raise UsageError(str(exc)) from None
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB)")
    return 0
