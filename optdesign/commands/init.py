"""optdesign init MECHANISM [FILE]: write a commented starting config for a mechanism.

Every shipped mechanism is offered: the hand-written ones (a config written
from the mechanism's parameter table, :func:`optdesign.config.scaffold.scaffold`)
and the described ones (a copy of the shipped description config, package data
``optdesign/data/templates/<name>.yaml``, the same file as ``configs/<name>.yaml``).
``init --list`` prints the names with one line each.  FILE ``-`` (or no FILE)
writes to standard output."""
from __future__ import annotations

import os
import re
import sys

COMMAND = "init"
_TEMPLATES = "templates"


def register(sub):
    p = sub.add_parser(COMMAND, help="write a commented starting config for a mechanism")
    p.add_argument("mechanism", nargs="?", default=None,
                   help="a shipped mechanism name (see 'optdesign init --list')")
    p.add_argument("file", nargs="?", default=None,
                   help="the config file to write (default or '-': print to standard output); never overwritten")
    p.add_argument("--name", default=None, help="the config's name (default: <mechanism>_design)")
    p.add_argument("--list", action="store_true", help="list the mechanisms init knows, one line each, and stop")
    p.set_defaults(func=run)


def _templates() -> dict[str, str]:
    """name -> text of the described mechanisms' shipped configs."""
    from importlib.resources import files

    root = files("optdesign") / "data" / _TEMPLATES
    out = {}
    for entry in sorted(root.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".yaml"):
            out[entry.name[:-5]] = entry.read_text(encoding="utf-8")
    return out


def _template_description(text: str) -> str:
    m = re.search(r"^description:\s*(.+)$", text, flags=re.M)
    return m.group(1).strip() if m else "a described mechanism"


def known() -> dict[str, str]:
    """Every mechanism init can write a config for -> its one-line description."""
    from ..mechanisms import available, get

    out = {}
    for n in available():
        doc = (get(n).__doc__ or "").strip().splitlines()
        out[n] = doc[0].strip() if doc else "a hand-written mechanism"
    for n, text in _templates().items():
        out.setdefault(n, "(described) " + _template_description(text))
    return out


def _with_name(text: str, name: str) -> str:
    return re.sub(r"^name:.*$", f"name: {name}", text, count=1, flags=re.M)


def run(args) -> int:
    from ..config.scaffold import scaffold
    from ..io import atomic_write_text
    from ..mechanisms import available, get
    from ._common import UsageError, check_name_option

    names = known()
    if args.list:
        width = max(len(n) for n in names)
        for n, line in names.items():
            print(f"{n.ljust(width)}  {line}")
        return 0
    if args.mechanism is None:
        raise UsageError(f"init: expected a mechanism name (one of {', '.join(names)}; see 'optdesign init --list')")
    if args.mechanism not in names:
        from ..checking import suggest

        raise UsageError(f"init: unknown mechanism {args.mechanism[:60]!r}{suggest(args.mechanism, names)}; "
                         f"expected one of {', '.join(names)}")
    check_name_option(args.name, "init: --name")
    if args.mechanism in available():
        text = scaffold(get(args.mechanism), args.name)
    else:
        text = _templates()[args.mechanism]
        if args.name is not None:
            text = _with_name(text, args.name)
    if args.file is None or args.file == "-":
        sys.stdout.write(text)
        return 0
    if not args.file.strip() or "\x00" in args.file:
        raise UsageError(f"init: expected a file name (or '-' for standard output), got {args.file!r}")
    if os.path.lexists(args.file):
        raise UsageError(f"init: {args.file} exists; give a new file name (init never overwrites)")
    if os.path.isdir(args.file) or args.file.endswith(("/", os.sep)):
        raise UsageError(f"init: {args.file} is a folder; give a file name")
    parent = os.path.dirname(os.path.abspath(args.file))
    if not os.path.isdir(parent):
        raise UsageError(f"init: folder {parent} does not exist")
    try:
        atomic_write_text(args.file, text)
    except OSError as exc:
        raise UsageError(f"init: cannot write {args.file} ({exc.strerror or type(exc).__name__})") from None
    print(f"wrote {args.file}; check it with: optdesign validate-config {args.file}")
    return 0
