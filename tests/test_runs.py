"""Run folders: contents, resume equals uninterrupted, signals, corrupted folders."""
from __future__ import annotations

import functools
import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import edited_text

from optdesign.config import load_config, parse_config
from optdesign.optimize.pipeline import Interrupted
from optdesign.runner import resume_run as _resume_run
from optdesign.runner import start_run as _start_run
from optdesign.runs import FORMAT_VERSION, RunFolder, RunFolderError
from optdesign.studies.p4s_paper import table3_note

DATA = Path(__file__).parent / "data"
SMALL = DATA / "p4s_small.yaml"
#: runs as `optdesign run` starts and resumes them: with the paper study's note on the reference
start_run = functools.partial(_start_run, reference_note=table3_note)
resume_run = functools.partial(_resume_run, reference_note=table3_note)


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs")
    res = start_run(load_config(SMALL), seed=7, out=out)
    return res


def _strip(results: dict) -> dict:
    r = dict(results)
    r.pop("wall_time_s", None)
    return r


@pytest.mark.slow
def test_run_folder_is_complete(finished):
    p = finished.folder.path
    for f in ("config.yaml", "manifest.json", "results.json", "results.md", "history.csv", "population.csv",
              "convergence.png", "pareto.png", "pareto_nsga2.csv", "pareto_nsga3.csv"):
        assert (p / f).is_file(), f
    assert not list(p.rglob("*.tmp")), "a temporary file was left behind"
    m = json.loads((p / "manifest.json").read_text())
    assert m["status"] == "complete" and m["seed"] == 7 and m["format_version"] == FORMAT_VERSION
    assert m["evaluations"] > 0 and m["wall_time_s"] > 0 and m["end_time"]
    assert {"numpy", "pymoo", "optdesign"} <= set(m["versions"])
    r = json.loads((p / "results.json").read_text())
    assert r["status"] == "complete" and r["seed"] == 7
    assert set(r["optimum"]) == {"r_a", "r_b", "L", "d", "phi"}
    assert 0.21 <= r["optimum"]["r_a"] <= 0.29 and np.radians(25) <= r["optimum"]["phi"] <= np.radians(35)
    assert set(r["global_indices"]) == {"dynamic", "stiffness", "isotropy"}
    assert np.isfinite(r["objective"])
    md = (p / "results.md").read_text()
    assert "| phi       |  deg |" in md and "35.0000" in md  # the after design in degrees, the unit named
    # results.md speaks of the config's reference, never of a paper -- except in the note on what the
    # reference (this config's is the paper's) can and cannot confirm, which is about that paper
    note = r.get("reference_note", "")
    assert note and "Table 3" in note
    assert "paper" not in md.replace(note, "").lower() and "eq." not in md
    # the history has one row per generation of the weighted-sum GA
    rows = (p / "history.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + 8


@pytest.mark.slow
def test_single_point_front_when_indices_agree(finished):
    """Within the paper's bounds the three indices do not conflict: the front
    collapses to (nearly) one design."""
    pr = finished.results["pareto"]["pareto_nsga2"]
    assert pr["front_spread"] < 0.05


@pytest.mark.slow
def test_weighted_optimum_against_the_front(tmp_path):
    """The weighted-sum optimum is not dominated by any point of the NSGA-II
    front (indices + base radius, a real trade-off) by more than the front's own spread."""
    res = start_run(load_config(DATA / "p4s_tradeoff_small.yaml"), seed=4, out=tmp_path)
    finished = res
    pr = finished.results["pareto"]["pareto_nsga2"]
    assert pr["front_size"] >= 3 and pr["front_spread"] > 0.1
    pl = pr["placement"]["weighted_sum_optimum"]
    assert pl["epsilon"] >= -pr["front_spread"]
    assert pr["hypervolume"] > 0
    # placement is computed, not assumed: check one epsilon by hand from the CSV
    import csv

    with open(finished.folder.path / "pareto_nsga2.csv") as fh:
        front = list(csv.DictReader(fh))
    terms = pr["normalization"]["terms"]
    lo, hi = np.array(pr["normalization"]["best"]), np.array(pr["normalization"]["worst"])
    # the CSV shows each objective in its own sense and shown unit ('stiffness [N/m]'):
    # back to the minimized SI objectives the placement uses
    from optdesign.units import objective_unit, strip_unit

    cfg = load_config(DATA / "p4s_tradeoff_small.yaml")
    front = [{strip_unit(k): float(v) for k, v in r.items()} for r in front]
    F = np.array([[(-1 if t.startswith("-") else 1) * r[t.lstrip("-")] / objective_unit(cfg.units(), t.lstrip("-"))[1]
                   for t in terms] for r in front])
    Fn = (F - lo) / (hi - lo)
    p = np.array(pl["normalized_objectives"])
    assert pl["epsilon"] == pytest.approx(np.min(np.max(Fn - p, axis=1)))


@pytest.mark.slow
@pytest.mark.parametrize("stop_after", [3, 17, 50])
def test_resume_equals_uninterrupted(finished, tmp_path, stop_after):
    cfg = load_config(SMALL)
    with pytest.raises(Interrupted):
        start_run(cfg, seed=7, out=tmp_path, name="cut", stop_after=stop_after)
    (folder,) = list(tmp_path.iterdir())
    m = json.loads((folder / "manifest.json").read_text())
    assert m["status"] == "interrupted"
    assert not (folder / "results.json").exists()
    res = resume_run(folder)
    assert res.results["status"] == "complete"
    assert _strip(res.results) == _strip(finished.results)


@pytest.mark.slow
def test_a_stop_saves_a_checkpoint_whatever_the_interval(finished, tmp_path):
    """With checkpoint_interval far longer than the run, no checkpoint is written
    on the way, but a stop still saves one, and the resumed run ends as the
    uninterrupted one (which checkpointed every generation)."""
    cfg = parse_config(SMALL.read_text().replace("checkpoint_interval: 0", "checkpoint_interval: 100000"),
                       source=str(SMALL))
    assert cfg.optimizer.checkpoint_interval == 100000
    with pytest.raises(Interrupted):
        start_run(cfg, seed=7, out=tmp_path, name="cut", stop_after=11)   # inside the second stage
    (folder,) = list(tmp_path.iterdir())
    (ck,) = list(folder.rglob("checkpoint.npz"))
    assert RunFolder(folder).load_checkpoint(ck.parent.name)[0]["history"]["rows"] == 11 - 8
    res = resume_run(folder)
    assert _strip(res.results) == _strip(finished.results)


@pytest.mark.slow
def test_resume_twice_interrupted(finished, tmp_path):
    cfg = load_config(SMALL)
    with pytest.raises(Interrupted):
        start_run(cfg, seed=7, out=tmp_path, name="cut", stop_after=5)
    (folder,) = list(tmp_path.iterdir())
    with pytest.raises(Interrupted):
        resume_run(folder, stop_after=30)
    res = resume_run(folder)
    assert _strip(res.results) == _strip(finished.results)


@pytest.mark.slow
def test_resume_at_generations_of_every_stage_kind_is_byte_identical(tmp_path):
    """One folder of p4s_tiny.yaml (4 single-index stages and 2 weighted sums of
    4 generations, NSGA-II and NSGA-III of 3) stopped again and again: in a
    single-index stage, at the first generation of the weighted sum, inside the
    literal one, inside NSGA-II, at NSGA-III's first generation, at its last;
    then finished.  Every file equals the uninterrupted run's."""
    tiny = DATA / "p4s_tiny.yaml"
    whole = start_run(load_config(tiny), seed=7, out=tmp_path / "whole")
    with pytest.raises(Interrupted):
        start_run(load_config(tiny), seed=7, out=tmp_path / "cut", stop_after=2)
    (folder,) = list((tmp_path / "cut").iterdir())
    done = 2
    for at in (17, 22, 26, 28, 30):
        with pytest.raises(Interrupted):
            resume_run(folder, stop_after=at - done)
        done = at
        assert json.loads((folder / "manifest.json").read_text())["status"] == "interrupted"
    res = resume_run(folder)
    assert _strip(json.loads(json.dumps(res.results))) == _strip(json.loads(json.dumps(whole.results)))
    files = [p.relative_to(whole.folder.path) for p in whole.folder.path.rglob("*")
             if p.suffix == ".csv" or p.name == "result.json"]
    assert len(files) >= 8 * 3 + 2 + 2
    for rel in files:
        assert (folder / rel).read_bytes() == (whole.folder.path / rel).read_bytes(), rel


@pytest.mark.slow
def test_stages_in_two_processes_equal_one(finished, tmp_path):
    """jobs=2 runs stages in a worker process too: same results, a complete
    manifest (written by this process only), no stop file left behind."""
    res = start_run(load_config(SMALL), seed=7, out=tmp_path, jobs=2)
    assert _strip(res.results) == _strip(finished.results)
    m = json.loads((res.folder.path / "manifest.json").read_text())
    assert m["status"] == "complete"
    assert sorted(m["stages_done"]) == sorted(p.name for p in (res.folder.path / "stages").iterdir())
    assert not (res.folder.path / ".stop").exists()
    for f in ("history.csv", "pareto_nsga2.csv", "pareto_nsga3.csv"):
        assert (res.folder.path / f).read_text() == (finished.folder.path / f).read_text(), f


def test_concurrent_runs_never_share_a_folder(tmp_path):
    made = {RunFolder.create(tmp_path, "same", "x: 1\n", 1, "k").path for _ in range(20)}
    assert len(made) == 20


@pytest.mark.slow
def test_corrupted_and_foreign_folders_give_clear_errors(tmp_path, finished):
    with pytest.raises(RunFolderError, match="not a run folder"):
        RunFolder(tmp_path / "nothing").read_manifest()
    bad = RunFolder.create(tmp_path, "bad", SMALL.read_text(), 1, "k")
    bad.manifest_path.write_text("{not json")
    with pytest.raises(RunFolderError, match="corrupted"):
        resume_run(bad.path)
    old = RunFolder.create(tmp_path, "old", SMALL.read_text(), 1, "k")
    m = old.read_manifest()
    m["format_version"] = 0
    old.manifest_path.write_text(json.dumps(m))
    with pytest.raises(RunFolderError, match="format version"):
        resume_run(old.path)
    # a corrupted checkpoint
    cfg = load_config(SMALL)
    with pytest.raises(Interrupted):
        start_run(cfg, seed=7, out=tmp_path / "c", stop_after=2)
    (folder,) = list((tmp_path / "c").iterdir())
    (ck,) = list(folder.rglob("checkpoint.npz"))
    ck.write_bytes(b"garbage")
    with pytest.raises(RunFolderError, match="corrupted checkpoint"):
        resume_run(folder)


def _cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "optdesign.cli", *args], capture_output=True, text=True, **kw)


