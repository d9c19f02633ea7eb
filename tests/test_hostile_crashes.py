"""Issue 20, "Crashes, escapes and races": each case failed on the main of that day."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _legs_with_d_bounds(tmp_path) -> Path:
    """configs/p4s_legs.yaml with d free over [0.05, 0.6] m: d > 2 r_a (theta =
    asin(d / 2 r_a)) is impossible geometry for part of the box."""
    text = (ROOT / "configs" / "p4s_legs.yaml").read_text()
    text, n = re.subn(r"^  d:   \{value: 0\.12\}", "  d:   {value: 0.12, bounds: [0.05, 0.6]}", text, flags=re.M)
    assert n == 1
    text = text.replace("step: 0.01", "step: 0.05")
    p = tmp_path / "legs_d.yaml"
    p.write_text(text)
    return p


@pytest.mark.slow
def test_the_optimality_measure_survives_impossible_geometry_next_to_the_design(tmp_path):
    """At d = 2 r_a the model's derivative is not finite (the optimum of a run
    over that box sits there): the measure says so instead of nnls raising on
    NaN, and a design past it is infeasible."""
    from optdesign.config import load_config
    from optdesign.evaluate import Evaluator
    from optdesign.optimize.polish import optimality
    from optdesign.optimize.problem import DesignProblem, index_term
    from optdesign.report.md import optimality_lines

    ev = Evaluator.from_config(load_config(_legs_with_d_bounds(tmp_path)))
    X = np.array([ev.vector({"r_a": 0.25, "r_b": 0.71, "d": d, "phi": np.radians(35)}) for d in (0.3, 0.55)])
    r = ev(X)
    assert all(np.isfinite(r["values"][k][0]) and not np.isfinite(r["values"][k][1]) for k in r["values"])
    assert max(c[1] for c in r["constraints"].values()) > 0          # impossible geometry is infeasible
    assert max(c[0] for c in r["constraints"].values()) <= 0
    edge = ev.vector({"r_a": 0.25, "r_b": 0.71, "d": 0.5, "phi": np.radians(35)})
    o = optimality(DesignProblem(ev, [index_term("dynamic", "min")]), edge, ev.free)
    assert o["measurable"] is False and o["converged"] is False and o["kkt_relative"] is None
    json.dumps(o, allow_nan=False)                                   # results.json stays valid JSON
    lines = optimality_lines({"polish": {"optimality": o, "starts": 1, "objective": 1.0}})
    assert any("not measured" in line for line in lines)
    inside = ev.vector({"r_a": 0.25, "r_b": 0.67, "d": 0.12, "phi": np.radians(30)})
    o = optimality(DesignProblem(ev, [index_term("dynamic", "min")]), inside, ev.free)
    assert o["measurable"] is True and np.isfinite(o["kkt_relative"])


# ---------------------------------------------------------------- report reads a run folder

RUN = ROOT / "runs" / "p4s_paper-reproduction"


def _one_line_error(rc: int, err: str, *fragments: str) -> None:
    assert rc == 2, (rc, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("optdesign: error: "), err
    for f in fragments:
        assert f in lines[0], (f, lines[0])


def _copy_run(tmp_path) -> Path:
    import shutil

    dst = tmp_path / "run"
    shutil.copytree(RUN, dst, ignore=shutil.ignore_patterns("report.html", "run.lock"))
    return dst


def _link_to_copy(path: Path, elsewhere: Path) -> None:
    """``path`` replaced by a symbolic link to a copy of itself elsewhere (same bytes, same hash)."""
    import shutil

    if path.is_dir():
        shutil.move(str(path), str(elsewhere))
    else:
        elsewhere.write_bytes(path.read_bytes())
        path.unlink()
    path.symlink_to(elsewhere)


@pytest.mark.parametrize("case", ["config.yaml to /etc/passwd", "history.csv to its own copy",
                                  "result.json to its own copy", "stages/ to its own copy",
                                  "a stage folder to its own copy", "results.json to its own copy",
                                  "manifest.json to its own copy"])
def test_report_never_reads_through_a_link_in_the_run_folder(tmp_path, case):
    from cli_helpers import run_cli_in

    run = _copy_run(tmp_path)
    other = tmp_path / "elsewhere"
    if case.startswith("config.yaml"):
        (run / "config.yaml").unlink()
        (run / "config.yaml").symlink_to("/etc/passwd")
        where = "config.yaml"
    else:
        rel = {"history.csv": "stages/weighted_sum/history.csv", "result.json": "stages/weighted_sum/result.json",
               "stages/": "stages", "a stage folder": "stages/prescan", "results.json": "results.json",
               "manifest.json": "manifest.json"}[case.split(" to ")[0]]
        _link_to_copy(run / rel, other)
        where = rel
    rc, out, err = run_cli_in(tmp_path, ["report", str(run), "--resolution", "3"])
    _one_line_error(rc, err, where, "symbolic link")
    assert not (run / "report.html").exists()


@pytest.mark.parametrize("rel", ["stages/weighted_sum/history.csv", "stages/pareto_nsga2/result.json", "pareto_nsga3.csv"])
def test_report_checks_the_recorded_hashes_before_use(tmp_path, rel):
    from cli_helpers import run_cli_in

    run = _copy_run(tmp_path)
    with open(run / rel, "a") as fh:
        fh.write("\n")
    rc, out, err = run_cli_in(tmp_path, ["report", str(run), "--resolution", "3"])
    _one_line_error(rc, err, rel, "SHA-256")
    assert not (run / "report.html").exists()


@pytest.mark.parametrize("case", ["empty stages/", "no stages/", "one stage folder gone"])
def test_report_says_what_is_missing(tmp_path, case):
    import shutil

    from cli_helpers import run_cli_in

    run = _copy_run(tmp_path)
    if case == "one stage folder gone":
        shutil.rmtree(run / "stages" / "weighted_sum")
        want = "weighted_sum"
    else:
        shutil.rmtree(run / "stages")
        if case == "empty stages/":
            (run / "stages").mkdir()
        want = "is empty" if case == "empty stages/" else "is missing"
    rc, out, err = run_cli_in(tmp_path, ["report", str(run), "--resolution", "3"])
    _one_line_error(rc, err, "stages", want)
    assert not (run / "report.html").exists()


def test_report_ignores_stage_files_the_manifest_does_not_record(tmp_path):
    """A planted stage folder (not in the manifest) is never read: the run's own
    files are enough, and the page does not name the stray stage."""
    from optdesign.report.html.rundata import load_run

    run = _copy_run(tmp_path)
    (run / "stages" / "planted").mkdir()
    (run / "stages" / "planted" / "result.json").symlink_to("/etc/passwd")
    (run / "stages" / "weighted_sum" / "extra.csv").write_text("a,b\n1,2\n")
    data = load_run(run)
    assert "planted" not in data.stages and "weighted_sum" in data.history and data.fronts


# ---------------------------------------------------------------- one run at a time in a folder

def test_a_second_resume_of_a_locked_folder_is_refused_naming_the_holder(tmp_path):
    """A process holds RUN/run.lock (as a run does for its whole life): run
    --resume refuses at once with one line naming that process; once the
    holder exits (even by SIGKILL) the resume goes on."""
    import os
    import signal
    import subprocess
    import sys

    from cli_helpers import run_cli_in

    run = _copy_run(tmp_path)
    code = ("import sys; from optdesign.runs import RunFolder\n"
            "lk = RunFolder(sys.argv[1]).lock(); print('locked', flush=True); sys.stdin.read()")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    holder = subprocess.Popen([sys.executable, "-c", code, str(run)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              text=True, env=env, cwd=tmp_path)
    try:
        assert holder.stdout.readline().strip() == "locked"          # a condition, not a sleep
        rc, out, err = run_cli_in(tmp_path, ["run", "--resume", str(run), "--quiet"])
        _one_line_error(rc, err, "already running", f"pid {holder.pid}", str(run))
        assert (run / "run.lock").read_text().startswith(f"pid {holder.pid} on host ")
        # the lock of a process in this one (another open file) is refused the same way
        from optdesign.runs import RunFolder, RunFolderError

        with pytest.raises(RunFolderError, match=f"already running .*pid {holder.pid}"):
            RunFolder(run).lock()
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait()
    rc, out, err = run_cli_in(tmp_path, ["run", "--resume", str(run), "--quiet"])   # a finished run: its summary
    assert rc == 0 and "complete" in out, err
    with RunFolder(run).lock():            # released when the command ended
        pass


def test_run_holds_the_lock_for_its_whole_life(tmp_path, monkeypatch):
    """While the pipeline of a new run goes on, its folder is locked."""
    from optdesign.config import load_config
    from optdesign import runner
    from optdesign.runs import RunFolder, RunFolderError

    seen = []

    def pipeline(cfg, folder, *a, **k):
        with pytest.raises(RunFolderError, match="already running"):
            RunFolder(folder.path).lock()
        seen.append(folder.path)
        raise RuntimeError("stop here")

    monkeypatch.setattr(runner, "run_pipeline", pipeline)
    with pytest.raises(RuntimeError, match="stop here"):
        runner.start_run(load_config(ROOT / "tests" / "data" / "p4s_tiny.yaml"), out=tmp_path / "runs")
    with RunFolder(seen[0]).lock():        # released once the run ended (here by an error)
        pass


def test_a_batch_summary_never_reads_results_through_a_link(tmp_path):
    from optdesign.report.summary import row_from_folder
    from optdesign.runs import RunFolderError

    run = _copy_run(tmp_path)
    assert row_from_folder(run)["objective"] is not None
    _link_to_copy(run / "results.json", tmp_path / "elsewhere.json")
    with pytest.raises(RunFolderError, match="symbolic link"):
        row_from_folder(run)
