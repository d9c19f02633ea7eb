"""What a designer takes away from a run: generic wording for a config
without `reference:`, units in the CSV headers and printed values, degrees
where the config says deg, the optimum exported in the config's units,
`--json` outputs that parse, tables and progress lines that fit the terminal
(a real pseudo-terminal of fixed width)."""
from __future__ import annotations

import csv
import json
import os
import re
import select
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from cli_helpers import run_cli_in
from conftest import small_data

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data"
#: columns that are counts or flags, not quantities
PLAIN = {"generation", "evaluations", "feasible", "front_size", "reachable"}


def _noref_config(folder: Path) -> Path:
    d = small_data()
    d.pop("reference")
    d["name"] = "noref"
    p = folder / "noref.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


@pytest.fixture(scope="module")
def noref(tmp_path_factory):
    """`optdesign run` of a config without `reference:` (jobs 1): (folder, stdout, stderr)."""
    base = tmp_path_factory.mktemp("noref")
    _noref_config(base)
    rc, out, err = run_cli_in(base, ["run", "noref.yaml", "--out", "runs", "--jobs", "1"])
    assert rc == 0, err
    (folder,) = list((base / "runs").iterdir())
    return folder, out, err


@pytest.mark.slow
def test_no_paper_wording_anywhere(noref):
    from test_report_html import _visible_text

    folder, out, err = noref
    texts = {"results.md": (folder / "results.md").read_text(), "printed output": out + err,
             "report.html": _visible_text((folder / "report.html").read_text()),
             "optimum.yaml": (folder / "optimum.yaml").read_text()}
    for what, text in texts.items():
        low = text.lower()
        assert "paper" not in low, what
        assert "eq." not in low and not re.search(r"\beq\s*\(?\d", low), what
        assert "table 3" not in low, what


def test_csv_headers_carry_units(noref):
    folder, _, _ = noref
    files = [folder / "pareto_nsga2.csv", folder / "population.csv", folder / "history.csv",
             *sorted((folder / "stages").glob("*/*.csv"))]
    for f in files:
        head = next(csv.reader(f.open()))
        bare = [h for h in head if h not in PLAIN and not re.search(r" \[[^\]]+\]$", h)]
        assert not bare, (f.name, bare)
        assert not any(h.startswith("objective_-") or "_-" in h for h in head), (f.name, head)
    head = next(csv.reader((folder / "pareto_nsga2.csv").open()))
    assert "phi [deg]" in head and "stiffness [N/m]" in head and "dynamic [kg]" in head


def test_csv_values_in_the_configs_units_and_own_sense(noref):
    """The front CSV against results.json's front (SI, minimized): phi in degrees, stiffness as itself."""
    folder, _, _ = noref
    res = json.loads((folder / "stages" / "pareto_nsga2" / "result.json").read_text())
    rows = list(csv.DictReader((folder / "pareto_nsga2.csv").open()))
    assert len(rows) == len(res["front"]) > 0
    for r, f in zip(rows, res["front"]):
        assert float(r["phi [deg]"]) == pytest.approx(np.degrees(f["phi"]), rel=1e-12)
        assert float(r["stiffness [N/m]"]) == pytest.approx(-f["objective_-stiffness"], rel=1e-12)
        assert float(r["stiffness [N/m]"]) > 0
    hist = list(csv.DictReader((folder / "stages" / "single_stiffness_max" / "history.csv").open()))
    assert all(float(h["mean_stiffness [N/m]"]) > 0 for h in hist)      # a maximized index as itself


def test_degrees_printed_in_degrees(noref):
    folder, out, _ = noref
    r = json.loads((folder / "results.json").read_text())
    phi = np.degrees(r["optimum"]["phi"])
    assert 25 <= phi <= 35
    m = re.search(r"phi = ([0-9.]+) deg", out)
    assert m and float(m.group(1)) == pytest.approx(phi, rel=1e-5)
    assert f"phi = {r['optimum']['phi']:.6g}" not in out           # never the radians
    md = (folder / "results.md").read_text()
    row = next(line for line in md.splitlines() if line.startswith("| phi "))
    assert "deg" in row and f"{phi:.4f}" in row


def test_optimum_yaml_pastes_into_designs(noref, tmp_path):
    """optimum.yaml under `designs:` of the config gives back the run's optimum (SI) to 12 digits."""
    from optdesign.config import load_config

    folder, _, _ = noref
    r = json.loads((folder / "results.json").read_text())
    exported = yaml.safe_load((folder / "optimum.yaml").read_text())
    d = yaml.safe_load((folder / "config.yaml").read_text())
    d["designs"].update(exported)
    p = tmp_path / "with_optimum.yaml"
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    cfg = load_config(p)
    for k, v in cfg.design("optimum").items():
        assert v == pytest.approx(r["optimum"][k], rel=1e-11), k
    assert 25 <= exported["optimum"]["phi"] <= 35                  # degrees, as the config writes phi


