"""Config loading: the paper's config parses to the right SI values, and every
kind of mistake ends the real command with exit status 2 and one line naming
the file and the key path (never a traceback)."""
from __future__ import annotations

import copy
import math
import subprocess
import sys

import pytest
import yaml

from optdesign.evaluate import build
from optdesign.config import ConfigError, load_config, parse_config

from cli_helpers import run_main
from conftest import PAPER, ROOT, load_paper_config, paper_data

BASE = paper_data()


# ----------------------------------------------------------------------------- the paper's config
def test_paper_config_values(paper_config):
    c = paper_config
    assert c.mechanism == "p4s"
    assert c.design("before") == pytest.approx(dict(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=math.radians(30)))
    assert c.design("after") == pytest.approx(dict(r_a=0.21, r_b=0.71, L=0.38, d=0.12, phi=math.radians(35)))
    assert c.design("initial") == c.design("before")
    phi = c.design_variables["phi"]
    assert phi.unit == "deg" and phi.bounds == pytest.approx((math.radians(25), math.radians(35)))
    assert phi.display(phi.value) == pytest.approx(30.0)
    assert [v.name for v in c.free_variables] == ["r_a", "r_b", "phi"]
    assert c.parameters["m_platform"] == 4.16 and c.parameters["rod_Ixx"] == 0.0223
    ws = c.workspace
    assert ws.type == "box" and ws.sampling == "grid" and ws.step == 0.01
    assert ws.axes == {"x": (-0.05, 0.05), "y": (-0.05, 0.05), "z": (0.57, 0.57)}
    assert {k: (v.kind, v.convention, v.sense) for k, v in c.indices.items()} == {
        "dynamic": ("dynamic", None, "min"),
        "stiffness": ("stiffness", "lambda_min_K", "max"),
        "isotropy": ("isotropy", "frobenius", "min")}
    assert c.reference["before"]["dynamic"] == 29.9205
    assert c.optimizer.population == 50 and c.optimizer.generations == 100 and c.optimizer.elites == 2
    m = build(c, "after")
    assert float(m.r_a) == 0.21 and float(m.m_slider) == 2.57


def test_defaults_and_units():
    text = """
mechanism: p4s
design_variables:
  r_a: 0.25           # plain numbers are SI
  r_b: {value: 670, unit: mm}
  L: {value: 0.38}
  d: 0.12
  phi: {value: 0.5, unit: rad}
workspace: {type: cylinder, radius: 0.04, axes: {z: [0.55, 0.59]}, sampling: sobol, points: 64, seed: 3}
indices: {dynamic: {}, iso: {kind: isotropy}}
"""
    with pytest.raises(ConfigError, match=r"design_variables\.d: expected d < 2 r_a"):
        parse_config(text.replace("r_a: 0.25 ", "r_a: 0.05 "))
    c = parse_config(text, source="t.yaml")
    assert c.design("initial")["r_b"] == pytest.approx(0.67)
    assert c.design("initial")["phi"] == 0.5
    assert c.parameters == {}                                 # paper's masses by default
    assert float(build(c, "initial").m_platform) == 4.16
    assert c.indices["iso"].convention == "frobenius"         # the default convention
    assert c.indices["dynamic"].kind == "dynamic"
    assert c.workspace.radius == 0.04 and c.workspace.points == 64 and c.workspace.seed == 3
    assert c.optimizer.weights == {"dynamic": 1.0, "iso": 1.0}
    assert c.name == "t"


# ----------------------------------------------------------------------------- mistakes
def _set(path, value):
    d = copy.deepcopy(BASE)
    cur = d
    for k in path[:-1]:
        cur = cur[k]
    if value is KeyError:
        del cur[path[-1]]
    else:
        cur[path[-1]] = value
    return d


