"""What the field trial's red team broke (issue 20, "Crashes, escapes and races"):
each case failed on the main of that day.  Run folders are made by a real
(small) run once per module; every case works on a copy."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from cli_helpers import run_cli_in
from hostile_helpers import check_outcome

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "configs" / "p4s_paper.yaml"


def _one_line_error(rc: int, err: str, *fragments: str) -> None:
    assert rc == 2, (rc, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("optdesign: error: "), err
    for f in fragments:
        assert f in lines[0], (f, lines[0])


# ---------------------------------------------------------------- numbers on the command line

@pytest.mark.parametrize("argv", [
    ["run", "--seed", "\u0663", "CONFIG"],                # Arabic-Indic 3
    ["run", "--seed", "\uff13", "CONFIG"],                # full-width 3
    ["run", "--seed", "1_0", "CONFIG"],
    ["run", "--seed", " 3", "CONFIG"],
    ["run", "--jobs", "\u0662", "CONFIG"],
    ["reproduce", "--seed", "\u0663", "--no-plots"],
    ["batch", "--seeds", "\u0663", "CONFIG"],
    ["batch", "--seed-list", "1,\u0663", "CONFIG"],
    ["batch", "--timeout", "\u0661", "CONFIG"],
    ["batch", "--timeout", "nan", "CONFIG"],
    ["atlas", "--resolution", "\u0663\u0660", "CONFIG"],
    ["ik", "CONFIG", "0", "0", "\u0660.3"],
    ["fk", "CONFIG", "0.1", "0.1", "\u0660.1"],
])
def test_numbers_take_ascii_digits_only(tmp_path, argv):
    argv = [str(PAPER) if a == "CONFIG" else a for a in argv]
    rc, out, err = run_cli_in(tmp_path, argv)
    _one_line_error(rc, err, "ASCII" if "--seed-list" not in argv else "--seed-list")
    assert not any(tmp_path.iterdir()), "a refused command wrote files"


def test_ascii_numbers_still_work(tmp_path):
    rc, out, err = run_cli_in(tmp_path, ["ik", str(PAPER), "0", "0", "0.3"])
    assert rc == 0 and "l1 = " in out, (rc, out, err)
    rc, out, err = run_cli_in(tmp_path, ["ik", str(PAPER), "0", "0", "3e-1"])
    assert rc == 0 and "l1 = " in out, (rc, out, err)


# ---------------------------------------------------------------- expression depth

def test_a_flat_sum_is_not_deep():
    from optdesign.mechanisms.described.expr import ExprError, evaluate, parse

    for n in (26, 60, 100):
        assert evaluate(parse("+".join(["a"] * n), ["a"]), {"a": 1.0}) == n
        assert evaluate(parse(" - ".join(["a"] * n), ["a"]), {"a": 1.0}) == 2 - n
        assert evaluate(parse("*".join(["a"] * n), ["a"]), {"a": 2.0}) == 2.0 ** n
    assert evaluate(parse("a + a - a + a * a / a * a - a", ["a"]), {"a": 3.0}) == 3 + 3 - 3 + 9 - 3
    # true nesting is still refused: parentheses on the right, calls, signs, powers
    for text in ["a + (" * 30 + "a" + ")" * 30, "sin(" * 30 + "a" + ")" * 30, "-" * 30 + "a", "a**" * 30 + "a",
                 "a * (" * 26 + "a + a" + ")" * 26]:
        with pytest.raises(ExprError, match="nested deeper than 24 levels"):
            parse(text, ["a"])
    with pytest.raises(ExprError, match="more than 200 terms"):
        parse("+".join(["a"] * 120), ["a"])
    with pytest.raises(ExprError, match="longer than"):
        parse("+".join(["a"] * 300), ["a"])


# ---------------------------------------------------------------- absurd magnitudes

def _paper_with(tmp_path, old: str, new: str) -> Path:
    text = PAPER.read_text()
    assert re.search(old, text, flags=re.M)
    p = tmp_path / "c.yaml"
    p.write_text(re.sub(old, new, text, count=1, flags=re.M))
    return p


@pytest.mark.parametrize("value", ["1e-320", "-1e-320", "5e-324", "1e-15", "2.0e-13"])
def test_subnormal_and_absurdly_small_positive_values_are_refused(tmp_path, value):
    cfg = _paper_with(tmp_path, r"^  k: 1\.0", f"  k: {value}")
    rc, out, err = run_cli_in(tmp_path, ["validate-config", str(cfg)])
    _one_line_error(rc, err, "c.yaml: parameters.k", "sensible size")


def test_a_subnormal_in_a_description_is_refused():
    from optdesign.mechanisms.described.expr import ExprError, parse

    for v in ("a * 1e-320", 1e-320):
        with pytest.raises(ExprError, match="subnormal|sensible size"):
            parse(v, ["a"])
    assert parse("a * 1e-300", ["a"])[3] == ("num", 1e-300)


# ---------------------------------------------------------------- compare --out and atomic writes

RUN = ROOT / "runs" / "p4s_paper-reproduction"


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    import shutil

    top = tmp_path_factory.mktemp("cmp")
    for n in ("a", "b"):
        shutil.copytree(RUN, top / n)
    return top


@pytest.mark.parametrize("case", ["link to a text file", "link to an html file", "dangling link",
                                  "an existing text file named .html", "not .html", "a FIFO"])
def test_compare_never_overwrites_what_is_not_its_page(two_runs, tmp_path, case):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    page = tmp_path / "page.html"
    page.write_text("<!DOCTYPE html><html></html>")
    out = tmp_path / "out.html"
    if case == "link to a text file":
        out.symlink_to(victim)
    elif case == "link to an html file":
        out.symlink_to(page)
    elif case == "dangling link":
        out.symlink_to(tmp_path / "nowhere.html")
    elif case == "an existing text file named .html":
        out.write_text("keep")
    elif case == "not .html":
        out = victim
    else:
        import os

        os.mkfifo(out)
    rc, so, err = run_cli_in(tmp_path, ["compare", str(two_runs / "a"), str(two_runs / "b"), "--out", str(out)])
    _one_line_error(rc, err, "--out")
    assert victim.read_text() == "keep" and page.read_text() == "<!DOCTYPE html><html></html>"
    assert not (tmp_path / "nowhere.html").exists()
    if case == "an existing text file named .html":
        assert out.read_text() == "keep"


def test_compare_replaces_its_own_page(two_runs, tmp_path):
    out = tmp_path / "out.html"
    out.write_text("<!DOCTYPE html>\n<html>old</html>")
    rc, so, err = run_cli_in(tmp_path, ["compare", str(two_runs / "a"), str(two_runs / "b"), "--out", str(out)])
    assert rc == 0, err
    assert out.read_text().startswith("<!DOCTYPE html>") and "old" not in out.read_text()[:100]


def test_atomic_writes_refuse_a_link(tmp_path):
    from optdesign.io import UnsafeDestination, atomic_write_text

    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    (tmp_path / "summary.csv").symlink_to(victim)
    with pytest.raises(UnsafeDestination, match="symbolic link"):
        atomic_write_text(tmp_path / "summary.csv", "x")
    assert victim.read_text() == "keep" and sorted(p.name for p in tmp_path.iterdir()) == ["summary.csv", "victim.txt"]