@pytest.mark.slow
def test_sigterm_leaves_an_incomplete_folder_that_resumes(tmp_path, finished):
    """A real process, a real SIGTERM, then ``optdesign run --resume``."""
    out = tmp_path / "runs"
    proc = subprocess.Popen([sys.executable, "-m", "optdesign.cli", "run", str(SMALL), "--seed", "7",
                             "--out", str(out), "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        if list(out.rglob("checkpoint.npz")):
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=120)
    (folder,) = list(out.iterdir())
    m = json.loads((folder / "manifest.json").read_text())
    if proc.returncode == 0:  # the run finished before the signal arrived
        assert m["status"] == "complete"
    else:
        assert proc.returncode == 143, stderr
        assert m["status"] == "interrupted"
        assert "Traceback" not in stderr and "--resume" in stderr
        r = _cli("run", "--resume", str(folder), "--quiet")
        assert r.returncode == 0, r.stderr
    res = json.loads((folder / "results.json").read_text())
    assert _strip(res) == _strip(json.loads(json.dumps(finished.results)))


@pytest.mark.slow
def test_run_command_errors_are_one_line(tmp_path):
    r = _cli("run", "--resume", str(tmp_path / "missing"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    r = _cli("run")
    assert r.returncode == 2 and "Traceback" not in r.stderr


@pytest.mark.slow
def test_an_index_with_weight_zero_stays_on_the_front(tmp_path):
    """An index with weight 0 gets no single-objective runs and no term in the
    weighted sum, but is still an objective of the Pareto front."""
    text = edited_text(SMALL.read_text(), {
        "population: 16, generations: 8,":
        "weights: {dynamic: 1, stiffness: 1, isotropy: 0}, population: 10, generations: 3,"})
    cfg_path = tmp_path / "w0.yaml"
    cfg_path.write_text(text)
    res = start_run(load_config(cfg_path), seed=1, out=tmp_path / "runs")
    assert set(res.results["normalization"]) == {"dynamic", "stiffness"}
    assert "single_isotropy_min" not in res.stages
    pr = res.results["pareto"]["pareto_nsga2"]
    assert pr["normalization"]["terms"] == ["dynamic", "-stiffness", "isotropy"]


@pytest.mark.slow
def test_an_old_folder_with_the_removed_optimizer_keys_resumes_and_reports(tmp_path):
    """optimizer.normalization and optimizer.min_transmission had no effect and
    were removed: a new config holding them is refused with one line, but the
    config.yaml of an earlier run folder holding them still resumes and reports."""
    from optdesign.report.folders import config_of_folder
    from optdesign.report.html.rundata import load_run

    tiny = DATA / "p4s_tiny.yaml"
    old = tiny.read_text().replace("optimizer: {", "optimizer: {normalization: sense, min_transmission: 0.2, ")
    for key, value in (("normalization", "sense"), ("min_transmission", "0.2")):
        text = tiny.read_text().replace("optimizer: {", f"optimizer: {{{key}: {value}, ")
        with pytest.raises(Exception, match=rf"new\.yaml: optimizer\.{key}: this key was removed .*; delete it"):
            parse_config(text, source="new.yaml")
    cfg = load_config(tiny)
    cfg.text = old                      # the folder keeps the text of an earlier version
    with pytest.raises(Interrupted):
        start_run(cfg, seed=7, out=tmp_path, name="old", stop_after=2)
    folder = next(tmp_path.iterdir())
    assert "min_transmission" in (folder / "config.yaml").read_text()
    assert config_of_folder(folder).optimizer.weights == cfg.optimizer.weights
    res = resume_run(folder)
    assert res.results["status"] == "complete"
    assert set(load_run(folder).results["global_indices"]) == {"dynamic", "stiffness"}


@pytest.mark.slow
def test_the_pipeline_writes_the_reports_it_is_handed(tmp_path):
    """The optimizer knows no report and no study: without outputs a run writes
    the optimizer's files only; with them, the note it is handed lands in
    results.json, the report is written before the manifest says complete and
    the page after; the numbers are the same either way."""
    from optdesign.optimize.outputs import RunOutputs
    from optdesign.optimize.pipeline import run_pipeline
    from optdesign.runner import config_text, run_outputs, run_spec

    cfg = load_config(DATA / "p4s_tiny.yaml")
    text = config_text(cfg)
    spec = run_spec(cfg)        # the plain pieces the pipeline reads: no config below the runner
    bare = run_pipeline(spec, RunFolder.create(tmp_path, "bare", text, 7, "k"), 7, pareto=False)
    assert (bare.folder.path / "results.json").is_file()
    assert not [n for n in ("results.md", "optimum.yaml", "report.html", "convergence.png", "history.csv")
                if (bare.folder.path / n).exists()]
    assert "reference_note" not in bare.results
    seen = []
    outputs = RunOutputs(reference_note=lambda: "a note",
                         write_report=lambda f, r, s: seen.append(("report", f.read_manifest()["status"])),
                         write_html=lambda f: seen.append(("html", f.read_manifest()["status"])))
    handed = run_pipeline(spec, RunFolder.create(tmp_path, "handed", text, 7, "k"), 7, pareto=False, outputs=outputs)
    assert handed.results.pop("reference_note") == "a note"
    assert seen == [("report", "running"), ("html", "complete")]
    assert _strip(handed.results) == _strip(bare.results)
    full = run_pipeline(spec, RunFolder.create(tmp_path, "full", text, 7, "k"), 7, pareto=False,
                        outputs=run_outputs(cfg, lambda c: f"a note on {c.name}"))
    assert full.results.pop("reference_note") == f"a note on {cfg.name}"   # the runner binds the study to the config
    assert all((full.folder.path / n).is_file() for n in ("results.md", "optimum.yaml", "report.html", "history.csv"))
    assert _strip(full.results) == _strip(bare.results)
