"""Batches on a real local Dask cluster: a scheduler and two workers as separate
processes on 127.0.0.1; one worker is killed mid-batch and the batch still
finishes, with results equal to a local run."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed", reason="the dask extra is not installed")

from optdesign.batch import connect_dask, plan, run_task  # noqa: E402

from conftest import BATCH_SMALL, SAME_FIELDS as SAME  # noqa: E402


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_port(port: int, proc: subprocess.Popen, timeout: float = 300.0) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise RuntimeError(f"dask scheduler exited with {proc.returncode}")
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=1):
                return
        except OSError:
            time.sleep(0.2)
    raise RuntimeError("dask scheduler did not open its port")


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two single-thread workers (no nanny, so killing a worker's
    process kills the worker), each a separate process; all stopped at the end."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: dict[str, subprocess.Popen] = {}
    logs = []

    def start(name, args):
        log = open(tmp_path / f"{name}.log", "w")
        logs.append(log)
        procs[name] = subprocess.Popen([sys.executable, "-m", "dask", *args], stdout=log, stderr=subprocess.STDOUT,
                                       cwd=tmp_path, start_new_session=True)

    try:
        start("scheduler", ["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"])
        _wait_port(port, procs["scheduler"])
        for i in (1, 2):
            start(f"worker{i}", ["worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                                 "--host", "127.0.0.1", "--death-timeout", "300",
                                 "--local-directory", str(tmp_path / f"w{i}")])
        # generous bounds: only a cluster that never comes up fails here (a busy machine starts slowly)
        client = connect_dask(address, timeout=300)
        client.wait_for_workers(2, timeout=300)
        client.close()
        yield address, procs
    finally:
        # the workers first, while the scheduler still answers their goodbye (a worker closing after it
        # waits for it), then the scheduler
        workers = [p for n, p in procs.items() if n != "scheduler"]
        for group in (workers, [procs[n] for n in procs if n == "scheduler"]):
            for p in group:
                if p.poll() is None:
                    p.terminate()
            for p in group:
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
        for log in logs:
            log.close()


def _running_with_checkpoint(out: Path) -> list[Path]:
    busy = []
    for d in out.glob("*-s*-*"):
        try:
            m = json.loads((d / "manifest.json").read_text())
        except (OSError, ValueError):
            continue
        if m.get("status") == "running" and any(d.glob("stages/*/checkpoint.npz")):
            busy.append(d)
    return busy


@pytest.mark.slow
def test_dask_batch_survives_a_killed_worker(cluster, tmp_path, edited_copy):
    address, procs = cluster
    # a little longer than the other tests' runs, so that a worker is caught mid-run
    # (checkpoint after every generation, so that it has one when it is caught)
    cfg = edited_copy(BATCH_SMALL, {"generations: 5": "generations: 30, checkpoint_interval: 0"}, "slow.yaml")
    out = tmp_path / "runs"
    cmd = [sys.executable, "-m", "optdesign.cli", "batch", str(cfg), "--seeds", "2", "--out", str(out),
           "--backend", "dask", "--scheduler", address, "--timeout", "30"]
    batch = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    try:
        # both single-thread workers busy, each with a run that has checkpointed a generation
        t0 = time.monotonic()
        while len(_running_with_checkpoint(out)) < 2:
            assert batch.poll() is None, batch.communicate()
            assert time.monotonic() - t0 < 240, "the workers never started two runs"
            time.sleep(0.05)
        os.kill(procs["worker1"].pid, signal.SIGKILL)
        procs["worker1"].wait(timeout=10)
        stdout, stderr = batch.communicate(timeout=300)
    finally:
        if batch.poll() is None:
            batch.kill()
            batch.wait()
    assert batch.returncode == 0, stderr
    rows = {r["run_key"]: r for r in _csv_rows(out / "summary.csv")}
    assert len(rows) == 2 and all(r["status"] == "complete" for r in rows.values())
    # the killed worker's run was taken over by the other worker and resumed from its checkpoint
    assert "resumed" in {r["this_batch"] for r in rows.values()}, stdout
    assert (out / "summary.png").is_file()

    # the same tasks run locally (in this process) give identical results
    ref_out = tmp_path / "ref"
    for t in plan([str(cfg)], 2):
        ref = run_task(t, str(ref_out))
        got = rows[t.key]
        for k in SAME:
            assert str(got[k]) == _csv_str(ref[k]), (k, got[k], ref[k])
        # and the final populations are the same, generation for generation
        a = (out / t.folder_name / "stages" / "weighted_sum" / "history.csv").read_text()
        b = (ref_out / t.folder_name / "stages" / "weighted_sum" / "history.csv").read_text()
        assert a == b


def _csv_rows(path: Path) -> list[dict]:
    import csv

    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def _csv_str(v) -> str:
    return repr(v) if isinstance(v, float) else str(v)


def test_dask_errors_are_one_line(tmp_path):
    from optdesign.cli import main

    port = _free_port()        # nothing listens there
    rc = main(["batch", str(BATCH_SMALL), "--out", str(tmp_path), "--backend", "dask",
               "--scheduler", f"tcp://127.0.0.1:{port}", "--timeout", "1"])
    assert rc == 2
    assert not any(tmp_path.iterdir())          # nothing was run


# ----------------------------------------------------------------------------- hostile listeners
class _Listener:
    """A TCP server on 127.0.0.1 that accepts connections and then says
    nothing (``silent``) or answers garbage (``garbage``)."""

    def __init__(self, mode: str):
        import threading

        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.port = self.sock.getsockname()[1]
        self.mode, self.conns = mode, []
        #: time.monotonic() of the first connection (the client's first contact, after its start-up)
        self.first: float | None = None
        #: a connection found in the backlog at close (the serving thread never took it)
        self.late = False
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self):
        while True:
            try:
                c, _ = self.sock.accept()
            except OSError:
                return
            if self.first is None:
                self.first = time.monotonic()
            self.conns.append(c)
            if self.mode == "garbage":
                try:
                    c.sendall(b"HTTP/1.1 200 OK\r\n\r\n" + b"\xff\x00 not a scheduler " * 500)
                except OSError:
                    pass

    def close(self):
        """Close every connection; a client that connected while the serving
        thread had not yet run (a busy machine) still counts as a contact:
        its connection waits in the backlog, taken here without blocking."""
        self.sock.setblocking(False)
        while True:
            try:
                c, _ = self.sock.accept()
            except OSError:
                break
            self.late = True
            self.conns.append(c)
        for c in self.conns:
            c.close()
        self.sock.close()

    @property
    def contacted(self) -> bool:
        return self.first is not None or self.late


@pytest.mark.parametrize("mode", ["silent", "garbage", "tls without certificates"])
def test_a_listener_that_is_not_a_scheduler(tmp_path, mode):
    """The batch gives up within --timeout (plus start-up) with one line and no
    traceback, whatever answers on the port; nothing is written."""
    listener = _Listener("silent" if mode == "silent" else "garbage")
    scheme = "tls" if mode.startswith("tls") else "tcp"
    # a listener that answers garbage is known at once: a long --timeout costs nothing there and
    # leaves no race between the client's clock and its first contact on a busy machine
    timeout = "2" if mode == "silent" else "20"
    try:
        r = subprocess.run([sys.executable, "-m", "optdesign.cli", "batch", str(BATCH_SMALL), "--out",
                            str(tmp_path / "runs"), "--backend", "dask", "--scheduler",
                            f"{scheme}://127.0.0.1:{listener.port}", "--timeout", timeout],
                           capture_output=True, text=True, timeout=300, cwd=tmp_path,
                           env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])})
        done = time.monotonic()
    finally:
        listener.close()
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("optdesign: error: "), r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr
    # counted from the client's first contact (not from its start-up, which a busy machine stretches):
    # the silent listener's 2 s of --timeout and the exit, the garbage answered at once, well below
    # dask's own connect timeout of 30 s (tls without certificates is refused before any contact)
    assert listener.contacted == (scheme == "tcp"), r.stderr
    if mode == "garbage":
        assert "does not answer as a Dask scheduler" in r.stderr, r.stderr
    if listener.first is not None:
        assert done - listener.first < 20, done - listener.first
    assert not (tmp_path / "runs").exists()


@pytest.mark.slow
def test_sigterm_to_a_dask_batch(cluster, tmp_path, edited_copy):
    """SIGTERM to a batch running on Dask: exit 143, one line, the client closed
    and no process left in the batch's group."""
    address, procs = cluster
    cfg = edited_copy(BATCH_SMALL, {"generations: 5": "generations: 60"}, "slow.yaml")
    out = tmp_path / "runs"
    proc = subprocess.Popen([sys.executable, "-m", "optdesign.cli", "batch", str(cfg), "--seeds", "2", "--out", str(out),
                             "--backend", "dask", "--scheduler", address, "--timeout", "30"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                            start_new_session=True)
    try:
        t0 = time.monotonic()
        while not list(out.glob("*/stages/*")):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() - t0 < 120
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1].startswith("optdesign: batch interrupted (SIGTERM)"), err
    assert "Traceback" not in err
    t0 = time.monotonic()
    while True:
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        assert time.monotonic() - t0 < 120, "a process of the batch's group is left"   # one left stays for good
        time.sleep(0.1)
    for name, p in procs.items():      # the workers would finish the run they hold: no need to wait
        if name.startswith("worker"):
            p.kill()