@pytest.mark.slow
def test_run_json(tmp_path):
    _noref_config(tmp_path)
    rc, out, err = run_cli_in(tmp_path, ["run", "noref.yaml", "--out", "runs", "--jobs", "1", "--no-pareto", "--json"])
    assert rc == 0, err
    d = json.loads(out)
    r = json.loads((Path(d["folder"]) / "results.json").read_text())
    assert d["objective"] == r["objective"] and d["seed"] == r["seed"] == 3
    assert d["optimum"]["phi"]["unit"] == "deg"
    assert d["optimum"]["phi"]["value"] == pytest.approx(np.degrees(r["optimum"]["phi"]))
    assert d["optimum"]["phi"]["si"] == r["optimum"]["phi"]
    assert d["global_indices"]["stiffness"] == {"mean": r["global_indices"]["stiffness"], "unit": "N/m", "sense": "max"}
    assert Path(d["files"]["optimum.yaml"]).is_file()


@pytest.mark.slow
def test_batch_and_summarize_json(tmp_path):
    _noref_config(tmp_path)
    rc, out, err = run_cli_in(tmp_path, ["batch", "noref.yaml", "--seeds", "2", "--out", "b", "--jobs", "1", "--json"])
    assert rc == 0, err
    d = json.loads(out)
    assert d["runs"] == d["complete"] == 2 and len(d["rows"]) == 2
    assert {r["seed"] for r in d["rows"]} == {3, 4}
    for row in d["rows"]:
        res = json.loads((Path(row["folder"]) / "results.json").read_text())
        assert row["objective"] == res["objective"] and row["opt_phi"] == res["optimum"]["phi"]
    rc, out2, err = run_cli_in(tmp_path, ["summarize", "b", "--json", "--no-plot"])
    assert rc == 0, err
    s = json.loads(out2)
    assert s["runs"] == 2 and s["groups"][0]["stats"]["objective"]["mean"] == pytest.approx(
        np.mean([r["objective"] for r in d["rows"]]))
    assert s["summary"]["plot"] is None


# --------------------------------------------------------------------------- tables and terminals
def test_fold_table_fits_and_keeps_every_cell():
    from optdesign.tables import fit_text, fold_table, table

    headers = ["index"] + [f"column {i} long header" for i in range(9)]
    rows = [["stiffness"] + [f"{i * 1.2345:.4f}" for i in range(9)], ["dynamic"] + [str(i) for i in range(9)]]
    parts = fold_table(headers, rows, 60)
    assert len(parts) > 1
    text = "\n".join(parts)
    assert max(len(line) for line in text.splitlines()) <= 60
    for h in headers:
        assert h in text
    assert all(p.splitlines()[2].startswith("| stiffness") for p in parts)   # the first column repeated
    assert fold_table(headers, rows, None) == [table(headers, rows)]
    md = "# title\n\n" + table(headers, rows) + "\n\nend"
    folded = fit_text(md, 50)
    assert folded.startswith("# title") and folded.endswith("end")
    assert max(len(line) for line in folded.splitlines()) <= 50


def _pty_run(argv: list[str], cwd: Path, columns: int, stdout_too: bool = False, timeout: float = 240):
    """Run ``python -m optdesign.cli *argv`` with stderr (and stdin; with
    ``stdout_too`` stdout as well) on a pseudo-terminal of ``columns`` columns,
    else stdout to a file: (exit status, what the terminal showed, stdout)."""
    import fcntl
    import pty
    import struct
    import termios
    import time

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, columns, 0, 0))
    env = {**os.environ, "COLUMNS": str(columns), "LINES": "40", "TERM": "xterm",
           "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out_path = cwd / "stdout.txt"
    with open(out_path, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", "optdesign.cli", *argv], cwd=cwd, stdin=slave,
                                stdout=slave if stdout_too else out,
                                stderr=slave, env=env, close_fds=True)
        os.close(slave)
        buf, t0 = b"", time.monotonic()
        while time.monotonic() - t0 < timeout:
            r, _, _ = select.select([master], [], [], 0.5)
            if r:
                try:
                    chunk = os.read(master, 65536)
                except OSError:
                    break
                if not chunk:
                    break
                buf += chunk
            elif proc.poll() is not None:
                break
        rc = proc.wait(timeout=30)
    os.close(master)
    return rc, buf.decode("utf-8", "replace"), out_path.read_text()


def _screen_lines(raw: str) -> list[str]:
    """Every line segment the terminal drew (escape sequences removed, split at CR and LF)."""
    plain = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]|\x1b\][^\x07]*\x07|\x1b[()][A-Z0-9]", "", raw)
    return [s for s in re.split(r"[\r\n]", plain) if s.strip()]


