"""progress.json in a run folder and ``optdesign status RUN`` (issue 20, "a run
you can watch"): written atomically, at most once a second, in the config's
units, and readable from another process while the run goes on."""
from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from cli_helpers import run_cli_in

ROOT = Path(__file__).resolve().parents[1]
TINY = ROOT / "tests" / "data" / "p4s_tiny.yaml"


# ---------------------------------------------------------------- the file's writer
def test_status_file_writes_at_most_once_per_interval_and_the_end_at_once(tmp_path):
    from optdesign.optimize.watch import PROGRESS_FILE, StatusFile

    n = {"calls": 0}

    def snap():
        n["calls"] += 1
        return {"status": "running", "generation": n["calls"]}

    sf = StatusFile(tmp_path, snap, interval=3600.0)
    for _ in range(50):
        sf.poke()
    assert sf.writes == 1                               # the first at once, the others wait for the hour
    data = json.loads((tmp_path / PROGRESS_FILE).read_text())
    assert data["status"] == "running" and data["generation"] == 1 and data["format"] == 1
    assert data["updated_at"].endswith("Z") and isinstance(data["pid"], int)
    sf.end("interrupted")                               # the end is written at once, and is the last write
    sf.poke()
    assert sf.writes == 2
    assert json.loads((tmp_path / PROGRESS_FILE).read_text())["status"] == "interrupted"
    assert not [p for p in tmp_path.iterdir() if p.name != PROGRESS_FILE]   # no temporary file left


def test_status_file_writes_a_deferred_change_when_the_interval_is_over(tmp_path):
    from optdesign.optimize.watch import PROGRESS_FILE, StatusFile

    state = {"g": 1}
    sf = StatusFile(tmp_path, lambda: {"generation": state["g"]}, interval=0.05)
    sf.poke()
    state["g"] = 2
    sf.poke()                                           # within the interval: deferred, not lost
    for _ in range(400):                                # the timer's write (no assumption on its delay)
        if sf.writes >= 2:
            break
        time.sleep(0.05)
    assert sf.writes == 2
    assert json.loads((tmp_path / PROGRESS_FILE).read_text())["generation"] == 2


def test_status_file_refuses_to_write_through_a_link_and_the_run_goes_on(tmp_path):
    from optdesign.optimize.watch import PROGRESS_FILE, StatusFile

    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    (tmp_path / PROGRESS_FILE).symlink_to(victim)
    sf = StatusFile(tmp_path, lambda: {"x": 1}, interval=0.0)
    sf.poke()                                           # no exception: progress never stops a run
    assert victim.read_text() == "keep" and sf.failed and sf.writes == 0


def test_snapshot_has_stage_generation_best_in_units_and_eta(tmp_path):
    from optdesign.optimize.progress import Progress

    p = Progress(False)
    p.watch(tmp_path)                                   # tracking without a terminal
    p.plan([("prescan", 1, 100), ("single_stiffness_max", 10, 8)])
    p._t0 -= 5.0
    p.stage_done("prescan", "31 of 32 designs feasible")
    p.start("single_stiffness_max", 10, describe=lambda r: f"stiffness = {r:.4g} N/m")
    p.update(3, 0.0005307)
    s = p.snapshot()
    assert s["stage"] == "single_stiffness_max" and s["generation"] == 3 and s["generations"] == 10
    assert s["best"] == "stiffness = 0.0005307 N/m"
    assert s["stages_done"] == 1 and s["stages_total"] == 2
    assert s["eta_s"] is not None and s["eta"] and s["eta_s"] > 0
    assert s["finished"] == [{"stage": "prescan", "label": "[1/2] prescan", "result": "31 of 32 designs feasible"}]
    json.dumps(s)                                       # JSON as it is


