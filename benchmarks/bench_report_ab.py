"""report.html of the current tree against an earlier revision's, in one process.

The committed reproduction's folder (``runs/p4s_paper-reproduction``, or
``--folder``) is read once per revision and its page built ``--repeat``
times by each (CPU seconds, the best; the revisions alternate); then each
revision's first page in a fresh process (imports included, as an
``optdesign run`` pays it), ``--fresh`` times each, alternating.  The
earlier revision's package is extracted from git as ``optdesign_<rev>``
(``bench_evaluate_ab.py``).  The two pages must hold the same figures
(traces, layouts, configs and frames parsed and compared) and the same text.

    python benchmarks/bench_report_ab.py [--rev 27de7e1] [--repeat 7] [--fresh 3]

The ratios are the point (the machine may be shared).
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_evaluate_ab import ROOT, _old_package  # noqa: E402

_DEC = json.JSONDecoder()


def _figures(page: str):
    """(the page without its figures' scripts, [[data, layout, config] (+ frames)] per figure)."""
    figs, rest, pos = [], [], 0
    for m in re.finditer(r'Plotly\.newPlot\(\s*"[^"]+",\s*', page):
        rest.append(page[pos:m.start()])
        i, vals = m.end(), []
        for _ in range(3):
            v, i = _DEC.raw_decode(page, i)
            vals.append(v)
            while page[i] in ", \n":
                i += 1
        j, k = page.find("Plotly.addFrames(", i), page.find("Plotly.newPlot(", i)
        if j != -1 and (k == -1 or j < k):
            j = page.index(",", j) + 1
            v, i = _DEC.raw_decode(page, j + len(page[j:]) - len(page[j:].lstrip()))
            vals.append(v)
        figs.append(vals)
        pos = i
    rest.append(page[pos:])
    return "".join(rest), figs


_FRESH = """
import sys, time
sys.path.insert(0, {path!r})
t = time.process_time()
from {pkg}.report.html.report import build_report, load_run
build_report(load_run({folder!r}))
print(time.process_time() - t)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rev", default="27de7e1", help="the earlier revision (default: the last with plotly's objects)")
    ap.add_argument("--folder", default=os.path.join(ROOT, "runs", "p4s_paper-reproduction"))
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--fresh", type=int, default=3)
    a = ap.parse_args(argv)
    sys.path.insert(0, ROOT)
    import optdesign.report.html.report as new

    old_pkg = _old_package(a.rev)
    old = __import__(f"{old_pkg.__name__}.report.html.report", fromlist=["build_report"])
    runs = {"current": (new, new.load_run(a.folder)), a.rev: (old, old.load_run(a.folder))}
    pages = {k: m.build_report(r) for k, (m, r) in runs.items()}
    (text_a, figs_a), (text_b, figs_b) = (_figures(p) for p in pages.values())
    same = text_a == text_b and figs_a == figs_b
    best = {k: float("inf") for k in runs}
    for _ in range(a.repeat):
        for k, (m, r) in runs.items():
            t = time.process_time()
            m.build_report(r)
            best[k] = min(best[k], time.process_time() - t)
    fresh = {k: [] for k in runs}
    for _ in range(a.fresh):
        for k in runs:
            path = ROOT if k == "current" else os.path.dirname(os.path.dirname(old_pkg.__file__))
            pkg = "optdesign" if k == "current" else old_pkg.__name__
            code = _FRESH.format(path=path, pkg=pkg, folder=a.folder)
            out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                                 cwd=tempfile.gettempdir())
            fresh[k].append(float(out.stdout.strip().splitlines()[-1]))
    print(f"folder: {a.folder}")
    print(f"same figures and text: {'yes' if same else 'NO'} ({len(figs_a)} figures)")
    print(f"build_report, best of {a.repeat} (CPU s): current {best['current']:.3f}, {a.rev} {best[a.rev]:.3f}, "
          f"ratio {best[a.rev] / best['current']:.2f}")
    print(f"first page in a fresh process, imports included, best of {a.fresh} (CPU s): current "
          f"{min(fresh['current']):.3f}, {a.rev} {min(fresh[a.rev]):.3f}, "
          f"ratio {min(fresh[a.rev]) / min(fresh['current']):.2f}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
