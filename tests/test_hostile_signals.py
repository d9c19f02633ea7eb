"""Signals to a real ``optdesign batch`` process with two loky workers busy:
it exits 130 (SIGINT) or 143 (SIGTERM) with one line, and no process of
its process group is left behind (loky workers and their helpers included)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import BATCH_SMALL, ROOT, edited_text


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:     # pragma: no cover - a process of another user in the group
        return True
    return True


#: a generous bound on waits for a condition (seconds): a limit against a hang
#: with both cores busy, never a measure of speed
PATIENCE = 600


def _wait_for(cond, proc, what: str) -> None:
    """Poll ``cond()`` until true (the batch must still be running meanwhile)."""
    t0 = time.monotonic()
    while not cond():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < PATIENCE, what
        time.sleep(0.05)


def _group(pgid: int) -> list[int]:
    """The pids of the process group's members (from /proc), the leader included."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                fields = (d / "stat").read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                out.append(int(d.name))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("sig, to, status", [(signal.SIGTERM, "batch", 143), (signal.SIGINT, "group", 130),
                                             (signal.SIGINT, "workers", 130)],
                         ids=["SIGTERM to the batch", "SIGINT to its group", "SIGINT to its workers first"])
def test_signal_stops_the_batch_and_its_workers(tmp_path, sig, to, status):
    """Race-free with both cores busy: the signal is sent once both runs have
    a stage folder (a condition on disk, not a delay), and every wait is on a
    condition bounded only against a hang.  "SIGINT to its workers first" is
    the order a loaded machine can give a SIGINT to the group: a worker's
    KeyboardInterrupt reaches the batch through joblib before the batch's own
    handler has run; it is the same interruption, reported the same way."""
    cfg = tmp_path / "slow.yaml"
    cfg.write_text(edited_text(BATCH_SMALL.read_text(), {"generations: 5": "generations: 60"}))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "optdesign.cli", "batch", str(cfg), "--seeds", "2", "--jobs", "2",
                             "--out", str(tmp_path / "runs")], cwd=tmp_path, env=env, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    pgid = proc.pid
    try:
        # both workers inside a run: a stage folder in each of the two run folders
        _wait_for(lambda: len({p.parent.parent for p in (tmp_path / "runs").glob("*/stages/*")}) >= 2, proc,
                  "the workers never started")
        if to == "batch":
            os.kill(pgid, sig)
        elif to == "group":
            os.killpg(pgid, sig)
        else:
            for pid in _group(pgid):
                if pid != pgid:
                    try:
                        os.kill(pid, sig)
                    except ProcessLookupError:
                        pass
        out, err = proc.communicate(timeout=PATIENCE)
    finally:
        if proc.poll() is None:
            os.killpg(pgid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == status, err
    lines = err.strip().splitlines()
    assert lines[-1].startswith(f"optdesign: batch interrupted ({sig.name})"), err
    assert "Traceback" not in err and len(lines) == 2, err        # the start line and the interruption line
    t0 = time.monotonic()
    while _group_alive(pgid):
        if time.monotonic() - t0 > PATIENCE:
            ps = subprocess.run(["ps", "-o", "pid,pgid,stat,cmd", "-g", str(pgid)], capture_output=True, text=True)
            pytest.fail(f"processes left in the batch's group:\n{ps.stdout}")
        time.sleep(0.1)
    # the interrupted runs are resumable: their folders are there, unfinished
    manifests = list(Path(tmp_path / "runs").glob("*/manifest.json"))
    assert len(manifests) == 2


_LEAK = """
import sys
from optdesign.batch import execute
if sys.argv[1] == "batch":
    execute._quiet_resource_tracker()        # what run_batch does before its pool starts
from joblib.externals.loky.backend import resource_tracker
resource_tracker.register("/optdesign-test-never-unlinked", "semlock")   # as a killed worker leaves it
"""


@pytest.mark.parametrize("user_filters", ["", "default::DeprecationWarning"])
def test_the_resource_tracker_says_nothing_after_the_batch_line(tmp_path, monkeypatch, user_filters):
    """A semaphore left registered by a killed worker makes joblib's resource
    tracker (its own process, writing to the batch's stderr after the batch
    has exited) warn that it leaked: deterministic here, where the test above
    meets it only when a worker dies at the wrong moment.  Without the batch's
    filter the warning is there (so this test can fail); with it, nothing,
    and the user's own filters are kept."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": user_filters}
    got = {}
    for mode in ("plain", "batch"):
        proc = subprocess.run([sys.executable, "-c", _LEAK, mode], cwd=tmp_path, env=env, capture_output=True,
                              text=True, timeout=PATIENCE)
        assert proc.returncode == 0, proc.stderr
        got[mode] = proc.stderr
    assert "leaked semlock" in got["plain"], got["plain"]
    assert got["batch"] == "", got["batch"]
    from optdesign.batch.execute import TRACKER_QUIET, _quiet_resource_tracker

    monkeypatch.setenv("PYTHONWARNINGS", user_filters)
    _quiet_resource_tracker()
    _quiet_resource_tracker()
    assert os.environ["PYTHONWARNINGS"].split(",") == [f for f in (user_filters, TRACKER_QUIET) if f]


_HOOK = '''
import os, signal, sys

class _SignalAtImport:
    """Sends SIGTERM to this process when the module named in the environment is first imported."""
    def find_spec(self, name, path=None, target=None):
        if name == os.environ.get("OPTDESIGN_TEST_SIGTERM_AT"):
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGTERM)
        return None

sys.meta_path.insert(0, _SignalAtImport())
'''


@pytest.mark.parametrize("module", ["numpy", "optdesign.commands.run", "optdesign.runner", "pymoo"],
                         ids=["heavy imports", "parser", "the command's imports", "the optimizer's imports"])
@pytest.mark.parametrize("entry", ["optdesign", "optdesign.cli"])
def test_sigterm_while_starting_gives_143_and_one_line(tmp_path, module, entry):
    """SIGTERM at a given point of the start (sent by an import hook when that
    module is first imported: a condition, not a delay) ends the command with
    143 and one line, never by the signal itself."""
    (tmp_path / "hook").mkdir()
    (tmp_path / "hook" / "sitecustomize.py").write_text(_HOOK)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path / "hook"), str(ROOT)]),
           "OPTDESIGN_TEST_SIGTERM_AT": module, "OPTDESIGN_WARMUP": "0"}
    proc = subprocess.run([sys.executable, "-m", entry, "run", str(ROOT / "tests" / "data" / "p4s_tiny.yaml"), "--quiet",
                           "--out", str(tmp_path / "runs")], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 143, (proc.returncode, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("optdesign: interrupted"), proc.stderr
    assert "SIGTERM" in lines[0] or "run interrupted" in lines[0] or "before the run started" in lines[0], lines