@pytest.mark.slow
def test_progress_never_wider_than_the_terminal(tmp_path):
    """A run with a worker process on a 60-column terminal: every line the
    progress draws fits, the run's line counts stages, every stage gets its
    line when done, a maximized index is shown as itself."""
    (tmp_path / "small.yaml").write_text((DATA / "p4s_small.yaml").read_text())
    rc, screen, out = _pty_run(["run", "small.yaml", "--out", "runs", "--jobs", "2"], tmp_path, 60)
    assert rc == 0, screen[-2000:]
    lines = _screen_lines(screen)
    assert lines, "no progress on a terminal"
    too_wide = [s for s in lines if len(s) > 60]
    assert not too_wide, too_wide[:3]
    from optdesign.config import load_config
    from optdesign.optimize.pipeline import stage_plan

    cfg = load_config(tmp_path / "small.yaml")
    n = len(stage_plan(cfg.optimizer, {k: s.sense for k, s in cfg.indices.items()}))   # pre-scan, 6 single, 2 weighted, 2 Pareto
    assert n >= 10
    assert any("stages done" in s and f"/{n} " in s for s in lines)
    done = {re.match(rf"done \[(\d+)/{n}\]", s).group(1) for s in lines if re.match(rf"done \[\d+/{n}\]", s)}
    assert done == {str(i) for i in range(1, n + 1)}
    assert not any(re.search(r"stiffness = -", s) for s in lines)
    assert "complete" in out and "phi = " in out           # the result itself goes to stdout


@pytest.mark.slow
def test_no_progress_when_not_a_terminal(tmp_path):
    (tmp_path / "small.yaml").write_text((DATA / "p4s_tiny.yaml").read_text())     # what is printed, not the run
    p = subprocess.run([sys.executable, "-m", "optdesign.cli", "run", "small.yaml", "--out", "runs", "--jobs", "1",
                        "--no-pareto"], cwd=tmp_path, capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=240)
    assert p.returncode == 0 and p.stderr == "", p.stderr
    lines = p.stdout.strip().splitlines()     # the summary line, then the paths of report.html and results.md
    assert len(lines) == 3 and lines[1].startswith("report: ") and lines[2].startswith("results: ")


@pytest.mark.slow
def test_tables_fit_the_terminal(tmp_path):
    """evaluate's table on a 60-column terminal is folded; into a file it keeps its width."""
    rc, screen, out = _pty_run(["evaluate", str(ROOT / "configs" / "p4s_paper.yaml")], tmp_path, 60)
    assert rc == 0
    wide = max(len(line) for line in out.splitlines() if line.startswith("|"))
    assert wide > 60   # stdout is a file here: the full width
    # the same command with stdout on the terminal
    rc, screen, _ = _pty_run(["evaluate", str(ROOT / "configs" / "p4s_paper.yaml")], tmp_path, 60, stdout_too=True)
    assert rc == 0
    rows = [s for s in _screen_lines(screen) if s.startswith("|")]
    assert rows and max(len(s) for s in rows) <= 60
    assert sum("stiffness [N/m]" in s for s in rows) >= 4       # every row kept (both designs, in each part)


def test_compile_notice_before_a_cold_kernel_module(monkeypatch):
    """The notice is given once, when the kernels of the first module without a
    cache run (compile), not for one whose cache is there; what it returns is
    called with the seconds the compile took."""
    import optdesign.fast as fast

    said, ended = [], []

    def notice(name):
        said.append(name)
        return ended.append

    old = fast.set_compile_notice(notice)
    try:
        monkeypatch.setattr(fast, "kernel_cache_present", lambda name: name != "colorsys")
        warm = fast.KernelModule("json")
        assert warm.get() is not None
        with warm.compiling():
            pass
        assert said == []
        cold = fast.KernelModule("colorsys")
        assert cold.get() is not None and said == []          # importing compiles nothing
        with cold.compiling():
            pass
        assert said == ["colorsys"] and len(ended) == 1 and ended[0] >= 0.0
        with cold.compiling():
            pass
        again = fast.KernelModule("colorsys")
        again.get()
        with again.compiling():
            pass
        assert said == ["colorsys"]           # once
    finally:
        fast.set_compile_notice(old)
        fast.KernelModule.instances[:] = [k for k in fast.KernelModule.instances if k.name not in ("json", "colorsys")]


def test_terminal_notice_counts_seconds_only_on_a_terminal():
    import io

    import optdesign.fast as fast

    class Tty(io.StringIO):
        def isatty(self):
            return True

    assert fast.terminal_notice(io.StringIO())("x") is None          # not a terminal: nothing
    out = Tty()
    end = fast.terminal_notice(out)("x")
    end(21.4)
    text = out.getvalue()
    assert text.startswith("optdesign: compiling the engine's kernels") and text.endswith("done in 21 s\n")


def test_cache_detection_sees_an_empty_cache(tmp_path):
    code = ("import optdesign.fast as f; "
            "print(f.kernel_cache_present('optdesign.engine.kernels'))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path)})
    assert p.stdout.strip() == "False", p.stderr