# (id, config data, key path the line must name, words the message must contain)
MISTAKES = [
    ("missing-key", _set(["mechanism"], KeyError), "mechanism", "missing"),
    ("missing-design-variable", _set(["design_variables", "r_b"], KeyError), "design_variables.r_b", "missing"),
    ("missing-workspace", _set(["workspace"], KeyError), "workspace", "missing"),
    ("missing-axis", _set(["workspace", "axes", "z"], KeyError), "workspace.axes.z", "missing"),
    ("wrong-type-number", _set(["parameters", "m_slider"], "heavy"), "parameters.m_slider", "expected a number"),
    ("wrong-type-mapping", _set(["indices"], ["dynamic"]), "indices", "expected a mapping"),
    ("wrong-type-integer", _set(["optimizer", "population"], 50.5), "optimizer.population", "expected an integer"),
    ("wrong-type-bool", _set(["design_variables", "r_a", "value"], True), "design_variables.r_a.value", "expected a number"),
    ("bounds-reversed", _set(["design_variables", "r_a", "bounds"], [0.29, 0.21]), "design_variables.r_a.bounds", "above upper"),
    ("bounds-not-pair", _set(["design_variables", "r_a", "bounds"], [0.1, 0.2, 0.3]), "design_variables.r_a.bounds", "[lower, upper]"),
    ("workspace-reversed", _set(["workspace", "axes", "x"], [0.05, -0.05]), "workspace.axes.x", "above upper"),
    ("unknown-mechanism", _set(["mechanism"], "stewart9"), "mechanism", "unknown mechanism"),
    ("unknown-index", _set(["indices", "dynamic", "kind"], "dynamo"), "indices.dynamic.kind", "unknown index"),
    ("unknown-convention", _set(["indices", "stiffness", "convention"], "sqrt"), "indices.stiffness.convention", "expected one of"),
    ("unknown-key", _set(["colour"], "red"), "colour", "unknown key"),
    ("unknown-parameter", _set(["parameters", "mass"], 3), "parameters.mass", "unknown key"),
    ("negative-length", _set(["design_variables", "L", "value"], -0.38), "design_variables.L.value", "positive length"),
    ("negative-length-design", _set(["designs", "after", "r_b"], -0.71), "designs.after.r_b", "positive length"),
    ("zero-length", _set(["design_variables", "d"], 0), "design_variables.d", "positive length"),
    ("negative-mass", _set(["parameters", "m_rod"], -1.59), "parameters.m_rod", "non-negative"),
    ("zero-stiffness", _set(["parameters", "k"], 0), "parameters.k", "positive"),
    ("not-finite", _set(["parameters", "g"], float("nan")), "parameters.g", "finite"),
    ("value-outside-bounds", _set(["design_variables", "r_a", "value"], 0.5), "design_variables.r_a.value", "outside the bounds"),
    ("impossible-geometry", _set(["designs", "after", "d"], 0.5), "designs.after.d", "d < 2 r_a"),
    ("rail-angle", _set(["designs", "after", "phi"], 95), "designs.after.phi", "between 0 and 90"),
    ("bad-unit", _set(["design_variables", "phi", "unit"], "grad"), "design_variables.phi.unit", "expected one of"),
    ("step-negative", _set(["workspace", "step"], -0.01), "workspace.step", "positive"),
    ("step-too-fine", _set(["workspace", "step"], 1e-9), "workspace.step", "at most"),
    ("bad-weight", _set(["optimizer", "weights", "speed"], 1), "optimizer.weights.speed", "unknown index"),
    ("partial-weights", _set(["optimizer", "weights"], {"dynamic": 1, "stiffness": 1}), "optimizer.weights",
     "no weight for isotropy; give every index a weight (give 0 to leave one out)"),
    ("removed-normalization", _set(["optimizer", "normalization"], "sense"), "optimizer.normalization",
     "this key was removed"),
    ("removed-min-transmission", _set(["optimizer", "min_transmission"], 0.2), "optimizer.min_transmission",
     "this key was removed"),
    ("bad-probability", _set(["optimizer", "crossover_probability"], 1.5), "optimizer.crossover_probability", "probability"),
    ("top-level-list", [1, 2, 3], "", "expected a mapping"),
    ("count-not-whole", _set(["parameters", "rods_per_branch"], 2.5), "parameters.rods_per_branch", "whole number"),
    ("mm-on-an-angle", _set(["design_variables", "phi", "unit"], "mm"), "design_variables.phi.unit", "expected one of deg, rad"),
    ("deg-on-a-length", _set(["design_variables", "r_a"], {"value": 250, "unit": "deg"}), "design_variables.r_a.unit",
     "expected one of m, mm"),
    ("deg-on-length-axes", _set(["workspace", "unit"], "deg"), "workspace.unit", "axis x is a length"),
    ("unit-on-a-mass", _set(["parameters", "m_rod"], {"value": 1.59, "unit": "mm"}), "parameters.m_rod.unit",
     "expected one of kg"),
    ("step-and-points-per-axis", _set(["workspace", "points_per_axis"], 11), "workspace.points_per_axis", "not both"),
    ("points-on-a-grid", _set(["workspace", "points"], 100), "workspace.points", "'points' is for sampling"),
    ("seed-too-large", _set(["workspace", "seed"], 10 ** 30), "workspace.seed", "<= 4294967295"),
    ("radius-on-a-box", _set(["workspace", "radius"], 0.1), "workspace.radius", "for type: cylinder"),
    ("bounds-outside-the-valid-range", _set(["design_variables", "phi", "bounds"], [25, 95]),
     "design_variables.phi.bounds", "between 0 and 90"),
    ("bounds-with-impossible-corners", _set(["design_variables", "r_a", "bounds"], [0.05, 0.29]),
     "design_variables.r_a.bounds", "the bounds hold impossible designs: at the corner r_a = 0.05"),
    ("index-option-unknown", _set(["indices", "stiffness", "options"], {"kk": 2}), "indices.stiffness.options.kk",
     "unknown key (did you mean 'k'?)"),
    ("index-takes-no-options", _set(["indices", "dynamic", "options"], {"k": 2}), "indices.dynamic.options.k",
     "takes no options"),
    ("name-with-a-slash", _set(["name"], "../up"), "name", "'/' is not allowed"),
    ("design-name-too-long", _set(["designs", "x" * 101], {"r_a": 0.25}), "", "a name of 101 characters; expected at most 100"),
    ("index-name-dot", _set(["indices", ".hidden"], {"kind": "dynamic"}), "indices..hidden", "may not start with '.'"),
    ("did-you-mean-key", _set(["worksapce"], {}), "worksapce", "did you mean 'workspace'"),
    ("worst-case-not-bool", _set(["optimizer", "worst_case"], "yes"), "optimizer.worst_case", "expected true or false"),
    ("margin-too-large", _set(["optimizer", "constraint_margin"], 0.7), "optimizer.constraint_margin",
     "expected a fraction in [0, 0.5)"),
    ("margin-negative", _set(["optimizer", "constraint_margin"], -0.01), "optimizer.constraint_margin",
     "expected a fraction in [0, 0.5), got -0.01"),
]


