"""Shared checks of the hostile-input suite (tests/test_hostile_*.py).

Every case runs the real command in-process (``cli_helpers.run_cli_in``) in
a folder ``work`` of its own, beside an empty folder ``outside``; a case
passes only if

* it exits 0 or 1, or exits 2 with exactly one stderr line ``optdesign:
  error: ...`` (no traceback anywhere), and never another status;
* nothing appears outside ``work`` (``outside`` stays empty and ``work``'s
  parent holds nothing else).

``Cases`` counts the cases each test ran, so that a test asserts it ran as
many as ``docs/reliability.md`` claims (hypothesis stops early when a
strategy runs out of distinct examples).
"""
from __future__ import annotations

import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from cli_helpers import run_cli_in


class Cases:
    """A counter of the cases one test ran."""

    def __init__(self):
        self.n = 0

    def __call__(self):
        self.n += 1


@contextmanager
def sandbox():
    """(work, outside): a fresh working folder and an empty sibling, removed afterwards."""
    top = Path(tempfile.mkdtemp(prefix="hostile-"))
    try:
        (top / "work").mkdir()
        (top / "outside").mkdir()
        yield top / "work", top / "outside"
    finally:
        shutil.rmtree(top, ignore_errors=True)


def nothing_outside(work: Path, outside: Path, what: str) -> None:
    top = work.parent
    assert sorted(p.name for p in top.iterdir()) == ["outside", "work"], f"{what}: wrote {sorted(top.iterdir())}"
    assert not any(outside.iterdir()), f"{what}: wrote into the sibling folder: {list(outside.iterdir())}"


def files_under(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def check_outcome(rc: int, err: str, what: str, *, file: str | None = None, key: str | None = None,
                  allowed=(0, 1, 2)) -> None:
    """The promises on one command's exit status and stderr (see the module docstring)."""
    assert rc in allowed, f"{what}: exit status {rc}; stderr {err[-500:]!r}"
    assert "Traceback" not in err and "Exception ignored" not in err, f"{what}: {err[-800:]!r}"
    if rc == 2:
        assert err.endswith("\n") and err.count("\n") == 1, f"{what}: not one line: {err[-800:]!r}"
        assert err.startswith("optdesign: error: "), f"{what}: {err!r}"
        assert len(err) < 2100, f"{what}: a {len(err)}-character message"
        if file is not None:
            assert err.startswith(f"optdesign: error: {file}: "), f"{what}: the line does not name {file}: {err!r}"
        if key is not None:
            assert key in err, f"{what}: the line does not name {key!r}: {err!r}"


def run_case(work: Path, outside: Path, argv: list[str], what: str, **expect) -> tuple[int, str, str]:
    """Run ``optdesign *argv`` in ``work`` and check the outcome and the folders."""
    rc, out, err = run_cli_in(work, argv)
    check_outcome(rc, err, what, **expect)
    nothing_outside(work, outside, what)
    return rc, out, err
