"""optdesign init MECHANISM [FILE]: write a commented starting config for a mechanism."""
from __future__ import annotations

import os
import sys

COMMAND = "init"


def register(sub):
    p = sub.add_parser(COMMAND, help="write a commented starting config for a mechanism")
    p.add_argument("mechanism", help="a registered mechanism name (see the README's mechanism table)")
    p.add_argument("file", nargs="?", default=None,
                   help="the config file to write (default: print to standard output); never overwritten")
    p.add_argument("--name", default=None, help="the config's name (default: <mechanism>_design)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..config.scaffold import scaffold
    from ..io import atomic_write_text
    from ..mechanisms import available, get
    from ._common import UsageError

    if args.mechanism not in available():
        import difflib

        close = difflib.get_close_matches(args.mechanism, available(), n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise UsageError(f"init: unknown mechanism {args.mechanism[:60]!r}{hint} (expected one of {', '.join(available())})")
    text = scaffold(get(args.mechanism), args.name)
    if args.file is None:
        sys.stdout.write(text)
        return 0
    if os.path.lexists(args.file):
        raise UsageError(f"init: {args.file} exists; give a new file name (init never overwrites)")
    parent = os.path.dirname(os.path.abspath(args.file))
    if not os.path.isdir(parent):
        raise UsageError(f"init: folder {parent} does not exist")
    atomic_write_text(args.file, text)
    print(f"wrote {args.file}; check it with: optdesign validate-config {args.file}")
    return 0
