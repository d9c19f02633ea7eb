"""Issue 20, "Output a user reads": what the commands print and write for a
user (init, ik/fk, evaluate, run's last lines, progress lines, plots)."""
from __future__ import annotations

from pathlib import Path

import pytest

from cli_helpers import run_cli_in

ROOT = Path(__file__).resolve().parents[1]
DESCRIBED = ["delta", "gough_stewart", "p4s_legs", "sps_s_legs"]


# ---------------------------------------------------------------- init
def test_init_list_names_every_shipped_mechanism(tmp_path):
    rc, out, err = run_cli_in(tmp_path, ["init", "--list"])
    assert rc == 0, err
    names = [line.split()[0] for line in out.splitlines() if line.strip()]
    for n in ["p4s", "ups_upr_s", "cpr_rrr", "sps_s", *DESCRIBED]:
        assert n in names
    assert all(len(line.split(None, 1)) == 2 for line in out.splitlines())   # a name and its description


@pytest.mark.parametrize("mech", DESCRIBED)
def test_init_writes_described_mechanisms_that_validate(tmp_path, mech):
    rc, out, err = run_cli_in(tmp_path, ["init", mech, "c.yaml", "--name", "mine"])
    assert rc == 0, err
    text = (tmp_path / "c.yaml").read_text()
    assert "\nname: mine\n" in text and f"name: {mech}\n" in text       # the mechanism keeps its name
    rc, out, err = run_cli_in(tmp_path, ["validate-config", "c.yaml"])
    assert rc == 0 and "ok" in out, err


@pytest.mark.parametrize("mech", DESCRIBED)
def test_init_templates_are_the_shipped_configs(mech):
    shipped = (ROOT / "configs" / f"{mech}.yaml").read_text()
    packaged = (ROOT / "optdesign" / "data" / "templates" / f"{mech}.yaml").read_text()
    assert packaged == shipped


def test_init_empty_file_name_is_one_line_error(tmp_path):
    rc, out, err = run_cli_in(tmp_path, ["init", "p4s", ""])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_init_dash_means_standard_output(tmp_path):
    rc, out, err = run_cli_in(tmp_path, ["init", "p4s", "-"])
    assert rc == 0, err
    assert out.startswith("# A starting config") and "mechanism: p4s" in out
    assert list(tmp_path.iterdir()) == []          # no file named '-'


def test_init_refuses_a_name_validate_config_would_refuse(tmp_path):
    rc, out, err = run_cli_in(tmp_path, ["init", "p4s", "c.yaml", "--name", "<script>x</script>"])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "--name" in err
    assert not (tmp_path / "c.yaml").exists()
    rc, out, err = run_cli_in(tmp_path, ["init", "p4s", "c.yaml", "--name", "ok_name-1.2"])
    assert rc == 0, err
    rc, out, err = run_cli_in(tmp_path, ["validate-config", "c.yaml"])
    assert rc == 0, err


# ---------------------------------------------------------------- ik / fk / evaluate
def test_ik_names_a_crank_angle_in_rad(tmp_path):
    rc, out, err = run_cli_in(tmp_path, ["ik", str(ROOT / "configs" / "delta.yaml"), "0", "0", "-0.55"])
    assert rc == 0, err
    parts = out.strip().split("  ")
    assert [p.split(" = ")[0] for p in parts] == ["theta1", "theta2", "theta3"]
    assert all(p.endswith(" rad") for p in parts), out
    # the angle closes the leg: fk of it gives the pose back
    angles = [p.split(" = ")[1].split()[0] for p in parts]
    rc, out, err = run_cli_in(tmp_path, ["fk", str(ROOT / "configs" / "delta.yaml"), *angles])
    assert rc == 0, err
    z = float(out.split("z = ")[1].split()[0])
    assert abs(z + 0.55) < 1e-9 and out.strip().endswith(" m")


@pytest.mark.parametrize("value", ["-1e-3", "-1E-3", "-.001", "-0.001", "-1.0e-03"])
def test_ik_takes_negative_numbers_with_exponents(tmp_path, value):
    cfg = str(ROOT / "configs" / "p4s_paper.yaml")
    rc, out, err = run_cli_in(tmp_path, ["ik", cfg, "--design", "after", value, "0", "0.592"])
    assert rc == 0, err
    rc2, ref, err = run_cli_in(tmp_path, ["ik", cfg, "--design", "after", "--", "-0.001", "0", "0.592"])
    assert rc2 == 0 and out == ref
    rc, out, err = run_cli_in(tmp_path, ["fk", cfg, "--design", "after", "0.42", "0.42", "0.42", "--json"])
    assert rc == 0


