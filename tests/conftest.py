"""Shared test inputs: the paths of the configs, the paper's config (parsed and
as a raw mapping), edited copies of YAML files, and one small batch run
(``--jobs 1``, and again with ``--jobs 2``) for the batch tests.

Test modules import the plain names (``from conftest import DATA``) where
they need them at import time, and take the fixtures otherwise.
"""
from __future__ import annotations

import functools
import os
import sys
from pathlib import Path

import pytest
import yaml

os.environ.setdefault("MPLBACKEND", "Agg")
# The suite writes Python's bytecode caches (__pycache__), as Python does by
# default, also where the environment says not to (PYTHONDONTWRITEBYTECODE, set
# in some containers): the suite starts about 120 Python processes (command
# runs, stage and batch workers), each of which would otherwise compile every
# module of optdesign from its source again, and each test worker would rewrite
# the asserts of all test files again.  Set here, before the test workers start,
# so that they and every process they start inherit it.
sys.dont_write_bytecode = False
os.environ.pop("PYTHONDONTWRITEBYTECODE", None)

# Property-based tests draw the same cases on every run of the suite (a red
# CI then always means the code changed), and new ones when asked:
# OPTDESIGN_HYPOTHESIS=explore python -m pytest tests/test_hostile_*.py
from hypothesis import settings as _hyp_settings  # noqa: E402

_hyp_settings.register_profile("ci", derandomize=True, database=None)
_hyp_settings.register_profile("explore", derandomize=False)
_hyp_settings.load_profile(os.environ.get("OPTDESIGN_HYPOTHESIS", "ci"))

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"
#: small configs and batch files of the tests
DATA = Path(__file__).resolve().parent / "data"
#: the 3-P(4S) paper's setup, every value annotated
PAPER = CONFIGS / "p4s_paper.yaml"
#: a tiny 3-P(4S) optimization for the batch tests (seconds per run)
BATCH_SMALL = DATA / "batch_small.yaml"
#: the fields of a batch row that must agree exactly between two runs of the
#: same task, whatever the backend or the number of workers
SAME_FIELDS = ("config", "config_key", "run_key", "seed", "status", "objective", "opt_r_a", "opt_r_b", "opt_phi",
               "dynamic", "stiffness", "isotropy", "evaluations")


@functools.cache
def shipped_optimizations() -> tuple[Path, ...]:
    """The shipped configs with free design variables (configs/, the batch
    file excepted), sorted: parsed once per test process (several test files
    parametrize over them as they are collected)."""
    from optdesign.config import load_config

    return tuple(sorted(p for p in CONFIGS.glob("*.yaml")
                        if p.name != "batch_example.yaml" and load_config(p).free_variables))


@functools.cache
def _small_data() -> dict:
    import yaml

    return yaml.safe_load((DATA / "p4s_small.yaml").read_text())


def small_data() -> dict:
    """tests/data/p4s_small.yaml as plain data, a fresh copy on each call
    (parsed once per test process: the hostile tests take one per example)."""
    import copy

    return copy.deepcopy(_small_data())


def load_paper_config():
    """The paper's config, parsed (a new object on each call)."""
    from optdesign.config import load_config

    return load_config(PAPER)


def paper_data() -> dict:
    """The paper's config as the raw YAML mapping (a new one on each call)."""
    return yaml.safe_load(PAPER.read_text())


def edited_text(text: str, replacements: dict[str, str]) -> str:
    """``text`` with each ``old -> new`` of ``replacements`` applied in order;
    an ``old`` that does not occur fails the test (an edit must not be a no-op)."""
    for old, new in replacements.items():
        assert old in text, f"{old!r} not in the text to edit"
        text = text.replace(old, new)
    return text


@pytest.fixture
def paper_config():
    return load_paper_config()


@pytest.fixture
def edited_copy(tmp_path):
    """``edited_copy(src, {old: new, ...}, name)``: a copy of the file ``src``
    with the edits of :func:`edited_text`, written as ``tmp_path / name``."""
    def make(src: str | os.PathLike, replacements: dict[str, str], name: str) -> Path:
        out = tmp_path / name
        out.write_text(edited_text(Path(src).read_text(), replacements))
        return out

    return make


@pytest.fixture
def write_yaml(tmp_path):
    """``write_yaml(data, name)``: ``yaml.safe_dump(data)`` written as ``tmp_path / name``."""
    def make(data, name: str) -> Path:
        out = tmp_path / name
        out.write_text(yaml.safe_dump(data))
        return out

    return make


