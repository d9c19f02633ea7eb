"""Interrupted and concurrent runs, with real processes and real signals.

* A run is killed with SIGINT, SIGTERM or SIGKILL at a randomly chosen
  generation (seeded), its folder is checked file by file (every file under
  its real name is whole: JSON parses, checkpoints load as data, CSV rows are
  complete), and it is resumed (killed again once, then finished): the
  results equal those of an uninterrupted run with the same seed.
* Eight processes that create a run folder of the same name in the same
  second get eight folders.
* Corrupted or foreign run folders make ``optdesign run --resume`` end with
  status 2 and one line, not a traceback.
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from optdesign.config import load_config
from optdesign.runner import resume_run, start_run
from optdesign.runs import RunFolder

TINY = """\
mechanism: p4s
name: tiny
design_variables:
  r_a: {value: 0.25, bounds: [0.21, 0.29]}
  r_b: {value: 0.67, bounds: [0.63, 0.71]}
  L: 0.38
  d: 0.12
  phi: {value: 30, bounds: [25, 35], unit: deg}
workspace: {type: box, axes: {x: [-0.05, 0.05], y: [-0.05, 0.05], z: 0.57}, sampling: grid, step: 0.05}
indices: {dynamic: {}, stiffness: {}}
optimizer: {worst_case: false, polish: 1, extremes: {starts: 1, scan: 256}, population: 8, generations: 4, elites: 2, seed: 3,
            checkpoint_interval: 0, pareto: {population: 8, generations: 3}}