def _check_one_line(err, path, keypath, words):
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    line = lines[0]
    assert line.startswith("optdesign: error: ")
    assert str(path) in line
    if keypath:
        assert f": {keypath}: " in line
    assert words in line


@pytest.mark.parametrize("name,data,keypath,words", MISTAKES, ids=[m[0] for m in MISTAKES])
def test_mistakes_through_validate_config(write_yaml, capsys, name, data, keypath, words):
    path = write_yaml(data, f"{name}.yaml")
    rc, out, err = run_main(capsys, ["validate-config", str(path)])
    assert rc == 2
    _check_one_line(err, path, keypath, words)
    assert out == ""


FILE_MISTAKES = [
    ("yaml-syntax", b"mechanism: p4s\n  bad: [1, 2\n", "YAML syntax error at line 2"),
    ("yaml-tab", b"mechanism: p4s\n\tindices: {}\n", "YAML syntax error"),
    ("empty", b"", "empty file"),
    ("only-comments", b"# nothing here\n", "empty file"),
    ("binary", bytes(range(256)) * 4, "not a text file"),
    ("nul-bytes", b"mechanism: p4s\x00\n", "not a text file"),
]


@pytest.mark.parametrize("name,content,words", FILE_MISTAKES, ids=[m[0] for m in FILE_MISTAKES])
def test_file_mistakes(tmp_path, capsys, name, content, words):
    path = tmp_path / f"{name}.yaml"
    path.write_bytes(content)
    rc, out, err = run_main(capsys, ["validate-config", str(path)])
    assert rc == 2
    _check_one_line(err, path, "", words)


