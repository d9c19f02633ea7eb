"""Results of every shipped config against an earlier revision, value for value.

For each config in ``configs/`` (the batch file excepted) the config's named
designs plus ``--random`` designs drawn uniformly (seeded) inside its design
variables' bounds are evaluated with ``optdesign evaluate --json``, on the
compiled path (``OPTDESIGN_FAST=1``) and on the numpy path (``OPTDESIGN_FAST=0``),
by the working tree and by the revision ``--base`` (its tree exported with
``git archive`` to a directory under the temp dir, kept between runs so its
numba cache survives).  Unless ``--no-reproduce``, ``optdesign reproduce`` (the
paper's run, Pareto stages included) is run by both and their results.json
compared, timings and paths left out.

Every number of the two JSON documents is compared exactly (JSON floats
round-trip, so equal text means equal bits); a difference is reported with
its path, both values and its distance in ulps.  The exit status is 1 when any
value differs, 0 otherwise.

    python benchmarks/bench_results_ab.py [--base 34e955f] [--random 3] [--configs delta gough_stewart]
                                          [--paths 1 0] [--no-reproduce]

The default base, 34e955f, is the last revision before the engine work of the
issue "One engine" (its results are the ones that must not move).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: keys of results.json that hold times, dates, paths or versions, not results
VOLATILE = ("time", "seconds", "elapsed", "date", "started", "finished", "path", "folder",
            "version", "commit", "host", "python", "platform", "jobs", "cpu", "wall", "duration")


def base_tree(rev: str) -> str:
    """The tree of revision ``rev``, exported once to a directory under the temp dir."""
    sha = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short=12", rev], check=True,
                         capture_output=True, text=True).stdout.strip()
    d = os.path.join(tempfile.gettempdir(), f"optdesign_tree_{sha}")
    if not os.path.exists(os.path.join(d, ".complete")):
        os.makedirs(d, exist_ok=True)
        arch = subprocess.run(["git", "-C", ROOT, "archive", sha], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", d], input=arch, check=True)
        open(os.path.join(d, ".complete"), "w").close()
    return d


def run(tree: str, args: list[str], fast: str, cwd: str | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=tree, OPTDESIGN_FAST=fast, MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-m", "optdesign", *args], check=False, cwd=cwd or tree, env=env,
                          capture_output=True, text=True)


def with_random_designs(path: str, k: int, seed: int, out_dir: str) -> str:
    """A copy of the config at ``path`` with ``k`` random designs added (inside the
    bounds of its design variables, in the config's units), written to out_dir."""
    with open(path) as f:
        cfg = yaml.safe_load(f)
    dv = cfg.get("design_variables") or {}
    bounded = {n: v["bounds"] for n, v in dv.items() if isinstance(v, dict) and v.get("bounds")}
    if not bounded:   # a config without bounds: within 10 % of each variable's value
        bounded = {n: sorted([0.9 * v["value"], 1.1 * v["value"]]) for n, v in dv.items()
                   if isinstance(v, dict) and isinstance(v.get("value"), (int, float)) and v["value"]}
    designs = dict(cfg.get("designs") or {})
    if bounded and k:
        template = next(iter(designs.values()), None) or {
            n: v["value"] for n, v in dv.items() if isinstance(v, dict) and "value" in v}
        rng = np.random.default_rng(seed)
        for i in range(k):
            d = dict(template)
            for n, (lo, hi) in bounded.items():
                d[n] = float(lo + (hi - lo) * rng.random())
            designs[f"random_{i}"] = d
    cfg["designs"] = designs
    dst = os.path.join(out_dir, os.path.basename(path))
    with open(dst, "w") as f:
        yaml.safe_dump(cfg, f, sort_keys=False)
    return dst


def ulps(a: float, b: float) -> float:
    if a == b:
        return 0.0
    if not (math.isfinite(a) and math.isfinite(b)):
        return math.inf
    return abs(a - b) / np.spacing(max(abs(a), abs(b)))


def compare(a, b, path="", out=None, skip=()):
    """Differences between two JSON documents: (path, a, b, ulps) for every number
    that differs, structure differences as (path, a, b, inf)."""
    out = [] if out is None else out
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if any(s in key.lower() for s in skip):
                continue
            if key not in a or key not in b:
                out.append((f"{path}/{key}", a.get(key, "<missing>"), b.get(key, "<missing>"), math.inf))
            else:
                compare(a[key], b[key], f"{path}/{key}", out, skip)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append((path, f"len {len(a)}", f"len {len(b)}", math.inf))
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, f"{path}[{i}]", out, skip)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if not (a == b or (math.isnan(a) and math.isnan(b))):
            out.append((path, a, b, ulps(float(a), float(b))))
    elif a != b:
        out.append((path, a, b, math.inf))
    return out


