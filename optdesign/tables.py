"""Plain-text tables (also valid Markdown) and the formatting of their cells.

Shared by the run reports, the batch summaries and the ``optdesign`` command;
a library module, so the CLI imports it and never the reverse.
"""
from __future__ import annotations

import math
from typing import Sequence

__all__ = ["fmt", "fmt_g", "table"]


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