@pytest.mark.parametrize("garbage", ["abc", "-x", "1e", "--", "-1e-3e"])
def test_ik_garbage_is_one_line(tmp_path, garbage):
    cfg = str(ROOT / "configs" / "p4s_paper.yaml")
    rc, out, err = run_cli_in(tmp_path, ["ik", cfg, "0", garbage, "0.592"])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_evaluate_shows_the_workspace_in_the_configs_units(tmp_path):
    rc, out, err = run_cli_in(tmp_path, ["evaluate", str(ROOT / "configs" / "sps_s.yaml"), "--design", "initial"])
    assert rc == 0, err
    first = out.splitlines()[0]
    assert "psi in [-10 deg, 10 deg]" in first and "grid step 1 deg" in first, first
    assert "0.1745" not in first
    rc, out, err = run_cli_in(tmp_path, ["evaluate", str(ROOT / "configs" / "p4s_paper.yaml"), "--design", "before"])
    assert "x in [-0.05 m, 0.05 m]" in out.splitlines()[0]


# ---------------------------------------------------------------- progress lines
def _tokens_kept_whole(line: str, full: str) -> bool:
    """Every field of ``line`` is a field of ``full``; one cut with … ends at a word boundary."""
    import re

    src = full.split()
    for tok in line.split():
        if tok in src or re.fullmatch(r"\[[#.]+\]", tok):   # a field, or the bar (its width follows the line's)
            continue
        if not tok.endswith("…"):
            return False
        head = tok[:-1]
        if head and not any(s == head or s.startswith(head + "_") for s in src):
            return False
        if any(c.isdigit() for c in head) and head not in src:
            return False
    return True


@pytest.mark.parametrize("width", range(20, 101, 4))
def test_stage_and_run_lines_never_cut_inside_a_number(width):
    from optdesign.optimize.progress import fit_line, stage_line

    label = "[3/10] single_stiffness_max (worker)"
    best = "stiffness = 0.0005307 N/m"
    line = stage_line(label, 13, 40, best, 75.0, width)
    assert len(line) <= width
    full = stage_line(label, 13, 40, best, 75.0, 400)
    assert _tokens_kept_whole(line, full), (width, line)
    assert ("0.0005307" in line) == ("stiffness" in line)   # the value goes with its name
    if "0.0005307" in line:
        assert "0.0005307 N/m" in line
    run = fit_line(["run: 5/10 stages done", "63%", "1:02 elapsed", "ETA 0:41"], width, shrink=None, drop=[2, 1])
    assert len(run) <= width and _tokens_kept_whole(run, "run: 5/10 stages done 63% 1:02 elapsed ETA 0:41")
    if width >= 32:
        assert "ETA 0:41" in run and "5/10" in run


def _progress(monkeypatch, width):
    import io

    from optdesign.optimize.progress import Progress

    monkeypatch.setenv("COLUMNS", str(width))
    buf = io.StringIO()
    p = Progress(True, stream=buf)
    return p, buf


def test_compile_notice_is_folded_at_words(monkeypatch):
    import re

    from optdesign.optimize.progress import COMPILE_NOTICE

    p, buf = _progress(monkeypatch, 60)
    try:
        p.compiling()
    finally:
        p.close()
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", buf.getvalue())
    lines = [ln.strip() for ln in text.replace("\r", "\n").split("\n") if ln.strip()]
    assert all(len(ln) <= 60 for ln in lines)
    words = " ".join(lines).split()
    assert words == COMPILE_NOTICE.split(), lines        # every word whole, none left out


def test_run_line_counts_resumed_stages_and_has_an_eta_from_the_prescan(monkeypatch):
    p, _ = _progress(monkeypatch, 100)
    try:
        plan = [("prescan", 1, 1000)] + [(f"s{i}", 10, 100) for i in range(9)]
        p.plan(plan, done=["prescan", "s0", "s1", "s2", "s3"])
        line = p._run_line(100)
        assert "5/10 stages done" in line
        assert int(line.split("%")[0].split()[-1]) == round(100 * (1000 + 4 * 1000) / 10000)   # 50 %
        # a fresh run: the pre-scan's first batch gives an ETA
        p.plan(plan)
        p._t0 -= 10.0
        assert "ETA …" in p._run_line(100)
        p.start("prescan", 1000)
        p.update(250)
        line = p._run_line(100)
        assert "ETA …" not in line and "ETA " in line, line
        eta = line.split("ETA ")[1].split(":")
        assert 60 * int(eta[0]) + int(eta[1]) == pytest.approx(10.0 * (10000 - 250) / 250, abs=3)
        p.finish()
        p.phase("writing report: results.md and its plots ...", "writing report …")
        line = p._run_line(100)
        assert "writing report …" in line and "ETA" not in line
    finally:
        p.close()