def test_file_not_found_and_directory(tmp_path, capsys):
    missing = tmp_path / "nope.yaml"
    rc, _, err = run_main(capsys, ["validate-config", str(missing)])
    assert rc == 2
    _check_one_line(err, missing, "", "file not found")
    rc, _, err = run_main(capsys, ["validate-config", str(tmp_path)])
    assert rc == 2
    _check_one_line(err, tmp_path, "", "directory")


@pytest.mark.parametrize("command", [["evaluate"], ["atlas"], ["ik", "--design", "after"]])
def test_other_commands_report_config_mistakes_the_same_way(write_yaml, capsys, command):
    path = write_yaml(_set(["design_variables", "r_a", "bounds"], [0.29, 0.21]), "bad.yaml")
    extra = ["0", "0", "0.57"] if command[0] == "ik" else []
    rc, _, err = run_main(capsys, [command[0], str(path), *command[1:], *extra])
    assert rc == 2
    _check_one_line(err, path, "design_variables.r_a.bounds", "above upper")


@pytest.mark.parametrize("content,words", [
    (yaml.safe_dump(_set(["workspace", "axes", "z"], KeyError)), "workspace.axes.z: missing"),
    ("mechanism: [p4s\n", "YAML syntax error"),
    (None, "file not found"),
], ids=["missing-axis", "yaml-syntax", "file-not-found"])
def test_real_process_exit_status_and_one_line(tmp_path, content, words):
    """The installed command in a fresh process: status 2, one line on stderr."""
    path = tmp_path / "c.yaml"
    if content is not None:
        path.write_text(content)
    proc = subprocess.run([sys.executable, "-m", "optdesign.cli", "validate-config", str(path)],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and words in lines[0]


def test_validate_config_ok(capsys):
    rc, out, err = run_main(capsys, ["validate-config", str(PAPER)])
    assert rc == 0 and err == ""
    assert "ok" in out and "121 points" in out and "free variables: r_a, r_b, phi" in out


def test_load_config_raises_config_error_with_path(write_yaml):
    path = write_yaml(_set(["indices", "dynamic", "kind"], "dynamo"), "x.yaml")
    with pytest.raises(ConfigError) as exc:
        load_config(path)
    assert exc.value.source == str(path)
    assert exc.value.path == "indices.dynamic.kind"
    assert "\n" not in str(exc.value)



def test_joint_stiffness_reaches_the_stiffness_index():
    """parameters.k is the k of K = J^T k J unless the index sets options.k."""
    c = parse_config(yaml.safe_dump(_set(["parameters", "k"], 2.0)))
    assert c.indices["stiffness"].options == {"k": 2.0}
    d = copy.deepcopy(BASE)
    d["parameters"]["k"] = 2.0
    d["indices"]["stiffness"]["options"] = {"k": 5.0}
    assert parse_config(yaml.safe_dump(d)).indices["stiffness"].options == {"k": 5.0}
    d["indices"]["stiffness"]["options"] = {"k": -1.0}
    with pytest.raises(ConfigError, match=r"indices\.stiffness\.options\.k: expected a positive number"):
        parse_config(yaml.safe_dump(d))
    from optdesign.evaluate import evaluate

    base = load_paper_config()
    ev1 = evaluate(base, [base.design("after")])
    ev2 = evaluate(c, [c.design("after")])
    assert ev2.summary["stiffness"]["mean"][0] == pytest.approx(2.0 * ev1.summary["stiffness"]["mean"][0], rel=1e-12)
    assert ev2.summary["isotropy"]["mean"][0] == pytest.approx(ev1.summary["isotropy"]["mean"][0], rel=1e-12)
