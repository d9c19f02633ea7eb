"""Stop requests and the stage worker pool (optimize/workers.py), with real
signals and real worker processes.

* A stop request follows the signals: at a generation boundary during the
  stages, at once before them, not at all once the run is complete; the stop
  file and a vanished parent stop a worker.
* A busy worker asked through the stop file stops at its next generation
  boundary with its checkpoint on disk, and the stage resumed from it ends as
  an uninterrupted one; a busy worker whose parent is SIGKILLed saves, stops
  and exits by itself.
* ``--jobs 2`` gives every file of ``--jobs 1`` byte for byte, and the
  weighted sums start only after every single-index run.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from conftest import DATA, edited_text

from optdesign.config import load_config, parse_config
from optdesign.optimize.pipeline import _stage_in_worker, execute_stage, stage_plan
from optdesign.runner import run_spec, start_run
from optdesign.optimize.workers import Interrupted, StagePool, StopRequest
from optdesign.runs import RunFolder

TINY = DATA / "p4s_tiny.yaml"


def _comparable(path: Path) -> dict:
    r = json.loads((path / "results.json").read_text())
    r.pop("wall_time_s")
    return r


def test_signals_stop_at_the_boundary_at_once_or_not_at_all():
    stop = StopRequest().install()
    try:
        os.kill(os.getpid(), signal.SIGTERM)             # during the stages: noted, the GA stops at its boundary
        assert stop.requested() and stop.signum == signal.SIGTERM and not stop.insisted
        with pytest.raises(Interrupted) as exc:          # a second one: at once
            os.kill(os.getpid(), signal.SIGINT)
        assert stop.insisted and exc.value.signum == signal.SIGINT
    finally:
        stop.restore()
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    early = StopRequest(deferred=False).install()
    try:
        with pytest.raises(Interrupted):                 # before the run starts: at once
            os.kill(os.getpid(), signal.SIGTERM)
        early.signum, early.completed = None, True
        os.kill(os.getpid(), signal.SIGTERM)             # once complete: noted only
        os.kill(os.getpid(), signal.SIGINT)
        assert early.late == signal.SIGINT and not early.requested()
    finally:
        early.restore()


def test_stop_file_and_a_vanished_parent(tmp_path):
    f = tmp_path / ".stop"
    s = StopRequest(f, os.getppid())
    assert not s.requested()
    f.write_text("2")
    assert s.requested() and s.signum == 2
    orphan = StopRequest(None, parent=os.getppid() + 12345)   # not our parent: as if it had gone
    assert orphan.requested() and orphan.signum == signal.SIGTERM


def _long(tmp_path, generations: int):
    """A config whose first GA stage runs ``generations`` generations, and a fresh folder for it."""
    text = edited_text(TINY.read_text(), {"generations: 4,": f"generations: {generations},"})
    cfg = parse_config(text, source=str(tmp_path / "long.yaml"))
    return cfg, text


def _first_ga_stage(spec):
    return next(s for s in stage_plan(spec.optimizer, spec.evaluator.senses) if s.kind == "single")


@pytest.mark.slow
def test_a_busy_worker_stops_at_the_boundary_and_its_stage_resumes(tmp_path):
    cfg, text = _long(tmp_path, 400)
    spec = run_spec(cfg)
    pieces = (spec.evaluator, spec.optimizer, spec.units)     # what a stage reads
    st = _first_ga_stage(spec)
    folder = RunFolder.create(tmp_path / "runs", "w", text, 11, "k")
    pool = StagePool(1, folder.path)
    try:
        pool.submit((0, st), st.name, _stage_in_worker, *pieces, str(folder.path), st, 0, {}, {}, 11, None)
        ck = folder.checkpoint_path(st.name)
        deadline = time.time() + 120
        while not ck.exists() and time.time() < deadline:
            time.sleep(0.01)
        assert ck.exists(), "the worker wrote no checkpoint"
        pool.stop(signal.SIGTERM, wait=True)
        fut, = pool.running
        with pytest.raises(Interrupted) as exc:
            fut.result()
        assert exc.value.signum == signal.SIGTERM
    finally:
        pool.close()
    assert not (folder.path / ".stop").exists()
    meta, _ = folder.load_checkpoint(st.name)
    assert meta["history"]["rows"] == meta["n_iter"] - 1 < 400     # stopped early, at a boundary
    execute_stage(*pieces, folder, st, 0, {}, {}, 11)                # resumed here
    whole = RunFolder.create(tmp_path / "runs", "whole", text, 11, "k")
    execute_stage(*pieces, whole, st, 0, {}, {}, 11)
    for f in ("history.csv", "population.csv", "result.json"):
        a = (folder.path / "stages" / st.name / f).read_bytes()
        assert a == (whole.path / "stages" / st.name / f).read_bytes(), f


def _children(pid: int) -> list[int]:
    out = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            out += [int(c) for c in (task / "children").read_text().split()]
        except (FileNotFoundError, ProcessLookupError):
            pass
    return out


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes() != b""
    except (FileNotFoundError, ProcessLookupError):
        return False


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs Linux /proc")
def test_an_orphaned_busy_worker_saves_stops_and_exits(tmp_path):
    cfg, text = _long(tmp_path, 100000)
    (tmp_path / "long.yaml").write_text(text)
    script = textwrap.dedent(f"""
        import sys, time
        from optdesign.config import load_config
        from optdesign.optimize.pipeline import _stage_in_worker, stage_plan
        from optdesign.optimize.workers import StagePool
        from optdesign.runner import run_spec
        from optdesign.runs import RunFolder
        spec = run_spec(load_config({str(tmp_path / 'long.yaml')!r}))
        st = next(s for s in stage_plan(spec.optimizer, spec.evaluator.senses) if s.kind == "single")
        folder = RunFolder.create({str(tmp_path / 'runs')!r}, "orphan", open({str(tmp_path / 'long.yaml')!r}).read(), 11, "k", exact=True)
        pool = StagePool(1, folder.path)
        pool.submit((0, st), st.name, _stage_in_worker, spec.evaluator, spec.optimizer, spec.units,
                    str(folder.path), st, 0, {{}}, {{}}, 11, None)
        while not folder.checkpoint_path(st.name).exists():
            time.sleep(0.01)
        print("busy", flush=True)
        time.sleep(600)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "busy"
        (worker,) = [c for c in _children(proc.pid) if b"spawn_main" in Path(f"/proc/{c}/cmdline").read_bytes()]
        proc.kill()
        proc.wait(timeout=300)
        t0 = time.time()
        while _alive(worker) and time.time() - t0 < 300:
            time.sleep(0.05)
        assert not _alive(worker), "the busy worker outlived its SIGKILLed parent"
    finally:
        proc.kill()
    folder = RunFolder(tmp_path / "runs" / "orphan")
    meta, _ = folder.load_checkpoint(_first_ga_stage(run_spec(cfg)).name)   # whole, and data only
    assert 1 <= meta["history"]["rows"] == meta["n_iter"] - 1 < 100000


@pytest.mark.slow
def test_two_processes_give_every_file_of_one(tmp_path):
    one = start_run(load_config(TINY), seed=5, out=tmp_path / "one", jobs=1).folder.path
    two = start_run(load_config(TINY), seed=5, out=tmp_path / "two", jobs=2).folder.path
    assert _comparable(one) == _comparable(two)
    files = sorted(p.relative_to(one) for p in one.rglob("*") if p.suffix == ".csv" or p.name == "result.json")
    assert len(files) >= 3 * 8 + 2
    for rel in files:
        assert (one / rel).read_bytes() == (two / rel).read_bytes(), rel
    done = json.loads((two / "manifest.json").read_text())["stages_done"]
    singles = [i for i, s in enumerate(done) if s.startswith("single_")]
    assert len(singles) == 4 and max(singles) < min(done.index("weighted_sum"), done.index("weighted_sum_literal"))
    assert not (two / ".stop").exists()
