"""optdesign summarize RUNS...: run folders -> one CSV/Markdown table and a plot of the spread across seeds."""
from __future__ import annotations

import sys
from pathlib import Path

COMMAND = "summarize"


def register(sub):
    p = sub.add_parser(COMMAND, help="gather run folders into one table (CSV, Markdown) and a spread plot (PNG)",
                       description="Gather run folders (given directly, or the run folders inside the given "
                                   "folders) into summary.csv (one row per run: config, sweep, config key, run key, "
                                   "seed, status, objective, optimum, global indices, wall time), summary.md "
                                   "(statistics across seeds per resolved config) and summary.png.")
    p.add_argument("paths", nargs="+", metavar="RUNS", help="run folders, or folders holding run folders")
    p.add_argument("--out", default=None, metavar="DIR",
                   help="where to write summary.* (default: the given folder if it holds run folders, "
                        "else the parent of the first run folder)")
    p.add_argument("--no-plot", action="store_true", help="skip summary.png")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object (every run's row and the statistics per config) instead of tables")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..report.summary import collect_folders, row_from_folder, summarize
    from ._common import UsageError, check_out_root, make_out_root
    from ..runs import RunFolderError

    if args.out is not None:
        check_out_root(args.out)

    try:
        folders = collect_folders(args.paths)
    except RunFolderError as exc:
        raise UsageError(str(exc)) from None
    if not folders:
        raise UsageError(f"no run folders (folders with a manifest.json) in {', '.join(args.paths)}")
    rows = []
    for f in folders:
        try:
            rows.append(row_from_folder(f))
        except RunFolderError as exc:
            print(f"optdesign: skipping {exc}", file=sys.stderr)
    if not rows:
        raise UsageError("no readable run folders")
    if args.out is not None:
        out = Path(args.out)
    else:
        first = Path(args.paths[0])
        out = first.parent if (first / "manifest.json").is_file() else first
    make_out_root(str(out), "--out" if args.out is not None else "RUNS")
    csv_path, md_path = summarize(rows, out, plot=not args.no_plot)
    png = md_path.with_suffix(".png")
    if args.json:
        from ..report.summary import group_stats
        from ._common import json_text

        print(json_text({"runs": len(rows), "complete": sum(1 for r in rows if r.get("status") == "complete"),
                          "summary": {"csv": str(csv_path), "markdown": str(md_path),
                                      "plot": str(png) if png.exists() and not args.no_plot else None},
                          "rows": rows, "groups": group_stats(rows)}))
        return 0
    from ..tables import print_text

    print_text(md_path.read_text())
    print(f"summary of {len(rows)} runs: {csv_path}, {md_path}" + (f", {png}" if png.exists() and not args.no_plot else ""))
    return 0
