"""Batches (issue 3, item 7; issue 7): determinism across --jobs, idempotent
reruns, resume of interrupted runs, sweeps from batch files, the summary table."""
from __future__ import annotations

import csv
import json
import math
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from optdesign.batch import (BackendError, collect_folders, connect_dask, group_stats, load_batch_file, plan,
                             row_from_folder, run_batch, run_task, summary_tables)
from optdesign.cli import main
from optdesign.config import ConfigError, parse_config
from optdesign.optimize.pipeline import Interrupted, run_pipeline
from optdesign.runs import RunFolder

DATA = Path(__file__).parent / "data"
SMALL = DATA / "batch_small.yaml"
#: what must agree exactly between two runs of the same task
SAME = ("config", "config_key", "run_key", "seed", "status", "objective", "opt_r_a", "opt_r_b", "opt_phi",
        "dynamic", "stiffness", "isotropy", "evaluations")


def _stage_files(folder: Path) -> dict[str, str]:
    """Every stage's per-generation history and final population, as text."""
    return {str(p.relative_to(folder)): p.read_text()
            for p in sorted(folder.glob("stages/*/*.csv"))}


@pytest.fixture(scope="module")
def batches(tmp_path_factory):
    """The same two tasks (seeds 1 and 2) run with --jobs 1 and with --jobs 2."""
    root = tmp_path_factory.mktemp("batches")
    tasks = plan([str(SMALL)], 2)
    rows1 = run_batch(tasks, str(root / "jobs1"), jobs=1)
    rows2 = run_batch(tasks, str(root / "jobs2"), jobs=2)
    return tasks, root, rows1, rows2


def test_same_seed_same_result_whatever_jobs(batches):
    tasks, root, rows1, rows2 = batches
    assert [r["seed"] for r in rows1] == [1, 2]
    assert all(r["status"] == "complete" and r["this_batch"] == "new" for r in rows1 + rows2)
    assert rows1[0]["objective"] != rows1[1]["objective"]          # the seeds do differ
    for a, b in zip(rows1, rows2):
        for k in SAME:
            assert a[k] == b[k], k
    for t in tasks:
        assert _stage_files(root / "jobs1" / t.folder_name) == _stage_files(root / "jobs2" / t.folder_name)


def test_rerun_skips_finished_runs(batches, capsys):
    tasks, root, rows1, _ = batches
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


def test_interrupted_runs_resumed_by_rerun(batches, tmp_path):
    tasks, root, rows1, _ = batches
    out = tmp_path / "runs"
    for t, stop in zip(tasks, (13, 27)):
        folder = RunFolder.create(out, t.folder_name, t.config_text, t.seed, t.key, exact=True)
        folder.update_manifest(pareto=False, name=t.name, sweep={})
        with pytest.raises(Interrupted):
            run_pipeline(parse_config(t.config_text), folder, t.seed, stop_after=stop)
        assert folder.read_manifest()["status"] == "interrupted"
        assert any(folder.path.glob("stages/*/checkpoint.pkl"))
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