def count_numbers(doc) -> int:
    if isinstance(doc, dict):
        return sum(count_numbers(v) for v in doc.values())
    if isinstance(doc, list):
        return sum(count_numbers(v) for v in doc)
    return int(isinstance(doc, (int, float)) and not isinstance(doc, bool))


def report(label: str, diffs, n: int, seconds: tuple[float, float]) -> bool:
    state = "bitwise equal" if not diffs else f"{len(diffs)} of {n} values differ"
    print(f"{label:42s} {n:6d} values  {state}   (base {seconds[0]:.1f} s, now {seconds[1]:.1f} s)")
    for p, x, y, u in diffs[:8]:
        print(f"    {p}: base {x!r}  now {y!r}  ({u:.3g} ulp)")
    return not diffs


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", default="34e955f", help="revision to compare with (default: 34e955f)")
    ap.add_argument("--random", type=int, default=3, help="random designs per config (default 3)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--configs", nargs="*", help="config names (default: every shipped config)")
    ap.add_argument("--paths", nargs="*", default=["1", "0"], help="OPTDESIGN_FAST values (default: 1 0)")
    ap.add_argument("--no-reproduce", action="store_true", help="skip the reproduction's results.json")
    a = ap.parse_args(argv)

    base = base_tree(a.base)
    names = a.configs or sorted(f[:-5] for f in os.listdir(os.path.join(ROOT, "configs"))
                                if f.endswith(".yaml") and f != "batch_example.yaml")
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            cfg = with_random_designs(os.path.join(ROOT, "configs", name + ".yaml"), a.random,
                                      a.seed, tmp)
            for fast in a.paths:
                docs, secs = [], []
                for tree in (base, ROOT):
                    t0 = time.perf_counter()
                    res = run(tree, ["evaluate", cfg, "--json"], fast)
                    secs.append(time.perf_counter() - t0)
                    if res.returncode:
                        docs.append({"error": res.stderr.strip().splitlines()[-1:]})
                        print(f"    {'base' if tree == base else 'now'}: exit {res.returncode}: {docs[-1]['error']}")
                    else:
                        docs.append(json.loads(res.stdout))
                diffs = compare(docs[0], docs[1], skip=("config",))
                ok &= report(f"{name} (OPTDESIGN_FAST={fast})", diffs, count_numbers(docs[1]), tuple(secs))
        if not a.no_reproduce:
            docs, secs = [], []
            for i, tree in enumerate((base, ROOT)):
                out = os.path.join(tmp, f"repro{i}")
                t0 = time.perf_counter()
                res = run(tree, ["reproduce", "--out", out, "--quiet"], "1")
                secs.append(time.perf_counter() - t0)
                if res.returncode:
                    print(res.stderr[-2000:])
                    return 1
                (folder,) = [os.path.join(out, d) for d in os.listdir(out)]
                with open(os.path.join(folder, "results.json")) as f:
                    docs.append(json.load(f))
            diffs = compare(docs[0], docs[1], skip=VOLATILE)
            ok &= report("reproduce results.json", diffs, count_numbers(docs[1]), tuple(secs))
    print("all bitwise equal" if ok else "DIFFERENCES (see above)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
