"""optdesign compare RUN_DIR RUN_DIR... [--out FILE]: one page setting runs side by side."""
from __future__ import annotations

from pathlib import Path

COMMAND = "compare"


def register(sub):
    p = sub.add_parser(COMMAND, help="write one HTML page setting finished runs side by side",
                       description="Write one self-contained HTML page comparing finished run folders: their "
                                   "optima (config units), global indices and manifests side by side, their "
                                   "Pareto fronts overlaid, the convergence of their weighted sums.")
    p.add_argument("run_dirs", nargs="+", metavar="RUN_DIR", help="finished run folders")
    p.add_argument("--out", default="compare.html", metavar="FILE",
                   help="the page to write, an .html file (default: compare.html in the current folder)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._common import UsageError, check_out_file
    from ..report.html import write_compare_html
    from ..runs import RunFolderError

    check_out_file(args.out, "--out")
    out = Path(args.out)
    if len(args.run_dirs) < 2:
        raise UsageError("compare: expected at least two RUN_DIRs")
    try:
        path = write_compare_html(args.run_dirs, out)
    except RunFolderError as exc:
        raise UsageError(str(exc)) from None
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB, {len(args.run_dirs)} runs)")
    return 0
