"""optdesign bench --list | NAME [ARGS...]: the scripts in ``benchmarks/``.

A thin front end: ``--list`` prints every benchmark with the first sentence
of its docstring; ``optdesign bench NAME ARGS`` runs ``python
benchmarks/<NAME>.py ARGS`` (NAME with or without its ``bench_`` prefix) in a
fresh process, with this checkout on the module path, and returns its exit
status.  The measurements live in the scripts.  ``benchmarks/`` sits beside
the package in the repository; an installation without it (a wheel) says so.
"""
from __future__ import annotations

import argparse
import ast
import os
import re
import subprocess
import sys
from pathlib import Path

COMMAND = "bench"


def register(sub):
    p = sub.add_parser(COMMAND, help="run a benchmark of benchmarks/ (--list shows them)",
                       description="Run a script of the repository's benchmarks/ folder: "
                                   "'optdesign bench NAME [ARGS...]' is 'python benchmarks/NAME.py ARGS'; "
                                   "'optdesign bench NAME --help' shows its options.")
    p.add_argument("--list", action="store_true", help="list the benchmarks with a one-line description")
    p.add_argument("name", nargs="?", metavar="NAME", help="a benchmark (e.g. throughput or bench_throughput)")
    p.add_argument("args", nargs=argparse.REMAINDER, metavar="ARGS", help="the benchmark's own options")
    p.set_defaults(func=run)


def benchmarks_dir() -> Path | None:
    """The repository's ``benchmarks/`` folder beside the (editable) package, or
    None (installed from a wheel: no repository around the package; a
    ``benchmarks`` folder of some other project in site-packages is not ours)."""
    import optdesign

    root = Path(optdesign.__file__).resolve().parent.parent
    d = root / "benchmarks"
    return d if d.is_dir() and (root / "pyproject.toml").is_file() else None


def benchmarks(folder: Path) -> dict[str, Path]:
    """Every benchmark script of ``folder`` (``*.py`` not starting with ``_``), by name."""
    return {p.stem: p for p in sorted(folder.glob("*.py")) if not p.name.startswith("_")}


def summary(path: Path, width: int = 100) -> str:
    """The first sentence of the script's module docstring (read, not imported), on one line."""
    try:
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"), str(path))) or ""
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return "(docstring unreadable)"
    text = " ".join(doc.split("\n\n", 1)[0].split()).replace("``", "")
    m = re.search(r"[:;](\s|$)|\.(\s+(?=[A-Z])|$)", text)   # not at "eq. 29"
    text = text[:m.start()] if m else text
    if len(text) > width:
        text = text[:width - 3].rsplit(" ", 1)[0] + "..."
    return text or "(no docstring)"


def resolve(name: str, found: dict[str, Path]) -> Path:
    """The script of ``name`` (with or without its ``bench_`` prefix); a UsageError if none."""
    from ..checking import shorten, suggest
    from ._common import UsageError

    for key in (name, f"bench_{name}", name[:-3] if name.endswith(".py") else None):
        if key in found:
            return found[key]
    short = {k.removeprefix("bench_"): k for k in found}
    hint = suggest(name, list(found)) or suggest(name, list(short))
    raise UsageError(f"bench: no benchmark named {shorten(name)}{hint}; see 'optdesign bench --list'")


def run(args) -> int:
    from ._common import UsageError

    folder = benchmarks_dir()
    if folder is None:
        raise UsageError("bench: no benchmarks/ folder beside the package (it ships with the repository, "
                         "not with an installed wheel); run it from a checkout installed with 'pip install -e .'")
    found = benchmarks(folder)
    if args.list or not args.name:
        if args.name or args.args:
            raise UsageError("bench: --list takes no benchmark name")
        width = max(map(len, found), default=0)
        for k, p in found.items():
            print(f"{k:<{width}}  {summary(p)}")
        if not args.list:
            print("\nrun one with 'optdesign bench NAME [ARGS...]'; 'optdesign bench NAME --help' shows its options")
        return 0
    script = resolve(args.name, found)
    root = str(folder.parent)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([root] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    sys.stdout.flush()
    proc = subprocess.Popen([sys.executable, str(script), *args.args], env=env)
    try:
        return proc.wait()
    except BaseException:          # Ctrl-C reaches the child too; SIGTERM (Terminated) ends it here
        proc.terminate()
        proc.wait()
        raise
