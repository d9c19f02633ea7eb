"""The ``optdesign`` command.

Subcommands live in ``optdesign/commands/<name>.py``; each module defines
``register(subparsers)`` which adds its parser and sets ``func`` (a function of
the parsed arguments returning an exit status).  Exit status: 0 success, 1 a
run that failed or was interrupted, 2 a mistake in the input (config, options),
130 interrupted by Ctrl-C.
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from . import __version__
from .commands._common import UsageError  # owned by the commands; optdesign.cli.UsageError stays an alias
from .config import ConfigError

#: order in which commands are listed in --help
_ORDER = ["reproduce", "run", "init", "evaluate", "atlas", "ik", "fk", "batch", "summarize", "report", "compare",
          "bench", "validate-config", "validate-dynamics"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="optdesign",
        description="Dimensional optimization of parallel mechanisms.",
    )
    parser.add_argument("--version", action="version", version=f"optdesign {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    from . import commands

    mods = []
    for info in pkgutil.iter_modules(commands.__path__):
        if info.name.startswith("_"):
            continue
        mods.append(importlib.import_module(f"{commands.__name__}.{info.name}"))
    registered = []
    for mod in mods:
        reg = getattr(mod, "register", None)
        if reg is not None:
            registered.append((getattr(mod, "COMMAND", mod.__name__), reg))
    registered.sort(key=lambda t: (_ORDER.index(t[0]) if t[0] in _ORDER else len(_ORDER), t[0]))
    for _, reg in registered:
        reg(sub)
    return parser


def _error(message: str) -> int:
    print(f"optdesign: error: {message}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    args.process_entry = argv is None   # this process is the command (not a caller in-process)
    try:
        rc = args.func(args)
        return 0 if rc is None else int(rc)
    except ConfigError as exc:
        return _error(str(exc))
    except UsageError as exc:
        return _error(str(exc))
    except KeyboardInterrupt:
        print("optdesign: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into head and the like
        return 0


if __name__ == "__main__":  # pragma: no cover
    # `python -m optdesign.cli`: run the package module, not this __main__ copy,
    # so that the exception classes the commands raise are the ones caught here
    from optdesign.cli import main as _main

    sys.exit(_main())
