"""optdesign.batch.execute: the same seed gives the same run whatever --jobs,
reruns skip finished runs and resume interrupted ones (from their checkpoints),
a failing run is a row and not a crash, and the Dask backend's checks."""
from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from optdesign.batch.execute import BackendError, _check_shared_folder, connect_dask, run_batch, run_task
from optdesign.report.summary import summary_tables
from optdesign.batch.tasks import plan
from optdesign.cli import main
from optdesign.config import parse_config
from optdesign.optimize.pipeline import Interrupted
from optdesign.runner import run_in_folder
from optdesign.runs import RunFolder

from conftest import BATCH_SMALL as SMALL, SAME_FIELDS as SAME


def _stage_files(folder: Path) -> dict[str, str]:
    """Every stage's per-generation history and final population, as text."""
    return {str(p.relative_to(folder)): p.read_text()
            for p in sorted(folder.glob("stages/*/*.csv"))}


@pytest.mark.slow
def test_same_seed_same_result_whatever_jobs(small_batches):
    tasks, root, rows1, rows2 = small_batches
    assert [r["seed"] for r in rows1] == [1, 2]
    assert all(r["status"] == "complete" and r["this_batch"] == "new" for r in rows1 + rows2)
    # the seeds do differ (both may reach the same optimum: the box's corner)
    assert _stage_files(root / "jobs1" / tasks[0].folder_name) != _stage_files(root / "jobs1" / tasks[1].folder_name)
    for a, b in zip(rows1, rows2):
        for k in SAME:
            assert a[k] == b[k], k
    for t in tasks:
        assert _stage_files(root / "jobs1" / t.folder_name) == _stage_files(root / "jobs2" / t.folder_name)


@pytest.mark.slow
def test_rerun_skips_finished_runs(small_batch, capsys):
    tasks, root, rows1 = small_batch
    out = root / "jobs1"
    stamps = {t.key: (out / t.folder_name / "results.json").stat().st_mtime_ns for t in tasks}
    rows = run_batch(tasks, str(out), jobs=1)
    assert [r["this_batch"] for r in rows] == ["done", "done"]
    assert {t.key: (out / t.folder_name / "results.json").stat().st_mtime_ns for t in tasks} == stamps
    for a, b in zip(rows, rows1):
        assert all(a[k] == b[k] for k in SAME)
    # --dry-run lists them as done (and a third seed as new) without running anything
    assert main(["batch", str(SMALL), "--seeds", "3", "--dry-run", "--out", str(out)]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == ["done", "done", "new"]
    assert not (out / plan([str(SMALL)], seeds=[3])[0].folder_name).exists()
    # the same config given twice, or the same seed twice, is planned once
    assert len(plan([str(SMALL), str(SMALL)], seeds=[1, 1, 2])) == 2


@pytest.mark.slow
def test_interrupted_runs_resumed_by_rerun(small_batch, tmp_path):
    tasks, root, rows1 = small_batch
    out = tmp_path / "runs"
    for t, stop in zip(tasks, (13, 27)):
        folder = RunFolder.create(out, t.folder_name, t.config_text, t.seed, t.key, exact=True)
        folder.update_manifest(pareto=False, name=t.name, sweep={})
        with pytest.raises(Interrupted):
            run_in_folder(parse_config(t.config_text), folder, t.seed, stop_after=stop, reports=False)
        assert folder.read_manifest()["status"] == "interrupted"
        assert any(folder.path.glob("stages/*/checkpoint.npz"))
    # a process killed outright leaves its manifest at "running": resumed the same way
    killed = RunFolder(out / tasks[1].folder_name)
    killed.update_manifest(status="running")

    rows = run_batch(tasks, str(out), jobs=1)
    assert [r["this_batch"] for r in rows] == ["resumed", "resumed"]
    for a, b in zip(rows, rows1):
        for k in SAME:
            assert a[k] == b[k], k
    for t in tasks:
        assert _stage_files(out / t.folder_name) == _stage_files(root / "jobs1" / t.folder_name)


def test_failed_run_is_a_row_not_a_crash(tmp_path, edited_copy):
    bad = edited_copy(SMALL, {"z: 0.57": "z: 3.0", "name: batch_small": "name: unreachable"}, "unreachable.yaml")
    (t,) = plan([str(bad)])
    row = run_task(t, str(tmp_path / "runs"))
    assert row["status"] == "failed" and "no feasible design" in row["error"]
    assert row["objective"] is None
    assert RunFolder(row["folder"]).read_manifest()["status"] == "failed"
    _, md = summary_tables([row])
    assert "Runs not complete" in md and "no feasible design" in md


@pytest.mark.slow
def test_unreadable_checkpoint_fails_that_run_with_a_clear_error(tmp_path):
    (t,) = plan([str(SMALL)], seeds=[5])
    out = tmp_path / "runs"
    folder = RunFolder.create(out, t.folder_name, t.config_text, t.seed, t.key, exact=True)
    with pytest.raises(Interrupted):
        run_in_folder(parse_config(t.config_text), folder, t.seed, stop_after=2, reports=False)
    (ckpt,) = folder.path.glob("stages/*/checkpoint.npz")
    ckpt.write_bytes(b"")                        # as a crash before the data reached the disk may leave it
    row = run_task(t, str(out))
    assert row["status"] == "failed" and row["this_batch"] == "resumed"
    assert "corrupted checkpoint" in row["error"] and str(ckpt.parent) in row["error"]
    shutil.rmtree(ckpt.parent)                   # what the message says to do
    row = run_task(t, str(out))
    assert row["status"] == "complete"


def test_dask_backend_without_the_extra(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)      # as if dask[distributed] were not installed
    with pytest.raises(BackendError, match=r"pip install 'optdesign\[dask\]'"):
        connect_dask("tcp://127.0.0.1:1")
    rc = main(["batch", str(SMALL), "--backend", "dask", "--scheduler", "tcp://127.0.0.1:1", "--out", str(tmp_path)])
    assert rc == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].startswith("optdesign: error: --backend dask needs the dask extra")


@pytest.mark.parametrize("args, msg", [
    (["--backend", "dask"], "--backend dask needs --scheduler"),
    (["--backend", "dask", "--scheduler", "foo:bar"], "--scheduler: expected an address"),
    (["--scheduler", "tcp://127.0.0.1:8786"], "--scheduler is only used with --backend dask"),
    (["--backend", "dask", "--scheduler", "tcp://127.0.0.1:8786", "--jobs", "2"], "--jobs is for --backend local"),
    (["--seeds", "0"], "--seeds: expected a positive integer"),
    (["--seed-list", "1,x"], "--seed-list: expected integers"),
])
def test_batch_usage_errors(tmp_path, capsys, args, msg):
    assert main(["batch", str(SMALL), "--out", str(tmp_path / "r"), *args]) == 2
    assert msg in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_dask_workers_must_see_the_run_folders(tmp_path):
    class Cluster:            # a client whose second worker is on another file system
        def run(self, fn, *args):
            return {"tcp://10.0.0.1:1": fn(*args), "tcp://10.0.0.2:1": False}

    with pytest.raises(BackendError, match=r"tcp://10.0.0.2:1 does not see .* shared"):
        _check_shared_folder(Cluster(), str(tmp_path))
    assert list(tmp_path.iterdir()) == []          # the marker file is removed