# ---------------------------------------------------------------- the end of a run
SMALL = ROOT / "tests" / "data" / "p4s_small.yaml"


def _small(tmp_path, algorithms=None):
    text = SMALL.read_text()
    if algorithms:
        text = text.replace("pareto: {population: 20, generations: 6}",
                            f"pareto: {{algorithms: [{', '.join(algorithms)}], population: 20, generations: 6}}")
        assert "nsga3" in text
    (tmp_path / "small.yaml").write_text(text)


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """One small run with NSGA-III, its JSON (--json) and the browser it asked for (--open)."""
    import json
    import time
    import webbrowser

    tmp = tmp_path_factory.mktemp("run")
    _small(tmp, ["nsga2", "nsga3"])
    opened = []
    old = webbrowser.open
    webbrowser.open = lambda url, *a, **k: opened.append(url) or True
    try:
        t0 = time.perf_counter()
        rc, out, err = run_cli_in(tmp, ["run", "small.yaml", "--out", "runs", "--jobs", "1", "--json", "--open"])
        elapsed = time.perf_counter() - t0
    finally:
        webbrowser.open = old
    assert rc == 0, err
    return json.loads(out), err, opened, elapsed


@pytest.mark.slow
def test_run_json_names_the_report_and_the_whole_wall_time(small_run):
    res, err, opened, elapsed = small_run
    folder = Path(res["folder"])
    assert res["files"]["report.html"] == str(folder / "report.html")
    assert res["files"]["results.md"] == str(folder / "results.md")
    # the whole run: the stages, the final results and the report's writing
    assert res["wall_time_s"] <= res["wall_time_total_s"] <= elapsed


@pytest.mark.slow
def test_run_open_opens_report_html(small_run):
    res, err, opened, _ = small_run
    assert opened == [(Path(res["folder"]) / "report.html").resolve().as_uri()]
    assert "opened" in err and "report.html" in err     # with --json the line goes to stderr


@pytest.mark.slow
def test_nsga3_count_during_the_run_is_the_reported_front(small_run):
    import csv

    res, *_ = small_run
    folder = Path(res["folder"])
    for alg in ("pareto_nsga2", "pareto_nsga3"):
        rows = list(csv.DictReader((folder / "stages" / alg / "history.csv").open()))
        assert int(rows[-1]["front_size"]) == res["pareto"][alg]["front_size"], alg


@pytest.mark.slow
def test_run_prints_the_report_paths_and_open_without_a_browser(tmp_path, monkeypatch):
    import webbrowser

    _small(tmp_path)
    monkeypatch.setattr(webbrowser, "open", lambda *a, **k: False)
    rc, out, err = run_cli_in(tmp_path, ["run", "small.yaml", "--out", "runs", "--jobs", "1", "--no-pareto", "--open"])
    assert rc == 0, err
    lines = out.strip().splitlines()
    folder = Path(lines[0].split(": complete")[0])
    assert lines[1] == f"report: {folder / 'report.html'}" and (tmp_path / folder / "report.html").exists()
    assert lines[2] == f"results: {folder / 'results.md'}"
    assert "no web browser available" in lines[3] and "report.html" in lines[3]


def test_resumed_run_percent_counts_the_stages_done_before(tmp_path):
    """A run stopped after some stages and resumed: the progress's percentage
    includes the finished stages' work."""
    from optdesign.config import load_config
    from optdesign.optimize.pipeline import stage_plan, stage_work
    from optdesign.optimize.progress import Progress

    _small(tmp_path)
    cfg = load_config(tmp_path / "small.yaml")
    plan = [(st.name, *stage_work(cfg.optimizer, st))
            for st in stage_plan(cfg.optimizer, {k: s.sense for k, s in cfg.indices.items()})]
    p = Progress(False)
    p.plan(plan, done=[n for n, *_ in plan[:5]])
    line = p._run_line(200)
    work = [g * n for _, g, n in plan]
    assert f"5/{len(plan)} stages done" in line
    assert f"{100 * sum(work[:5]) / sum(work):.0f}%" in line