@pytest.fixture(scope="session")
def small_batch(tmp_path_factory):
    """The two tasks of ``batch_small.yaml`` (seeds 1 and 2) run with --jobs 1
    into ``root / "jobs1"``: (tasks, root, rows)."""
    from optdesign.batch import plan, run_batch

    root = tmp_path_factory.mktemp("batches")
    tasks = plan([str(BATCH_SMALL)], 2)
    rows1 = run_batch(tasks, str(root / "jobs1"), jobs=1)
    return tasks, root, rows1


@pytest.fixture(scope="session")
def small_batches(small_batch):
    """``small_batch`` and the same tasks run again with --jobs 2 into
    ``root / "jobs2"``: (tasks, root, rows of jobs1, rows of jobs2)."""
    from optdesign.batch import run_batch

    tasks, root, rows1 = small_batch
    rows2 = run_batch(tasks, str(root / "jobs2"), jobs=2)
    return tasks, root, rows1, rows2


# ---------------------------------------------------------------------- the order the workers take the files in
#: The test files in the order pytest-xdist hands them to its two workers
#: (``--dist loadfile --no-loadscope-reorder``, pyproject.toml): one file at a
#: time, to whichever worker is nearly done with its own.  Longest first, so
#: that no long file starts last and runs alone while the other worker idles;
#: except that the first file compiles the engine's kernels (``run_tasks`` and
#: ``zoom`` in one process, where they share their routines) while the other
#: worker starts with files that compile none, and finds them in numba's cache
#: afterwards (with two long files first, both workers compiled the same kernels
#: side by side, and a process that loaded ``run_tasks`` from the cache then
#: compiled ``zoom`` with all its routines: 21 s instead of 6 s).
#: The comments are each file's seconds in ``python -m pytest --durations=0``
#: from a fresh clone of revision 2c55919, before this order (2 cores, quiet,
#: 2026-12-06; a file that compiles a kernel first takes longer); a file not named runs after
#: these in pytest's own order.  Only the order changes: no test depends on it.
LONGEST_FIRST = (
    "test_described_runs.py",   # 44 s: the engine's run_tasks, zoom and the mass blocks, compiled
    "test_hostile_yaml.py",     # 13 s  \
    "test_hostile_configs.py",  # 9 s    |
    "test_hostile_config.py",   # 6 s    |
    "test_architecture.py",     # 5 s     > no kernel compiled: the other worker's first files
    "test_hostile_cli.py",      # 4 s    |
    "test_hostile_names.py",    # 4 s    |
    "test_config_keys.py",      # 3 s    |
    "test_kernel_generators.py",  # 2 s /
    "test_interrupt.py",        # 78 s
    "test_runs.py",             # 67 s
    "test_dask.py",             # 35 s
    "test_engine.py",           # 25 s: the specialized tier of two shapes, compiled
    "test_report_html.py",      # 35 s
    "test_chain_compiled.py",   # 34 s
    "test_presentation.py",     # 31 s
    "test_polish.py",           # 30 s
    "test_field_trial_output.py",
    "test_batch_execute.py",
    "test_determinism.py",
    "test_config.py",
    "test_init.py",
    "test_hostile_signals.py",
    "test_extremes.py",
    "test_hostile_geometry.py",
    "test_normalized_terms.py",
    "test_workers.py",
    "test_certify_described.py",
    "test_python_api_doc.py",
    "test_wall.py",
    "test_hostile_runs.py",
    "test_checkpoint.py",
    "test_batch_schema.py",
    "test_progress_file.py",
    "test_described_compiled.py",
    "test_batch_summary.py",
    "test_hostile_limits.py",
    "test_certify.py",
    "test_described_ik_json.py",
)


def pytest_collection_modifyitems(config, items):
    """Sort the items by their file's place in LONGEST_FIRST (a stable sort:
    the order within a file is pytest's)."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


# ---------------------------------------------------------------------- a test worker's end
def pytest_sessionfinish(session):
    """In a test worker, after its last test: stop joblib's idle loky workers
    at once (killed: they hold nothing; otherwise the worker's exit waits for
    each to shut down) and move every object that survives one collection
    into the collector's permanent generation, so that pytest's own check for
    unraisable exceptions at the end (five full collections) scans only what
    is created after.  The last worker to finish took 5-7 s from its last
    test to its exit; the suite's wall time includes them."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return
    import gc

    if "joblib" in sys.modules:
        from optdesign.batch.execute import _kill_local_workers

        _kill_local_workers()
    gc.collect()
    gc.freeze()
