"""The basic commands: ik, fk, evaluate (table), atlas, validate-config, usage errors."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from optdesign.cli import build_parser
from optdesign.mechanisms import get

from cli_helpers import run_main
from conftest import PAPER as PAPER_YAML

PAPER = str(PAPER_YAML)
ROOT = PAPER_YAML.parents[1]
SMALL_YAML = ROOT / "tests" / "data" / "p4s_small.yaml"
P4S = get("p4s")
BEFORE = dict(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=np.radians(30.0))


def test_help_lists_the_basic_commands():
    text = build_parser().format_help()
    for cmd in ("evaluate", "atlas", "ik", "fk", "validate-config"):
        assert cmd in text


def test_ik_and_fk_round_trip(capsys):
    rc, out, err = run_main(capsys, ["ik", PAPER, "--design", "before", "0.02", "0.01", "0.576", "--json"])
    assert rc == 0 and err == ""
    rec = json.loads(out)
    assert rec["reachable"] is True and rec["design"] == "before"
    q = [rec["output"][k] for k in ("l1", "l2", "l3")]
    np.testing.assert_allclose(q, P4S(**BEFORE).inverse(np.array([[0.02, 0.01, 0.576]]))[0], rtol=1e-15)
    rc, out, _ = run_main(capsys, ["fk", PAPER, "--design", "before", *map(repr, q), "--json"])
    assert rc == 0
    x = json.loads(out)["output"]
    np.testing.assert_allclose([x["x"], x["y"], x["z"]], [0.02, 0.01, 0.576], atol=1e-12)


def test_ik_plain_text(capsys):
    rc, out, _ = run_main(capsys, ["ik", PAPER, "--design", "before", "0", "0", "0.592"])
    assert rc == 0
    # Table 1 pose 1 with the before dimensions: 0.4316 m (the table prints 0.42)
    assert out.strip() == "l1 = 0.431582777507 m  l2 = 0.431582777507 m  l3 = 0.431582777507 m"


def test_ik_unreachable_pose(capsys):
    rc, out, err = run_main(capsys, ["ik", PAPER, "0", "0", "3"])
    assert rc == 1
    assert out.startswith("unreachable")
    rc, out, _ = run_main(capsys, ["fk", PAPER, "--json", "0", "0", "5"])
    assert rc == 1
    assert json.loads(out)["reachable"] is False and json.loads(out)["output"]["x"] is None


@pytest.mark.parametrize("args,words", [
    (["ik", PAPER, "0", "0"], "expected 3 values"),
    (["fk", PAPER, "--design", "nope", "0.4", "0.4", "0.4"], "no design named 'nope'"),
    (["ik", PAPER, "nan", "0", "0.5"], "expected a finite number"),
    (["atlas", PAPER, "--resolution", "1"], "--resolution"),
    (["evaluate", PAPER, "--design", "middle"], "no design named 'middle'"),
])
def test_usage_errors_one_line(capsys, args, words):
    rc, out, err = run_main(capsys, args)
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("optdesign: error: ") and words in lines[0]
    assert "Traceback" not in err


def test_evaluate_table(capsys):
    rc, out, err = run_main(capsys, ["evaluate", PAPER])
    assert rc == 0 and err == ""
    assert "121 points" in out
    rows = {}   # the first table (mean, ±, paper, rel. diff); the spread over W follows
    for line in out.splitlines():
        if line.startswith("| "):
            rows.setdefault(tuple(c.strip() for c in line.strip("|").split("|")[:2]), line)
    line = rows[("after", "stiffness [N/m]")]        # the index with its unit
    assert "0.3523" in line and "0.3522" in line and "+0.02%" in line
    assert "-19.22%" in rows[("before", "dynamic [kg]")]
    head = next(l for l in out.splitlines() if l.startswith("| design"))
    assert "reference" in head and "paper" not in head


def test_evaluate_one_design_json(capsys):
    rc, out, _ = run_main(capsys, ["evaluate", PAPER, "--design", "after", "--json"])
    assert rc == 0
    d = json.loads(out)["designs"]
    assert list(d) == ["after"]
    assert set(d["after"]) >= {"dynamic", "stiffness", "isotropy", "reachable_fraction"}
    assert set(d["after"]["dynamic"]) >= {"mean", "min", "max"}


def _atlas_rows(path):
    """local_indices.csv keyed by quantity (the unit suffix dropped), and its header."""
    from optdesign.units import strip_unit

    with open(path) as f:
        rows = list(csv.DictReader(f))
    return [{strip_unit(k): v for k, v in r.items()} for r in rows], list(rows[0])


def test_atlas_writes_csv_and_pngs(tmp_path, capsys):
    # --resolution 11 is the config's own 11 x 11 grid: the local values average to the global indices
    rc, out, err = run_main(capsys, ["atlas", PAPER, "--design", "after", "--out", str(tmp_path), "--resolution", "11"])
    assert rc == 0 and err == ""
    folder = tmp_path / "p4s_paper-after"
    rows, head = _atlas_rows(folder / "local_indices.csv")
    assert len(rows) == 121
    assert head == ["x [m]", "y [m]", "z [m]", "reachable", "dynamic [kg]", "stiffness [N/m]", "isotropy [–]"]
    assert all(r["z"] == "0.57" and r["reachable"] == "1" for r in rows)
    # the local values of the CSV average to the global indices of `evaluate`
    means = {k: np.mean([float(r[k]) for r in rows]) for k in ("dynamic", "stiffness", "isotropy")}
    assert means["dynamic"] == pytest.approx(15.756576240, rel=1e-8)
    assert means["stiffness"] == pytest.approx(0.352279354, rel=1e-8)
    assert means["isotropy"] == pytest.approx(4.537952468, rel=1e-8)
    # the centre point: an independent local evaluation
    m = P4S(r_a=0.21, r_b=0.71, L=0.38, d=0.12, phi=np.radians(35.0))
    centre = next(r for r in rows if float(r["x"]) == 0 and float(r["y"]) == 0)
    J = m.jacobian(np.array([[0.0, 0.0, 0.57]]))[0]
    assert float(centre["stiffness"]) == pytest.approx(np.linalg.svd(J, compute_uv=False).min() ** 2, rel=1e-9)
    for k in ("dynamic", "stiffness", "isotropy"):
        png = (folder / f"{k}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    assert not list(folder.glob(".*.tmp"))


def test_atlas_has_a_grid_of_its_own(tmp_path, capsys):
    """By default the atlas is finer than the optimization's sample (81 points
    per axis against the config's 11), and its mean is close to the global index
    (the 11 x 11 grid's mean is itself an estimate of the integral mean: 1.2 % apart here)."""
    rc, _, _ = run_main(capsys, ["atlas", PAPER, "--design", "after", "--out", str(tmp_path), "--no-plots"])
    assert rc == 0
    rows, _ = _atlas_rows(tmp_path / "p4s_paper-after" / "local_indices.csv")
    assert len(rows) == 81 * 81
    assert np.mean([float(r["stiffness"]) for r in rows]) == pytest.approx(0.352279354, rel=0.02)


def test_atlas_of_a_cylinder_keeps_to_the_disc(tmp_path, capsys):
    """A cylinder workspace is mapped over its disc, not its bounding square."""
    from optdesign.config import load_config

    rc, _, _ = run_main(capsys, ["atlas", str(ROOT / "configs" / "delta.yaml"), "--out", str(tmp_path), "--no-plots",
                                 "--resolution", "41"])
    assert rc == 0
    cfg = load_config(ROOT / "configs" / "delta.yaml")
    (folder,) = list(tmp_path.iterdir())
    rows, head = _atlas_rows(folder / "local_indices.csv")
    r = np.hypot([float(q["x"]) for q in rows], [float(q["y"]) for q in rows])
    assert r.max() <= cfg.workspace.radius * (1 + 1e-9) and r.max() > 0.95 * cfg.workspace.radius
    # the square's corners are gone: the grid points within 20 steps of the axis (Gauss: about pi 20^2)
    assert len(rows) == pytest.approx(np.pi * 20 ** 2, rel=0.02) and len(rows) < 0.8 * 41 * 41


def test_atlas_resolution_and_no_plots(tmp_path, capsys):
    rc, _, _ = run_main(capsys, ["atlas", PAPER, "--design", "before", "--out", str(tmp_path), "--resolution", "5", "--no-plots"])
    assert rc == 0
    folder = tmp_path / "p4s_paper-before"
    rows, _ = _atlas_rows(folder / "local_indices.csv")
    assert len(rows) == 25
    assert sorted({float(r["x"]) for r in rows}) == pytest.approx([-0.05, -0.025, 0.0, 0.025, 0.05])
    assert not list(folder.glob("*.png"))


def test_a_design_that_reaches_no_pose_is_an_error_with_a_unit_hint(capsys, edited_copy):
    """r_a written as 250 without `unit: mm` is 250 m: the design reaches no
    pose of W.  `evaluate` ends with exit 2 and one line (not a table of '-'
    with reachable fraction 0 and exit 0); `validate-config` refuses the
    default design the same way; the same file in mm is fine."""
    tiny = ROOT / "tests" / "data" / "p4s_tiny.yaml"
    m = edited_copy(tiny, {"r_a: {value: 0.25, bounds: [0.21, 0.29]}": "r_a: {value: 250, bounds: [180, 300]}"},
                    "m.yaml")
    for cmd in ("evaluate", "validate-config"):
        rc, out, err = run_main(capsys, [cmd, str(m)])
        assert rc == 2 and out == "", (cmd, out)
        (line,) = err.strip().splitlines()
        assert f"{m}: design_variables: no pose of W is reachable for design 'initial'; are the values in m?" in line
        assert "unit: mm" in line
    mm = edited_copy(tiny, {"r_a: {value: 0.25, bounds: [0.21, 0.29]}":
                            "r_a: {value: 250, bounds: [210, 290], unit: mm}"}, "mm.yaml")
    for cmd in ("evaluate", "validate-config"):
        rc, out, err = run_main(capsys, [cmd, str(mm)])
        assert rc == 0 and err == "", (cmd, err)
    far = edited_copy(SMALL_YAML, {"z: 0.57": "z: 3.0"}, "far.yaml")     # in m, but W is out of reach
    rc, out, err = run_main(capsys, ["evaluate", str(far), "--design", "after"])
    assert rc == 2 and "designs.after: no pose of W is reachable for design 'after'" in err
    assert "are the values in m" not in err
