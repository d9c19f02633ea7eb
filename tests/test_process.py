"""The collector's settings in optdesign's own processes (:mod:`optdesign.process`):
the command's process and a stage worker collect their youngest generation
less often; a caller's process that calls the command in-process keeps its own."""
from __future__ import annotations

import gc
import subprocess
import sys

import pytest

from optdesign.process import GC_THRESHOLD, tune_collector


@pytest.fixture
def threshold():
    old = gc.get_threshold()
    yield
    gc.set_threshold(*old)


@pytest.mark.parametrize("before, after", [
    ((700, 10, 10), (GC_THRESHOLD, 10, 10)),            # CPython's default: raised, the older generations kept
    ((2000, 5, 7), (GC_THRESHOLD, 5, 7)),
    ((GC_THRESHOLD * 3, 10, 10), (GC_THRESHOLD * 3, 10, 10)),   # already less often: kept
    ((0, 10, 10), (0, 10, 10)),                           # collection off by threshold 0: kept off
])
def test_the_youngest_generation_is_raised_and_nothing_else(threshold, before, after):
    gc.set_threshold(*before)
    tune_collector()
    assert gc.get_threshold() == after


def test_the_command_process_tunes_its_collector_and_an_in_process_call_does_not(threshold):
    gc.set_threshold(700, 10, 10)
    from optdesign.cli import main

    assert main(["--version"]) == 0
    assert gc.get_threshold() == (700, 10, 10)       # the caller's process: as it was
    code = ("import gc, sys; from optdesign.cli import main; rc = main(); "
            "print(gc.get_threshold()[0], file=sys.stderr); sys.exit(rc)")
    p = subprocess.run([sys.executable, "-c", code, "--version"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert int(p.stderr.strip().splitlines()[-1]) == GC_THRESHOLD


def test_a_stage_worker_tunes_its_collector():
    import multiprocessing as mp
    import os
    from concurrent.futures import ProcessPoolExecutor

    from optdesign.optimize.workers import _worker_init

    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn"), initializer=_worker_init,
                             initargs=(os.getpid(), None)) as pool:
        assert pool.submit(gc.get_threshold).result(timeout=120)[0] == GC_THRESHOLD
