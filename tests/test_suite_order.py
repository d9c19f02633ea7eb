"""The order the workers take the test files in (tests/conftest.py): every
file it names exists (a renamed file would silently fall to the end), once."""
from __future__ import annotations

from pathlib import Path

from conftest import LONGEST_FIRST


def test_the_order_names_existing_files_once():
    here = Path(__file__).resolve().parent
    assert len(set(LONGEST_FIRST)) == len(LONGEST_FIRST)
    missing = [name for name in LONGEST_FIRST if not (here / name).is_file()]
    assert not missing, missing


def test_the_items_follow_the_order(request):
    """This session's items: the named files first, in the table's order."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    files = []
    for item in request.session.items:
        if not files or files[-1] != item.path.name:
            files.append(item.path.name)
    ranks = [rank.get(f, len(rank)) for f in files]
    assert ranks == sorted(ranks)
