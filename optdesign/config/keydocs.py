"""The key tables of docs/config.md, generated from the key table
(:mod:`optdesign.config.keys`): each block between ``<!-- keys:SECTION -->``
and ``<!-- /keys:SECTION -->`` is the table of that section (``top``,
``workspace``, ``optimizer``, ``checks``)::

    python -m optdesign.config.keydocs --write-docs docs/config.md   # rewrite the tables
    python -m optdesign.config.keydocs --check docs/config.md        # exit 1 if they differ
"""
from __future__ import annotations

import sys

from .keys import SECTIONS, Section

__all__ = ["main", "markdown_table", "update_docs"]


def markdown_table(section: Section) -> str:
    """The docs/config.md table of a section's keys."""
    rows = ["| key | type | default | meaning |", "|---|---|---|---|"]
    for k in section.keys:
        rows.append(f"| `{k.name}` | {k.type_text()} | {k.default_text()} | {k.doc} |")
    return "\n".join(rows)


def update_docs(text: str) -> str:
    """``text`` with every block between ``<!-- keys:NAME -->`` and
    ``<!-- /keys:NAME -->`` replaced by the table of section NAME."""
    for name, section in SECTIONS.items():
        start, end = f"<!-- keys:{name} -->", f"<!-- /keys:{name} -->"
        if start not in text:
            continue
        a = text.index(start) + len(start)
        b = text.index(end, a)
        text = text[:a] + "\n" + markdown_table(section) + "\n" + text[b:]
    return text


def main(argv=None) -> int:
    """``python -m optdesign.config.keydocs --write-docs docs/config.md`` (or
    ``--check docs/config.md``: exit 1 when the file's tables are not the table's)."""
    import argparse
    from pathlib import Path

    p = argparse.ArgumentParser(prog="python -m optdesign.config.keydocs")
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--write-docs", metavar="FILE")
    g.add_argument("--check", metavar="FILE")
    a = p.parse_args(argv)
    path = Path(a.write_docs or a.check)
    text = path.read_text(encoding="utf-8")
    new = update_docs(text)
    if a.check:
        if new != text:
            print(f"{path}: the key tables differ from optdesign/config/keys.py; run with --write-docs", file=sys.stderr)
            return 1
        return 0
    if new != text:
        path.write_text(new, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
