"""The ``optdesign`` command.

Subcommands live in ``optdesign/commands/<name>.py``; each module defines
``register(subparsers)`` which adds its parser and sets ``func`` (a function of
the parsed arguments returning an exit status).  Exit status: 0 success, 1 a
run that failed or was interrupted, 2 a mistake in the input (config, options),
130 interrupted by Ctrl-C.
"""
from __future__ import annotations

import signal
import sys


class Terminated(KeyboardInterrupt):
    """SIGTERM (or SIGINT) reached the command before it installed its own
    handler: the command ends as on Ctrl-C, with status 128 + ``signum``."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


_IN_MAIN = [False]


def _early_signal(signum, frame):
    """The handler of SIGTERM and SIGINT from the first line of the command on
    (before the heavy imports).  While the modules are still being imported
    nothing needs cleaning up: one line and exit 128 + signum.  Once main()
    runs, :class:`Terminated` unwinds the command (temporary files removed)
    to main(), which prints the line; a command that runs an optimization
    installs its own handler (optdesign.optimize.workers.StopRequest)."""
    if not _IN_MAIN[0]:
        print(f"optdesign: interrupted ({signal.Signals(signum).name}) while starting", file=sys.stderr, flush=True)
        raise SystemExit(128 + signum)
    raise Terminated(signum)


def _is_entry_process() -> bool:
    """This process is the ``optdesign`` command (the console script, ``python
    -m optdesign`` or ``python -m optdesign.cli``), not a program importing the module."""
    import os

    argv0 = sys.argv[0] if sys.argv else ""
    return os.path.basename(argv0) == "optdesign" or (
        os.path.basename(os.path.dirname(argv0)) == "optdesign" and os.path.basename(argv0) in ("__main__.py", "cli.py"))


if _is_entry_process():
    for _sig in (signal.SIGTERM, signal.SIGINT):
        try:
            signal.signal(_sig, _early_signal)
        except ValueError:   # pragma: no cover - not the main thread
            pass

import argparse  # noqa: E402 - after the signal handlers: the imports below take seconds on a busy machine
import functools  # noqa: E402
import importlib  # noqa: E402
import pkgutil  # noqa: E402

from . import __version__  # noqa: E402
from .commands._common import UsageError  # noqa: E402 - owned by the commands; optdesign.cli.UsageError stays an alias
from .config import ConfigError  # noqa: E402

#: order in which commands are listed in --help
_ORDER = ["reproduce", "run", "init", "evaluate", "certify", "atlas", "ik", "fk", "batch", "summarize", "report", "compare",
          "export", "status", "bench", "validate-config", "validate-dynamics", "kernel-source"]


class _Parser(argparse.ArgumentParser):
    """argparse with the package's one-line errors: ``optdesign: error: <what>
    (see 'optdesign COMMAND --help')``, exit status 2, and a "did you mean"
    for a mistyped command, choice or option."""

    def parse_known_args(self, args=None, namespace=None):
        self._argv = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def error(self, message):
        message = self._suggest(message)
        where = self.prog.split(" ", 1)[1] + ": " if " " in self.prog else ""
        cmd = self.prog if " " in self.prog else " ".join(["optdesign"] + self._command()[:1])
        line = _one_line(f"{where}{message} (see '{cmd} --help')")
        print(f"optdesign: error: {line}", file=sys.stderr)
        raise SystemExit(2)

    def _suggest(self, message: str) -> str:
        import ast
        import re

        from .checking import shorten, suggest

        m = re.match(r"^(argument .*?: )?invalid choice: (?P<value>.*?) \(choose from (?P<choices>.*)\)$", message)
        if m:
            try:
                value = ast.literal_eval(m.group("value"))
                choices = [str(c) for c in ast.literal_eval("[" + m.group("choices") + "]")]
            except (ValueError, SyntaxError):
                return message
            hint = suggest(str(value), choices, cutoff=0.5)
            return f"{m.group(1) or ''}invalid choice {shorten(value)}{hint}; expected one of {', '.join(choices)}"
        m = re.match(r"^unrecognized arguments: (?P<rest>.*)$", message)
        if m:
            first = m.group("rest").split(" ")[0]
            options = self._options_of_command()
            hint = suggest(first.split("=")[0], options) if first.startswith("-") else ""
            return f"unrecognized arguments: {shorten(m.group('rest'))[1:-1]}{hint}"
        return message

    def _command(self) -> list:
        """[name, parser] of the subcommand named in the arguments, or []."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001 - argparse has no public accessor
                for tok in getattr(self, "_argv", []):
                    if isinstance(tok, str) and tok in action.choices:
                        return [tok, action.choices[tok]]
        return []

    def _options_of_command(self) -> list[str]:
        """The option strings of the subcommand named in the arguments (or of this parser)."""
        found = self._command()
        return list((found[1] if found else self)._option_string_actions)  # noqa: SLF001


def _one_line(text: str, limit: int = 400) -> str:
    """``text`` as one printable line of at most about ``limit`` characters."""
    out = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return out if len(out) <= limit else out[:limit] + "..."