# ---------------------------------------------------------------- a run writes it
@pytest.fixture(scope="module")
def watched(tmp_path_factory):
    """A tiny run stopped inside its stages, with every progress.json it wrote (interval 0)."""
    from optdesign.config import load_config
    from optdesign.optimize import watch
    from optdesign.runner import start_run
    from optdesign.optimize.workers import Interrupted

    tmp = tmp_path_factory.mktemp("watched")
    seen = []
    orig = watch.StatusFile._write

    def spy(self, extra):
        orig(self, extra)
        seen.append(json.loads(self.path.read_text()))

    old_init = watch.StatusFile.__init__

    def fast(self, folder, snapshot, interval=1.0):
        old_init(self, folder, snapshot, 0.0)

    watch.StatusFile._write, watch.StatusFile.__init__ = spy, fast
    try:
        with pytest.raises(Interrupted) as exc:
            start_run(load_config(TINY), seed=3, out=tmp, stop_after=9, pareto=False)
    finally:
        watch.StatusFile._write, watch.StatusFile.__init__ = orig, old_init
    return Path(exc.value.folder), seen


def test_a_run_writes_its_progress_during_the_stages_and_how_it_ended(watched):
    folder, seen = watched
    running = [s for s in seen if s["status"] == "running" and s["stage"]]
    assert running, seen
    ga = [s for s in running if s["stage"].startswith("single_")]
    assert ga and max(s["generation"] for s in ga) >= 2
    assert any("kg" in (s["best"] or "") or "N/m" in (s["best"] or "") for s in ga)   # best in units, named
    assert any(s["eta_s"] is not None for s in running[1:]) or all(s["elapsed_s"] <= 1.0 for s in running)
    assert seen[-1]["status"] == "interrupted"
    assert json.loads((folder / "progress.json").read_text())["status"] == "interrupted"


def test_status_prints_the_progress_and_the_resume_command(watched):
    folder, _ = watched
    rc, out, err = run_cli_in(folder.parent, ["status", folder.name])
    assert rc == 0, err
    assert f"run: {folder.name} (interrupted" in out
    assert "stages done" in out and "done [1/" in out
    assert f"optdesign run --resume {folder.name}" in out
    rc, out, err = run_cli_in(folder.parent, ["status", folder.name, "--json"])
    assert rc == 0 and json.loads(out)["status"] == "interrupted"


def test_status_of_a_folder_that_is_no_run_or_has_no_progress_is_one_line(tmp_path, watched):
    import shutil

    folder, _ = watched
    (tmp_path / "plain").mkdir()
    for target, what in ((tmp_path / "missing", "no such directory"), (tmp_path / "plain", "no manifest.json")):
        rc, out, err = run_cli_in(tmp_path, ["status", str(target)])
        assert rc == 2 and err.count("\n") == 1 and what in err, err
    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    (copy / "progress.json").unlink()
    rc, out, err = run_cli_in(tmp_path, ["status", "copy"])
    assert rc == 2 and err.count("\n") == 1 and "no progress.json" in err, err
    (copy / "progress.json").write_text("{not json")
    rc, out, err = run_cli_in(tmp_path, ["status", "copy"])
    assert rc == 2 and err.count("\n") == 1 and "not valid JSON" in err, err
    (copy / "progress.json").unlink()
    (copy / "progress.json").symlink_to(folder / "progress.json")
    rc, out, err = run_cli_in(tmp_path, ["status", "copy"])
    assert rc == 2 and err.count("\n") == 1 and "link" in err, err


@pytest.mark.slow
def test_status_from_another_process_while_the_run_goes_on(tmp_path):
    """``optdesign status`` in a second process sees the run running, then complete."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPTDESIGN_WARMUP": "0", "MPLBACKEND": "Agg"}
    (tmp_path / "tiny.yaml").write_text(TINY.read_text())
    run = subprocess.Popen([sys.executable, "-m", "optdesign", "run", "tiny.yaml", "--out", "runs", "--jobs", "1",
                            "--quiet", "--no-pareto"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    seen = set()
    try:
        while run.poll() is None:
            for f in (tmp_path / "runs").glob("*/progress.json"):
                st = subprocess.run([sys.executable, "-m", "optdesign", "status", str(f.parent)], cwd=tmp_path,
                                    env=env, capture_output=True, text=True)
                assert st.returncode == 0, st.stderr
                seen.add(st.stdout.splitlines()[0].split("(")[1].split(",")[0].rstrip(")"))
            time.sleep(0.2)
        out, err = run.communicate()
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 0, err
    (folder,) = (tmp_path / "runs").iterdir()
    st = subprocess.run([sys.executable, "-m", "optdesign", "status", str(folder)], cwd=tmp_path, env=env,
                        capture_output=True, text=True)
    assert "(complete" in st.stdout
    assert "running" in seen, seen
