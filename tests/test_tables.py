"""optdesign.tables: the plain-text (Markdown) tables and the cell formats the
run reports, the batch summaries and the command share; and the rule that
makes it a library module: nothing below the command imports the command."""
from __future__ import annotations

import ast
import csv
import math
import re

import numpy as np
import pytest
from hypothesis import given, strategies as st

from optdesign.tables import fmt, fmt_g, table

from conftest import ROOT

#: numbers whose rounded text still reads back as a finite float
finite = st.floats(min_value=-1e300, max_value=1e300, allow_subnormal=False)


# ----------------------------------------------------------------------------- table
def test_table_layout():
    got = table(["quantity", "mean", "n"], [["objective", "1.5", 3], ["dynamic", "-", 12]])
    assert got == ("| quantity  | mean |  n |\n"
                   "|-----------|-----:|---:|\n"
                   "| objective |  1.5 |  3 |\n"
                   "| dynamic   |    - | 12 |")
    assert table(["a", "bb"], []) == "| a | bb |\n|---|---:|"


@given(st.lists(st.lists(st.text(alphabet="abc xyz-0123456789.+", max_size=12), min_size=3, max_size=3),
                max_size=6))
def test_table_cells_read_back_with_a_csv_reader(rows):
    """Read back with the standard library's CSV reader (``|`` as delimiter):
    the same cells, each column as wide as its widest entry, the first column
    left-aligned and the others right-aligned, as the Markdown separator says."""
    headers = ["name", "value", "x"]
    text = table(headers, rows)
    lines = text.split("\n")
    assert len(lines) == len(rows) + 2
    assert len({len(line) for line in lines}) == 1
    parsed = list(csv.reader(lines, delimiter="|"))
    assert all(len(r) == 5 and r[0] == "" and r[-1] == "" for r in parsed)     # | at both ends
    cells = [r[1:-1] for r in parsed]
    sep = cells[1]
    assert re.fullmatch(r"-+", sep[0]) and all(re.fullmatch(r"-+:", c) for c in sep[1:])
    widths = [len(c) - 2 for c in sep]
    assert widths == [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(headers)]
    for got, want in zip(cells[:1] + cells[2:], [headers] + rows):
        assert got[0] == f" {want[0].ljust(widths[0])} "
        assert got[1:] == [f" {w.rjust(n)} " for w, n in zip(want[1:], widths[1:])]


# ----------------------------------------------------------------------------- cells
@pytest.mark.parametrize("x, want", [
    (None, "-"), (math.nan, "-"), (np.float64("nan"), "-"), (math.inf, "inf"), (-math.inf, "-inf"),
    (0, "0.0000"), (0.0, "0.0000"), (3, "3.0000"), (1e-3, "0.0010"), (9.99e-4, "9.9900e-04"),
    (-9.99e-4, "-9.9900e-04"), (999999.0, "999999.0000"), (1e6, "1.0000e+06"), (-2.5e7, "-2.5000e+07"),
    (29.9205, "29.9205"),
])
def test_fmt_cases(x, want):
    assert fmt(x) == want


@given(finite, st.integers(0, 8))
def test_fmt_rounds_to_the_digits_shown(x, digits):
    """``float(fmt(x))`` is ``x`` to within half a unit of the last digit shown,
    in fixed notation between 1e-3 and 1e6 (and for 0), in exponent notation
    outside."""
    s = fmt(x, digits)
    fixed = x == 0 or 1e-3 <= abs(x) < 1e6
    assert ("e" in s) != fixed, s
    scale = 1.0 if fixed else 10.0 ** int(s.split("e")[1])
    assert abs(float(s) - x) <= 0.5 * 10.0 ** -digits * scale + abs(x) * 1e-15, s
    number = s.split("e")[0].lstrip("-")
    assert (len(number.split(".")[1]) == digits) if digits else ("." not in number), s
    if not fixed:
        assert 1 <= float(number) < 10, s


@pytest.mark.parametrize("x, want", [
    (None, "-"), (math.nan, "-"), (math.inf, "inf"), (-math.inf, "-inf"), (0.0, "0"), (6.0, "6"),
    (4.16, "4.16"), (1234567.0, "1.23457e+06"), (0.000123456789, "0.000123457"), (3, "3"),
])
def test_fmt_g_cases(x, want):
    assert fmt_g(x) == want


@given(finite.filter(lambda v: v != 0), st.integers(1, 10))
def test_fmt_g_keeps_the_significant_digits(x, digits):
    s = fmt_g(x, digits)
    assert abs(float(s) - x) <= 0.5 * 10.0 ** (1 - digits) * abs(x) * (1 + 1e-12), s
    mantissa = s.split("e")[0].lstrip("-").replace(".", "").lstrip("0")
    assert 1 <= len(mantissa) <= digits


def test_batch_summary_and_report_use_these_tables():
    from optdesign.report import md as report
    from optdesign.report import summary

    assert summary.table is table and summary.fmt_g is fmt_g
    rows = [["r_a / m", "0.2500"], ["phi / deg", "30.0000"]]
    assert report._md(["parameter", "value"], rows) == table(["parameter", "value"], rows)


# ----------------------------------------------------------------------------- layering
def _imports(path) -> set[str]:
    """The absolute names of the optdesign modules ``path`` imports (relative imports resolved)."""
    package = list(path.relative_to(ROOT).parts[:-1])      # the package a relative import starts from
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            mod = ".".join(base + ([node.module] if node.module else []))
            found.add(mod)
            found.update(f"{mod}.{a.name}" for a in node.names)
    return {m for m in found if m == "optdesign" or m.startswith("optdesign.")}


def test_nothing_below_the_command_imports_it():
    """Library modules never import optdesign.cli or optdesign.commands; the
    commands never import optdesign.cli (cli.py imports them, not the reverse)."""
    files = sorted((ROOT / "optdesign").rglob("*.py"))
    assert len(files) > 20
    for f in files:
        rel = f.relative_to(ROOT).as_posix()
        if rel in ("optdesign/cli.py", "optdesign/__main__.py"):   # the entry points are the top
            continue
        imported = _imports(f)
        assert not any(m == "optdesign.cli" or m.startswith("optdesign.cli.") for m in imported), rel
        if not rel.startswith("optdesign/commands/"):
            assert not any(m == "optdesign.commands" or m.startswith("optdesign.commands.") for m in imported), rel
    # the check does see a relative import of the command layer
    assert "optdesign.commands._common" in _imports(ROOT / "optdesign" / "cli.py")
    assert "optdesign.tables" in _imports(ROOT / "optdesign" / "report" / "md.py")