"""
# (kept cheap: what is tested is the signals; one polish start per stage; tests/test_polish.py and
# tests/test_worstcase.py check the polish and the continuous search)
SEED = 11
#: generations in the whole run: 4 single-index stages and 2 weighted sums of 4, 2 Pareto runs of 3
TOTAL_GENERATIONS = 6 * 4 + 2 * 3
RNG = np.random.default_rng(20261122)
CLI = [sys.executable, "-c", "import sys; from optdesign.cli import main; sys.exit(main())"]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    d = tmp_path_factory.mktemp("tiny")
    path = d / "tiny.yaml"
    path.write_text(TINY)
    return path


#: the same mechanism with the smallest budget (one generation per stage, no polish, so no multi-start
#: of the extremes): the tests of a signal after the run completed look at its last moments only
SMALLEST = TINY.replace("polish: 1, extremes: {starts: 1, scan: 256}, population: 8, generations: 4",
                        "polish: 0, population: 8, generations: 1").replace("generations: 3}", "generations: 1}")
assert SMALLEST.count("generations: 1") == 2 and "polish: 0" in SMALLEST


@pytest.fixture(scope="module")
def smallest(tmp_path_factory):
    path = tmp_path_factory.mktemp("smallest") / "smallest.yaml"
    path.write_text(SMALLEST)
    return path


@pytest.fixture(scope="module")
def reference(tiny, tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    res = start_run(load_config(tiny), seed=SEED, out=out)
    return _comparable(res.results)


def _comparable(results: dict) -> dict:
    r = json.loads(json.dumps(results))
    r.pop("wall_time_s", None)
    return r


def check_folder(folder: Path, config_text: str, allow_tmp: bool) -> int:
    """Every file under its real name is whole; returns the number of
    generations saved in the checkpoints."""
    tmp = [p for p in folder.rglob("*") if p.name.endswith(".tmp")]
    assert allow_tmp or not tmp, tmp
    assert (folder / "config.yaml").read_text() == config_text
    rf = RunFolder(folder)
    m = rf.read_manifest()
    assert m["seed"] == SEED
    gens = 0
    for p in folder.rglob("*"):
        if not p.is_file() or p.name.endswith(".tmp"):
            continue
        assert p.stat().st_size > 0, p
        if p.suffix == ".json":
            json.loads(p.read_text())
        elif p.suffix == ".csv":
            text = p.read_text()
            assert text.endswith("\n"), p
            rows = [r.split(",") for r in text.splitlines()]
            assert len({len(r) for r in rows}) == 1, p
        elif p.suffix == ".png":
            assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", p
        elif p.name == "checkpoint.npz":
            gens += rf.load_checkpoint(p.parent.name)[0]["history"]["rows"]
    return gens


def _checkpoint_writes(out: Path, seen: dict) -> int:
    """Count checkpoint replacements seen so far (each generation writes one)."""
    for p in out.rglob("checkpoint.npz"):
        try:
            ino = p.stat().st_ino
        except FileNotFoundError:
            continue
        seen.setdefault(str(p), set()).add(ino)
    return sum(len(v) for v in seen.values())


def _start(tiny: Path, out: Path, *extra: str) -> subprocess.Popen:
    # --jobs 2: the stages run in this process and a worker process, so every
    # kill also hits a run whose worker must stop (or notice it is orphaned)
    return subprocess.Popen(CLI + ["run", str(tiny), "--seed", str(SEED), "--out", str(out), "--quiet", "--jobs", "2", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _kill_at_generation(proc: subprocess.Popen, out: Path, generation: int, sig: int) -> tuple[int, str, int]:
    seen: dict = {}
    base = _checkpoint_writes(out, seen)          # checkpoints already there (a resumed run)
    deadline = time.time() + 300
    while proc.poll() is None and time.time() < deadline:
        if _checkpoint_writes(out, seen) - base >= generation:
            break
        time.sleep(0.005)
    observed = _checkpoint_writes(out, seen) - base
    if proc.poll() is None:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=300)
    return proc.returncode, err, observed


EXPECTED_STATUS = {signal.SIGINT: (130, "interrupted"), signal.SIGTERM: (143, "interrupted"),
                   signal.SIGKILL: (-9, "running")}


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL], ids=lambda s: s.name)
def test_kill_at_a_random_generation_then_resume(tiny, reference, tmp_path, sig):
    first = int(RNG.integers(1, TOTAL_GENERATIONS - 2))
    for attempt in range(4):
        # a generation takes milliseconds: on a fast machine the run can finish
        # before the signal lands; then try again, aiming earlier
        out = tmp_path / f"runs{attempt}"
        proc = _start(tiny, out)
        rc, err, observed = _kill_at_generation(proc, out, first, sig)
        if rc != 0:
            break
        first = max(1, first // 2)
    else:
        pytest.fail(f"the run finished before the signal in 4 attempts (last target generation {first})")
    (folder,) = list(out.iterdir())
    code, status = EXPECTED_STATUS[sig]
    assert rc == code, err
    assert "Traceback" not in err
    if sig != signal.SIGKILL:
        assert err.count("\n") == 1 and "interrupted" in err
    assert RunFolder(folder).read_manifest()["status"] == status
    assert not (folder / "results.json").exists()
    gens = check_folder(folder, TINY, allow_tmp=sig == signal.SIGKILL)
    print(f"{sig.name}: {gens} generations saved; killed after {observed} checkpoint writes (target {first})")

    if sig == signal.SIGKILL and gens < TOTAL_GENERATIONS - 1:
        # kill the resuming process too, at a random one of the generations left
        _kill_resumed_run_again(folder, out, int(RNG.integers(1, TOTAL_GENERATIONS - gens)))
    res = resume_run(folder)
    assert _comparable(res.results) == reference
    check_folder(folder, TINY, allow_tmp=sig == signal.SIGKILL)
    assert RunFolder(folder).read_manifest()["status"] == "complete"


def _kill_resumed_run_again(folder: Path, out: Path, second: int) -> None:
    """SIGKILL the process that resumes the run, once more."""
    sig, code = signal.SIGKILL, -9
    proc = subprocess.Popen(CLI + ["run", "--resume", str(folder), "--quiet"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    rc2, err2, observed2 = _kill_at_generation(proc, out, int(second), sig)
    assert rc2 in (0, code), err2
    assert "Traceback" not in err2
    check_folder(folder, TINY, allow_tmp=True)
    print(f"{sig.name}: resumed run killed after {observed2} checkpoint writes (target {second}), status {rc2}")


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except (FileNotFoundError, ProcessLookupError):
        return []


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except (FileNotFoundError, ProcessLookupError):
        return ""


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("delay", [0.0, 0.15, 0.3])
def test_sigkill_while_the_stage_worker_starts_leaves_no_process(tiny, tmp_path, delay):
    """The main process SIGKILLed while its stage worker is still starting up
    (``delay`` s after the worker process appears): the worker must not
    outlive it (it would hold the run folder and the caller's pipes)."""
    out = tmp_path / "runs"
    proc = _start(tiny, out)
    worker = None
    deadline = time.time() + 120
    while proc.poll() is None and time.time() < deadline and worker is None:
        worker = next((c for c in _children(proc.pid) if "spawn_main" in _cmdline(c)), None)
        time.sleep(0.001)
    assert worker is not None, "no stage worker seen"
    time.sleep(delay)
    proc.kill()
    proc.communicate(timeout=600)       # returns once no process holds the pipes
    t0 = time.time()
    while _cmdline(worker) and time.time() - t0 < 300:
        time.sleep(0.05)
    assert not _cmdline(worker), "the stage worker outlived its SIGKILLed parent"


def _group(pgid: int) -> list[int]:
    """The processes of a process group (from /proc)."""
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except (FileNotFoundError, ProcessLookupError, PermissionError):
                continue
            if int(stat.rsplit(")", 1)[1].split()[2]) == pgid:
                out.append(int(d.name))
    return out


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=lambda s: s.name)
def test_a_signal_during_the_run_leaves_no_process_of_its_group(tiny, reference, tmp_path, sig):
    """The run in its own process group; the signal to the main process
    (SIGTERM) or to the whole group (SIGINT, as Ctrl-C on a terminal): exit
    143/130, no process of the group left (stage worker, resource tracker),
    and the folder resumes to the uninterrupted result."""
    out = tmp_path / "runs"
    proc = subprocess.Popen(CLI + ["run", str(tiny), "--seed", str(SEED), "--out", str(out), "--quiet", "--jobs", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        if any("spawn_main" in _cmdline(c) for c in _children(proc.pid)) and list(out.rglob("checkpoint.npz")):
            break
        time.sleep(0.002)
    if sig == signal.SIGINT:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    t0 = time.time()
    while _group(proc.pid) and time.time() - t0 < 300:
        time.sleep(0.05)
    assert not _group(proc.pid), [_cmdline(p) for p in _group(proc.pid)]
    (folder,) = list(out.iterdir())
    status = RunFolder(folder).read_manifest()["status"]
    if proc.returncode == 0:   # finished before the signal landed
        assert status == "complete"
    else:
        assert proc.returncode == EXPECTED_STATUS[sig][0] and status == "interrupted", err
        assert "Traceback" not in err and err.count("\n") == 1
    assert _comparable(resume_run(folder).results) == reference


@pytest.mark.slow
@pytest.mark.parametrize("command", ["run", "reproduce"])
def test_a_signal_after_the_run_completed_gives_its_status(smallest, tmp_path, command):
    """SIGTERM or SIGINT as soon as the manifest says complete (and a few ms
    later): exit 0, as the manifest says, and nothing but the summary printed."""
    alive = 0
    for trial in range(2):
        out = tmp_path / f"runs{trial}"
        sig = (signal.SIGTERM, signal.SIGINT)[trial % 2]
        proc = subprocess.Popen(CLI + [command, str(smallest), "--seed", str(SEED), "--out", str(out), "--quiet",
                                       "--jobs", "1"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        deadline = time.time() + 120
        while proc.poll() is None and time.time() < deadline:
            try:
                (folder,) = list(out.iterdir())
                if json.loads((folder / "manifest.json").read_text())["status"] == "complete":
                    break
            except (ValueError, OSError):
                pass
            time.sleep(0.001)
        time.sleep(float(RNG.uniform(0, 0.02)))
        alive += proc.poll() is None
        if proc.poll() is None:
            proc.send_signal(sig)
        o, err = proc.communicate(timeout=120)
        assert proc.returncode == 0, (sig, proc.returncode, err)
        assert err == "" and "complete" in o
    assert alive >= 1, "every run had exited before its signal: nothing was tested"


@pytest.mark.slow
def test_many_folders_created_at_once(tmp_path):
    """Eight processes create a folder with the same name in the same second."""
    code = ("import sys, time; from optdesign.runs import RunFolder\n"
            "t = float(sys.argv[1])\n"
            "time.sleep(max(0.0, t - time.time()))\n"
            "print(RunFolder.create(sys.argv[2], 'same', 'x: 1\\n', 1, 'k').path)\n")
    start = time.time() + 3.0
    procs = [subprocess.Popen([sys.executable, "-c", code, repr(start), str(tmp_path)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(8)]
    paths = []
    for p in procs:
        o, e = p.communicate(timeout=120)
        assert p.returncode == 0, e
        paths.append(o.strip())
    assert len(set(paths)) == 8
    assert len(list(tmp_path.iterdir())) == 8


def _main(cwd: Path, argv) -> tuple[int, str]:
    from optdesign.cli import main

    err = io.StringIO()
    old = os.getcwd()
    os.chdir(cwd)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            rc = main(argv)
    finally:
        os.chdir(old)
    return rc, err.getvalue()


def _interrupted_folder(tiny: Path, out: Path) -> Path:
    from optdesign.optimize.pipeline import Interrupted

    with pytest.raises(Interrupted):
        start_run(load_config(tiny), seed=SEED, out=out, stop_after=5)
    (folder,) = list(out.iterdir())
    return folder


def _open_checkpoint(f: Path) -> Path:
    """The checkpoint of the stage the interruption cut short (the one resume reads)."""
    (p,) = [p for p in f.rglob("checkpoint.npz") if not (p.parent / "result.json").exists()]
    return p


CORRUPTIONS = {
    "truncated checkpoint": lambda f: _truncate(_open_checkpoint(f)),
    "empty checkpoint": lambda f: _open_checkpoint(f).write_bytes(b""),
    "checkpoint of another format": lambda f: _open_checkpoint(f).write_bytes(
        __import__("pickle").dumps({"format_version": 0, "state": None})),
    "truncated manifest": lambda f: _truncate(f / "manifest.json"),
    "manifest not an object": lambda f: (f / "manifest.json").write_text("[1, 2]"),
    "manifest of an older version": lambda f: (f / "manifest.json").write_text(
        json.dumps({**json.loads((f / "manifest.json").read_text()), "format_version": 0})),
    "manifest without a seed": lambda f: (f / "manifest.json").write_text(
        json.dumps({k: v for k, v in json.loads((f / "manifest.json").read_text()).items() if k != "seed"})),
    "no config": lambda f: (f / "config.yaml").unlink(),
    "broken config": lambda f: (f / "config.yaml").write_text("mechanism: [\n"),
    "truncated stage result": lambda f: _truncate(next(f.rglob("result.json"))),
    "not a run folder": lambda f: (f / "manifest.json").unlink(),
}


def _truncate(p: Path) -> None:
    b = p.read_bytes()
    p.write_bytes(b[: len(b) // 2])


@pytest.mark.parametrize("label", list(CORRUPTIONS))
def test_corrupted_folder_gives_one_line(tiny, tmp_path, label):
    folder = _interrupted_folder(tiny, tmp_path / "runs")
    CORRUPTIONS[label](folder)
    rc, err = _main(tmp_path, ["run", "--resume", str(folder), "--quiet"])
    assert rc == 2, (label, rc, err)
    assert err.count("\n") == 1 and err.startswith("optdesign: error: ") and "Traceback" not in err, err


def test_written_files_have_the_usual_permissions(tmp_path):
    """Atomic writes give a file the mode a plain open() would (0o666 less the
    umask), not the 0o600 of a temporary file."""
    from optdesign.io import atomic_write_text

    mask = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "a.txt", "x")
        assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(mask)
