"""Compiling the described mechanisms' kernels on the second core while the
rest of the suite runs on the first.

On a fresh checkout numba's cache is empty, and the tests of the described
kernels compile one specialization per mechanism shape (number of legs, pose
columns, rods), 20-50 s each: about 4 minutes of compilation on one core,
while the rest of the suite keeps the machine's second core mostly idle.  So
``conftest.py`` moves those test files to the end of the run and, at the
start, runs them once more in a background process (its own session, lowered
priority, output discarded) whose only effect is numba's cache under
``optdesign/mechanisms/described/__pycache__``; when the suite reaches them,
they load their kernels instead of compiling them.

Nothing depends on the background run: its results are ignored, the tests of
the main session check everything themselves, and if it has not finished (or
failed) they compile what is missing as they would without it.  It is stopped
when the session ends.  ``OPTDESIGN_WARMUP=0`` turns it off.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: the test files whose cost is compilation of the described kernel
FILES = ("test_described_compiled.py", "test_described_kernels.py", "test_described_runs.py")
#: set in the background run (so that it does not start one itself)
ENV = "OPTDESIGN_WARMING"

_proc: subprocess.Popen | None = None
_tmp: str | None = None


def wanted(n_other: int) -> bool:
    """A background run is worth starting: not inside one, not turned off, and
    enough other tests to run meanwhile."""
    return not os.environ.get(ENV) and os.environ.get("OPTDESIGN_WARMUP", "1") != "0" and n_other >= 50


def start(paths: list[str]) -> None:
    global _proc, _tmp
    if _proc is not None:
        return
    _tmp = tempfile.mkdtemp(prefix="optdesign-warmup-")
    env = dict(os.environ, **{ENV: "1"})
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--basetemp={_tmp}/t", *paths]
    _proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, start_new_session=True, preexec_fn=lambda: os.nice(10))


def stop() -> None:
    global _proc, _tmp
    if _proc is not None:
        if _proc.poll() is None:
            try:
                os.killpg(_proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        _proc.wait()
        _proc = None
    if _tmp is not None:
        shutil.rmtree(_tmp, ignore_errors=True)
        _tmp = None