def test_summary_statistics_match_the_rows(batches, tmp_path):
    tasks, root, rows1, _ = batches
    # an interrupted third run shows up in the table but not in the statistics
    out = tmp_path / "runs"
    shutil.copytree(root / "jobs1", out)
    t3 = plan([str(SMALL)], seeds=[3])[0]
    folder = RunFolder.create(out, t3.folder_name, t3.config_text, t3.seed, t3.key, exact=True)
    folder.update_manifest(name=t3.name)
    with pytest.raises(Interrupted):
        run_pipeline(parse_config(t3.config_text), folder, t3.seed, stop_after=2)

    assert main(["summarize", str(out)]) == 0
    with open(out / "summary.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [r["seed"] for r in table] == ["1", "2", "3"]
    assert [r["status"] for r in table] == ["complete", "complete", "interrupted"]
    assert table[2]["objective"] == ""
    assert (out / "summary.png").stat().st_size > 1000

    rows = [row_from_folder(f) for f in collect_folders([out])]
    (g,) = group_stats(rows)
    assert g["runs"] == 3 and g["complete"] == 2 and g["seeds"] == [1, 2, 3]
    for q in ("objective", "opt_r_a", "dynamic", "stiffness", "isotropy", "wall_time_s"):
        v = np.array([float(r[q]) for r in table[:2]])          # from the CSV, as a user would
        s = g["stats"][q]
        assert s["mean"] == pytest.approx(v.mean(), rel=1e-12)
        assert s["std"] == pytest.approx(v.std(ddof=1), rel=1e-12)
        assert (s["min"], s["max"]) == (v.min(), v.max())
        best = int(np.argmin([float(r["objective"]) for r in table[:2]]))
        assert s["best"] == v[best]
    assert g["best_seed"] == int(table[best]["seed"])
    md = (out / "summary.md").read_text()
    mean, sd = g["stats"]["objective"]["mean"], g["stats"]["objective"]["std"]
    assert re.search(rf"\| objective +\| +{re.escape(f'{mean:.6g}')} \| +{re.escape(f'{sd:.6g}')} \|", md)
    assert "Runs not complete" in md and "interrupted" in md


def test_sweep_grid_zip_and_resolved_configs(tmp_path):
    tasks = plan([str(DATA / "batch_sweep.yaml")])
    assert len(tasks) == 8 and len({t.key for t in tasks}) == 8          # 2 masses × 2 widths × 2 seeds
    got = sorted((parse_config(t.config_text).parameters["m_platform"],
                  parse_config(t.config_text).workspace.axes["x"], t.seed) for t in tasks)
    assert got == sorted((m, x, s) for m in (4.16, 6.0) for x in ((-0.03, 0.03), (-0.05, 0.05)) for s in (1, 2))
    assert len(plan([str(DATA / "batch_sweep.yaml")], n_seeds=1)) == 4     # --seeds overrides the file's seeds

    zipf = tmp_path / "zip.yaml"
    zipf.write_text(f"base: {SMALL}\nmode: zip\nsweep:\n  parameters.m_platform: [4.16, 6.0]\n"
                    "  workspace.axes.x: [[-0.03, 0.03], [-0.05, 0.05]]\n")
    bf = load_batch_file(zipf)
    assert [c[2] for c in bf.combinations] == [{"parameters.m_platform": 4.16, "workspace.axes.x": [-0.03, 0.03]},
                                                {"parameters.m_platform": 6.0, "workspace.axes.x": [-0.05, 0.05]}]
    out = tmp_path / "runs"
    assert main(["batch", str(zipf), "--jobs", "1", "--out", str(out)]) == 0
    folders = collect_folders([out])
    assert len(folders) == 2
    for f, t in zip(sorted(folders), sorted(plan([str(zipf)]), key=lambda t: t.folder_name)):
        assert (f / "config.yaml").read_text() == t.config_text      # the resolved config is what ran
        assert json.loads((f / "manifest.json").read_text())["sweep"] == t.sweep
    groups = group_stats([row_from_folder(f) for f in folders])
    assert [g["sweep"] for g in groups] == ["m_platform=4.16, x=-0.03..0.03", "m_platform=6, x=-0.05..0.05"]
    assert groups[0]["stats"]["dynamic"]["mean"] != groups[1]["stats"]["dynamic"]["mean"]


@pytest.mark.parametrize("body, where", [
    ("sweep: {parameters.m_platform: [1]}", "base: missing required key"),
    ("base: nothere.yaml\n", "base: config file not found"),
    ("base: {small}\nsweeps: {{}}\n", "sweeps: unknown key"),
    ("base: {small}\nsweep: {{parameters.m_platform: 4.0}}\n", "sweep.parameters.m_platform: expected a non-empty list"),
    ("base: {small}\nsweep: {{workspace.axis.x: [[0, 1]]}}\n", "sweep.workspace.axis.x: "),
    ("base: {small}\nsweep: {{mechanism.x: [1]}}\n", "sweep.mechanism.x: can only change keys under"),
    ("base: {small}\nsweep: {{optimizer.seed: [1, 2]}}\n", "sweep.optimizer.seed: the seed is not swept here"),
    ("base: {small}\nsweep: {{parameters.m_platform: [4.0, -1.0]}}\n", "sweep.parameters.m_platform: value -1.0 gives"),
    ("base: {small}\nsweep: {{workspace.axes.x: [[0.05, -0.05]]}}\n", "sweep.workspace.axes.x: value [0.05, -0.05] gives"),
    ("base: {small}\nmode: zip\nsweep: {{parameters.m_platform: [4, 5], parameters.g: [9.81]}}\n", "sweep: zip mode needs lists of equal length"),
    ("base: {small}\nmode: cartesian\n", "mode: expected grid or zip"),
    ("base: {small}\nseeds: [1, -2]\n", "seeds[1]: expected an integer"),
    ("base: {small}\nset: {{optimizer.population: 2}}\n", "set: the resolved config gives optimizer.population"),
])
def test_batch_file_errors_are_one_line(tmp_path, capsys, body, where):
    f = tmp_path / "b.yaml"
    f.write_text(body.format(small=SMALL) if "{small}" in body else body)
    with pytest.raises(ConfigError) as exc:
        load_batch_file(f)
    msg = str(exc.value)
    assert msg.startswith(f"{f}: ") and "\n" not in msg
    assert where in msg, msg
    assert main(["batch", str(f), "--out", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"optdesign: error: {msg}"]
    assert not (tmp_path / "runs").exists()


def test_failed_run_is_a_row_not_a_crash(tmp_path):
    bad = tmp_path / "unreachable.yaml"
    bad.write_text(SMALL.read_text().replace("z: 0.57", "z: 3.0").replace("name: batch_small", "name: unreachable"))
    (t,) = plan([str(bad)])
    row = run_task(t, str(tmp_path / "runs"))
    assert row["status"] == "failed" and "no feasible design" in row["error"]
    assert row["objective"] is None
    assert RunFolder(row["folder"]).read_manifest()["status"] == "failed"
    _, md = summary_tables([row])
    assert "Runs not complete" in md and "no feasible design" in md


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


def test_summarize_usage_errors(tmp_path, capsys):
    assert main(["summarize", str(tmp_path / "nope")]) == 2
    assert "no such directory" in capsys.readouterr().err
    assert main(["summarize", str(tmp_path)]) == 2
    assert "no run folders" in capsys.readouterr().err
    assert math.isnan(group_stats([{"config": "x", "config_key": "k", "seed": 1, "status": "failed",
                                     "objective": None}])[0]["stats"]["objective"]["mean"])


def test_dask_workers_must_see_the_run_folders(tmp_path):
    from optdesign.batch.execute import _check_shared_folder

    class Cluster:            # a client whose second worker is on another file system
        def run(self, fn, *args):
            return {"tcp://10.0.0.1:1": fn(*args), "tcp://10.0.0.2:1": False}

    with pytest.raises(BackendError, match=r"tcp://10.0.0.2:1 does not see .* shared"):
        _check_shared_folder(Cluster(), str(tmp_path))
    assert list(tmp_path.iterdir()) == []          # the marker file is removed


def test_unreadable_checkpoint_fails_that_run_with_a_clear_error(tmp_path):
    (t,) = plan([str(SMALL)], seeds=[5])
    out = tmp_path / "runs"
    folder = RunFolder.create(out, t.folder_name, t.config_text, t.seed, t.key, exact=True)
    with pytest.raises(Interrupted):
        run_pipeline(parse_config(t.config_text), folder, t.seed, stop_after=2)
    (ckpt,) = folder.path.glob("stages/*/checkpoint.pkl")
    ckpt.write_bytes(b"")                        # as a crash before the data reached the disk may leave it
    row = run_task(t, str(out))
    assert row["status"] == "failed" and row["this_batch"] == "resumed"
    assert "corrupted checkpoint" in row["error"] and str(ckpt.parent) in row["error"]
    shutil.rmtree(ckpt.parent)                   # what the message says to do
    row = run_task(t, str(out))
    assert row["status"] == "complete"


def test_validate_config_accepts_batch_files(capsys):
    from optdesign.cli import main

    root = Path(__file__).resolve().parents[1]
    assert main(["validate-config", str(root / "configs" / "batch_example.yaml")]) == 0
    assert "batch file" in capsys.readouterr().out