def _ascii_int(text: str) -> int:
    """An integer option: ASCII digits only (``int()`` would take '٣' as 3, '1_0' as 10, ' 3 ' as 3)."""
    import re

    if not isinstance(text, str) or not re.fullmatch(r"[+-]?[0-9]{1,4000}", text):
        raise argparse.ArgumentTypeError(f"expected an integer of ASCII digits, got {_quoted(text)}")
    return int(text)


def _ascii_float(text: str) -> float:
    """A number option: an ASCII decimal number (no other digits, underscores, spaces, nan or inf)."""
    import math
    import re

    if not isinstance(text, str) or not re.fullmatch(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]{1,6})?", text[:400]) \
            or len(text) > 400:
        if isinstance(text, str) and text.strip().lstrip("+-").lower() in ("nan", "inf", "infinity"):
            raise argparse.ArgumentTypeError(f"expected a finite number of ASCII digits, got {_quoted(text)}")
        raise argparse.ArgumentTypeError(f"expected a number of ASCII digits, got {_quoted(text)}")
    value = float(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {_quoted(text)}")
    return value


def _quoted(text) -> str:
    from .config.reader import shorten

    return shorten(text)


def _ascii_numbers(parser: argparse.ArgumentParser) -> None:
    """Every ``type=int`` / ``type=float`` option of every command takes ASCII digits only."""
    for action in parser._actions:  # noqa: SLF001 - argparse has no public accessor
        if action.type is int:
            action.type = _ascii_int
        elif action.type is float:
            action.type = _ascii_float
        if isinstance(action, argparse._SubParsersAction):  # noqa: SLF001
            for sub in set(action.choices.values()):
                _ascii_numbers(sub)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="optdesign",
        description="Dimensional optimization of parallel mechanisms.",
    )
    parser.add_argument("--version", action="version", version=f"optdesign {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
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
    _ascii_numbers(parser)
    return parser


@functools.cache
def _parser() -> argparse.ArgumentParser:
    """The command line's parser, built once per process (building it imports
    and registers every command: about 5 ms, which a caller running many
    commands in-process, as the test suite does thousands of times, paid on
    every call).  Parsing does not change it: a parse keeps only the
    arguments it was given, for its error messages."""
    return build_parser()


def _error(message: str) -> int:
    print(f"optdesign: error: {_one_line(message, 2000)}", file=sys.stderr)
    return 2


def _tolerant_output() -> None:
    """Names from the command line may hold bytes that are not UTF-8 (Python
    keeps them as lone surrogates): printed back, they are escaped instead of
    ending the command with UnicodeEncodeError."""
    for stream in (sys.stdout, sys.stderr):
        if getattr(stream, "errors", None) == "strict" and hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(errors="backslashreplace")
            except (ValueError, OSError):  # pragma: no cover - a stream that cannot change
                pass


def main(argv: list[str] | None = None) -> int:
    """The command; ``argv`` None: this process is the command (its signal
    handlers are the command's, see :func:`_early_signal`)."""
    if argv is None:        # this process is the command: its collector's settings are ours
        from .process import tune_collector

        tune_collector()
    if argv is None and signal.getsignal(signal.SIGTERM) is _early_signal:
        _IN_MAIN[0] = True
        if signal.getsignal(signal.SIGINT) is _early_signal:
            signal.signal(signal.SIGINT, signal.default_int_handler)   # Ctrl-C: KeyboardInterrupt, as before
    try:
        return _main(argv)
    except KeyboardInterrupt as exc:     # Ctrl-C, or Terminated by SIGTERM before a command's own handler
        signum = getattr(exc, "signum", None) or signal.SIGINT
        print("optdesign: interrupted" + (" (SIGTERM)" if signum == signal.SIGTERM else ""), file=sys.stderr)
        return 128 + int(signum)


def _main(argv: list[str] | None) -> int:
    from .io import UnsafeDestination
    from .names import OutsideRoot
    from .workspace import WorkspaceTooLarge

    _tolerant_output()
    parser = _parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:      # --help, --version (0) or a usage error (2, already reported)
        return exc.code if isinstance(exc.code, int) else 2
    if not getattr(args, "func", None):
        return _error("expected a command (see 'optdesign --help')")
    args.process_entry = argv is None   # this process is the command (not a caller in-process)
    from . import fast

    old_notice = fast.set_compile_notice(fast.terminal_notice())   # a run sets its own (its progress lines)
    try:
        rc = args.func(args)
        return 0 if rc is None else int(rc)
    except ConfigError as exc:
        return _error(str(exc))
    except UsageError as exc:
        return _error(str(exc))
    except (WorkspaceTooLarge, OutsideRoot, UnsafeDestination) as exc:
        return _error(str(exc))
    except BrokenPipeError:  # output piped into head and the like
        return 0
    finally:
        fast.set_compile_notice(old_notice)


if __name__ == "__main__":  # pragma: no cover
    # `python -m optdesign.cli`: run the package module, not this __main__ copy,
    # so that the exception classes the commands raise are the ones caught here
    from optdesign.cli import main as _main

    sys.exit(_main())
