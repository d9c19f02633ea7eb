"""optdesign bench: a thin front end over the scripts of benchmarks/ (no timing is checked)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from optdesign.cli import main
from optdesign.commands import bench

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"

#: the tiny sizes of bench_throughput that need no numba compilation
TINY = ["--points", "16", "--designs", "2", "--loop-points", "2", "--fk-poses", "50", "--repeat", "1"]


def test_list_shows_every_benchmark_with_its_docstring(capsys):
    assert main(["bench", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    names = [line.split()[0] for line in lines if line.strip()]
    scripts = sorted(p.stem for p in BENCH.glob("bench_*.py"))
    assert len(scripts) >= 10 and set(scripts) <= set(names)
    assert not any(n.startswith("_") for n in names)        # helpers such as _revision.py are not benchmarks
    row = next(line for line in lines if line.startswith("bench_throughput "))
    assert "Points per second of the local index evaluation" in row


def test_summary_is_the_first_sentence_on_one_line(tmp_path):
    p = tmp_path / "bench_x.py"
    p.write_text('"""What ``eq. 29`` costs over\nthe whole W: a second clause.\n\nMore text."""\n')
    assert bench.summary(p) == "What eq. 29 costs over the whole W"
    p.write_text("x = 1\n")
    assert bench.summary(p) == "(no docstring)"


@pytest.mark.parametrize("name, hint", [("scalingg", "(did you mean 'bench_scaling'?)"), ("zzz", None)])
def test_unknown_name_exits_2_with_one_line(capsys, name, hint):
    assert main(["bench", name]) == 2
    out = capsys.readouterr()
    assert out.out == "" and len(out.err.strip().splitlines()) == 1
    assert out.err.startswith(f"optdesign: error: bench: no benchmark named '{name}'")
    assert (hint in out.err) if hint else "did you mean" not in out.err


def test_no_benchmarks_folder_exits_2_with_one_line(capsys, monkeypatch):
    monkeypatch.setattr(bench, "benchmarks_dir", lambda: None)
    assert main(["bench", "--list"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "no benchmarks/ folder" in err


def test_runs_a_benchmark_and_returns_its_exit_status(capfd):
    """bench_throughput's numpy path on tiny sizes, through the CLI (a subprocess:
    its output reaches the file descriptor, hence capfd)."""
    assert main(["bench", "throughput", "--numpy-only", *TINY, "--json"]) == 0
    out = json.loads(capfd.readouterr().out)
    assert out["local"]["numpy"]["points_per_s"] > 0 and out["fk"]["numpy"]["poses_per_s"] > 0
    assert "fast" not in out["local"] and "reproduce" not in out
    assert main(["bench", "bench_throughput", "--points", "0"]) == 2     # the script's own usage error
    assert "must be positive" in capfd.readouterr().err
    assert main(["bench", "throughput", "--help"]) == 0                  # the options after NAME are the script's
    assert "usage: bench_throughput" in capfd.readouterr().out


@pytest.mark.slow
def test_throughput_compiled_paths_smoke(capfd):
    """bench_throughput end to end with the compiled paths (compiles the kernels on a cold cache)."""
    assert main(["bench", "throughput", "--points", "64", "--designs", "3", "--loop-points", "4", "--fk-poses", "500",
                 "--repeat", "1", "--no-reproduce", "--json"]) == 0
    out = json.loads(capfd.readouterr().out)
    assert out["local"]["fast"]["points_per_s"] > 0 and out["local"]["numpy"]["points_per_s"] > 0
    assert out["fk"]["numpy"]["poses_per_s"] > 0 and "fast" not in out["fk"]     # the 3-P(4S)'s FK: numpy only
