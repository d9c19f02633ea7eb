"""The gradient polish's cost per call, against an earlier revision in one process.

The polish (SLSQP on one design at a time, :mod:`optdesign.optimize.polish`)
is where a run spends most of its time after the GA (docs/performance.md,
"Where the reproduction's time goes" and "The test suite's time").  This
prints, per config:

* ``derivatives()`` of one design, values only (SLSQP's line searches) and
  full (values and design derivatives), in ms per call, best of --repeat
  passes over the same 20 designs of the middle of the box, each pass with
  the answers kept for repeated requests forgotten; the route (AD
  through CasADi, or central differences on the Evaluator);
* for the first config, ``polish_designs`` for each index and sense (as the
  extremes' multi-start runs them) from the 3 best designs of a Sobol scan,
  best of --repeat: the wall time, SLSQP iterations, gradient evaluations and value-only
  evaluations (SLSQP's line searches ask for values several times per
  iteration where they backtrack).

With ``--base REV`` the same measurements run on that revision's package
(extracted by git into a temporary folder, as bench_evaluate_ab.py does)
in alternation with this tree's, and print the ratios and the largest
relative difference of the values (0: the same bits).

    python benchmarks/bench_polish.py [--configs p4s_paper,delta_opt,sps_s_opt] [--repeat 3] [--base REV]

The machine may be shared: the load is printed; the ratios are the point.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

DESIGNS = 20


def _load() -> str:
    return "load {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


class Side:
    """One package (this tree's ``optdesign`` or a revision's copy) on one config."""

    def __init__(self, pkg, config: str):
        mod = lambda m: importlib.import_module(f"{pkg.__name__}.{m}")
        cfg = mod("config").load_config(ROOT / "configs" / f"{config}.yaml")
        ev_mod = mod("evaluate")
        self.ev = ev_mod.Evaluator.from_config(cfg, ev_mod.workspace_of(cfg))
        self.derivatives = mod("gradients").derivatives
        self.mod = mod
        rng = np.random.default_rng(0)
        self.X = self.ev.xl + (self.ev.xu - self.ev.xl) * rng.uniform(0.3, 0.7, (DESIGNS, len(self.ev.xl)))
        self.route = self.derivatives(self.ev, self.X[:1], "auto").route

    def forget(self):
        """Empty the answers kept for repeated requests (derivatives' memo and
        the Evaluator's worst-case searches): a pass over the same designs
        then costs what a first request does, not a lookup."""
        self.mod("gradients")._MEMOS.pop(self.ev, None)
        getattr(self.ev, "_memo", {}).clear()

    def calls(self, values_only: bool):
        self.forget()
        out = []
        with np.errstate(all="ignore"):
            for x in self.X:
                out.append(self.derivatives(self.ev, x[None], "auto", values_only=values_only))
        return out

    def polish(self):
        """One polish per index and sense (as the extremes' multi-start runs
        them) from the 3 best designs of a 64-design Sobol scan: (wall s,
        SLSQP iterations, gradient evaluations, value-only evaluations, the
        values found)."""
        polish = self.mod("optimize.polish")
        problem_mod = self.mod("optimize.problem")
        extremes = self.mod("optimize.extremes")
        X = extremes.extremes_scan(self.ev.xl, self.ev.xu, 64)
        vals, _, ok = extremes.evaluate_batches(self.ev, X)
        counted = {"values": 0}
        real = polish.derivatives

        def counting(ev, X, route="auto", values_only=False):
            counted["values"] += bool(values_only)
            return real(ev, X, route, values_only)

        its = grads = 0
        found = []
        self.forget()
        polish.derivatives = counting
        try:
            t = time.perf_counter()
            for name in self.ev.index_names:
                for sense in ("min", "max"):
                    term = problem_mod.index_term(name, sense)
                    f = np.where(ok, np.asarray(polish.term_value(term, vals), float), np.inf)
                    got = polish.polish_designs(problem_mod.DesignProblem(self.ev, [term]), X[np.argsort(f)[:3]],
                                                join=False)
                    its += sum(r["iterations"] for r in got["runs"])
                    grads += got["evaluations"]
                    found.append(None if got["best"] is None else got["best"][1])
            wall = time.perf_counter() - t
        finally:
            polish.derivatives = real
        return wall, its, grads, counted["values"], found


def _best_ms(fn, repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best / DESIGNS * 1e3


def _rel(a, b) -> float:
    """The largest relative difference of two arrays (0.0: the same bits; NaN where both are NaN)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return np.inf
    both = np.isnan(a) & np.isnan(b)
    with np.errstate(all="ignore"):
        r = np.where(both | (a == b), 0.0, np.abs(a - b) / np.maximum(np.abs(b), 1e-300))
    return float(np.max(r, initial=0.0))


def _largest_difference(a, b) -> float:
    """The largest relative difference of the values and constraints of two lists of Derivatives."""
    worst = 0.0
    for da, db in zip(a, b):
        for k in da.values:
            worst = max(worst, _rel(da.values[k], db.values[k]))
        for k in da.constraints:
            worst = max(worst, _rel(da.constraints[k], db.constraints[k]))
    return worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--configs", default="p4s_paper,delta_opt,sps_s_opt")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--base", default=None, help="an earlier revision to compare against (git rev)")
    args = ap.parse_args()
    import optdesign

    base_pkg = None
    if args.base:
        from bench_evaluate_ab import _old_package

        base_pkg = _old_package(args.base)
    print(f"gradient polish, {DESIGNS} designs per pass, best of {args.repeat} ({_load()})")
    for k, config in enumerate(args.configs.split(",")):
        sides = {"this tree": Side(optdesign, config)}
        if base_pkg is not None:
            sides[args.base] = Side(base_pkg, config)
        for s in sides.values():          # warm: kernels loaded or compiled, CasADi functions built
            s.calls(True), s.calls(False)
        ms = {name: {"values": np.inf, "full": np.inf} for name in sides}
        for _ in range(args.repeat):       # in alternation: a drift of the machine hits both
            for name, s in sides.items():
                ms[name]["values"] = min(ms[name]["values"], _best_ms(lambda s=s: s.calls(True), 1))
                ms[name]["full"] = min(ms[name]["full"], _best_ms(lambda s=s: s.calls(False), 1))
        here = sides["this tree"]
        print(f"  {config} ({here.route} route, {len(here.ev.workspace.X)} points):")
        for name in sides:
            print(f"    {name:10s} values only {ms[name]['values']:6.2f} ms, full {ms[name]['full']:6.2f} ms per call")
        if base_pkg is not None:
            b = sides[args.base]
            dv = _largest_difference(here.calls(True), b.calls(True))
            df = _largest_difference(here.calls(False), b.calls(False))
            print(f"    ratio (this / {args.base}): values only {ms['this tree']['values'] / ms[args.base]['values']:.2f}, "
                  f"full {ms['this tree']['full'] / ms[args.base]['full']:.2f}; largest relative difference of the "
                  f"values: values only {dv:.1e}, full {df:.1e} (0: the same bits)")
        if k == 0:
            found, runs = {}, {}
            for _ in range(args.repeat):   # in alternation, best of --repeat
                for name, s in sides.items():
                    got = s.polish()
                    if name not in runs or got[0] < runs[name][0]:
                        runs[name] = got
            for name in sides:
                wall, its, grads, values, found[name] = runs[name]
                print(f"    {name:10s} a polish per index and sense, 3 starts each: {wall:5.2f} s, {its} SLSQP "
                      f"iterations, {grads} gradient and {values} value-only evaluations "
                      f"({values / max(its, 1):.1f} per iteration)")
            if base_pkg is not None:
                print(f"    ratio (this / {args.base}): {runs['this tree'][0] / runs[args.base][0]:.2f}")
                print(f"    the polished values' largest relative difference: "
                      f"{_rel(np.array(found['this tree'], float), np.array(found[args.base], float)):.1e} (0: the same bits)")
    print(f"({_load()})")


if __name__ == "__main__":
    main()
