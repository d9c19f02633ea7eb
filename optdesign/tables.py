"""Plain-text tables (also valid Markdown) and the formatting of their cells.

Shared by the run reports, the batch summaries and the ``optdesign`` command;
a library module, so the CLI imports it and never the reverse.
"""
from __future__ import annotations

import math
import shutil
import sys
from typing import Sequence

__all__ = ["fmt", "fmt_g", "table", "fold_table", "fit_text", "terminal_width", "print_table", "print_text"]

#: the widest a table printed to a terminal may be
TERMINAL_TABLE_WIDTH = 80


def fmt(x: float, digits: int = 4) -> str:
    """``digits`` decimals, or an exponent below 1e-3 and from 1e6 on; ``-`` for None and NaN."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    ax = abs(x)
    if ax != 0 and (ax < 1e-3 or ax >= 1e6):
        return f"{x:.{digits}e}"
    return f"{x:.{digits}f}"


def fmt_g(x: float | None, digits: int = 6) -> str:
    """``digits`` significant digits (format ``g``); ``-`` for None and NaN."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return f"{x:.{digits}g}"


def table(headers: Sequence[str], rows: Sequence[Sequence], align: str | None = None) -> str:
    """A plain-text table (also valid Markdown)."""
    cells = [[str(c) for c in r] for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) if cells else len(h) for i, h in enumerate(headers)]
    def line(vals):
        return "| " + " | ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(vals, widths))) + " |"
    sep = "|" + "|".join(("-" * (w + 2)) if i == 0 else ("-" * (w + 1) + ":") for i, w in enumerate(widths)) + "|"
    return "\n".join([line(headers), sep] + [line(r) for r in cells])


def _shorten(cell: str, most: int) -> str:
    return cell if len(cell) <= most else cell[: most // 2 - 1] + "…" + cell[-(most - most // 2):]


def _is_number(cell: str) -> bool:
    try:
        float(cell.rstrip("x%×"))
    except ValueError:
        return cell.strip() in ("-", "inf", "-inf", "nan")
    return True


def _key_columns(rows: Sequence[Sequence[str]], n: int) -> int:
    """How many leading columns name a row (text, not numbers): 1 or 2."""
    if n > 2 and rows and all(not _is_number(r[1]) for r in rows):
        return 2
    return 1


def fold_table(headers: Sequence[str], rows: Sequence[Sequence], width: int | None) -> list[str]:
    """``table(headers, rows)`` as one or more tables no wider than ``width``
    characters (None: one table): the columns are split into groups, each
    table repeating the leading columns that name a row (one, or two where
    the second is text too); a cell too long for the width is shortened in
    the middle (…)."""
    full = table(headers, rows)
    if width is None or max(len(line) for line in full.splitlines()) <= width:
        return [full]
    most = max(8, width - 12)
    headers = [_shorten(str(h), most) for h in headers]
    rows = [[_shorten(str(c), most) for c in r] for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]
    keys = _key_columns(rows, len(headers))
    if len(headers) <= keys:
        return [table(headers, rows)]
    base = 1 + sum(widths[i] + 3 for i in range(keys))
    groups, cur, used = [], [], base
    for i in range(keys, len(headers)):
        if cur and used + widths[i] + 3 > width:
            groups.append(cur)
            cur, used = [], base
        cur.append(i)
        used += widths[i] + 3
    groups.append(cur)
    lead = list(range(keys))
    return [table([headers[i] for i in lead + g], [[r[i] for i in lead + g] for r in rows]) for g in groups]


def _parse(lines: list[str]) -> tuple[list[str], list[list[str]]] | None:
    """Headers and rows of a table written by :func:`table` (None if it is not one)."""
    def cells(line):
        return [c.strip() for c in line.strip()[1:-1].split(" | ")]

    if len(lines) < 2 or not set(lines[1].strip()) <= set("|-: "):
        return None
    head = cells(lines[0])
    rows = [cells(l) for l in lines[2:]]
    if any(len(r) != len(head) for r in rows):
        return None
    return head, rows


def fit_text(text: str, width: int | None) -> str:
    """Text (e.g. Markdown) whose tables are folded to ``width`` (see :func:`fold_table`)."""
    if width is None:
        return text
    out, block = [], []

    def flush():
        if not block:
            return
        parsed = _parse(block)
        if parsed is None or max(len(l) for l in block) <= width:
            out.extend(block)
        else:
            out.append("\n\n".join(fold_table(*parsed, width)))
        block.clear()

    for line in text.split("\n"):
        if line.startswith("|") and line.rstrip().endswith("|"):
            block.append(line)
        else:
            flush()
            out.append(line)
    flush()
    return "\n".join(out)


def terminal_width(stream=None) -> int | None:
    """The width a table printed to ``stream`` (default stdout) must fit: the
    terminal's, at most :data:`TERMINAL_TABLE_WIDTH`; None when the stream is
    not a terminal (a file or a pipe gets the full width)."""
    stream = stream or sys.stdout
    try:
        if not stream.isatty():
            return None
    except (AttributeError, ValueError):
        return None
    return max(20, min(TERMINAL_TABLE_WIDTH, shutil.get_terminal_size((TERMINAL_TABLE_WIDTH, 24)).columns))


def print_table(headers: Sequence[str], rows: Sequence[Sequence], file=None) -> None:
    """Print a table, folded to the terminal's width when printed to one."""
    file = file or sys.stdout
    print("\n\n".join(fold_table(headers, rows, terminal_width(file))), file=file)


def print_text(text: str, file=None) -> None:
    """Print text whose tables are folded to the terminal's width when printed to one."""
    file = file or sys.stdout
    print(fit_text(text, terminal_width(file)), file=file)
