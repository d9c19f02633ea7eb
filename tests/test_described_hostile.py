"""Hostile mechanism descriptions: every mistake ends with exit status 2 and
one stderr line ``optdesign: error: <file>: <key>: <message>`` naming the key of
the description, never a traceback, and writes nothing."""
from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml
from cli_helpers import run_cli_in

ROOT = Path(__file__).resolve().parents[1]
GS = yaml.safe_load((ROOT / "configs" / "gough_stewart.yaml").read_text())
DELTA = yaml.safe_load((ROOT / "configs" / "delta.yaml").read_text())


def _set(cfg, path, value):
    d = cfg
    keys = path.split(".")
    for k in keys[:-1]:
        d = d[int(k)] if isinstance(d, list) else d[k]
    last = keys[-1]
    if value is _DELETE:
        del d[int(last) if isinstance(d, list) else last]
    elif isinstance(d, list):
        d[int(last)] = value
    else:
        d[last] = value


_DELETE = object()

# (base config, [(dotted path, value)], expected key path, fragment of the message)
CASES = [
    ("unknown joint kind", GS, [("mechanism.legs.0.kind", "spherical")], "mechanism.legs[0].kind", "unknown leg kind 'spherical'"),
    ("misspelt joint kind", GS, [("mechanism.legs.0.kind", "strutt")], "mechanism.legs[0].kind", "did you mean 'strut'?"),
    ("a leg that can never close", DELTA, [("mechanism.legs.0.rod", {"length": 0.05, "mass": "m_rod", "count": 2})],
     "mechanism.legs[0]", "cannot close at the home pose"),
    ("undefined name", GS, [("mechanism.legs.0.base", ["R_q", 0, 0])], "mechanism.legs[0].base[0]",
     "unknown name 'R_q'"),
    ("did you mean", GS, [("mechanism.legs.0.platform", ["R_pp", 0, 0])], "mechanism.legs[0].platform[0]",
     "did you mean 'R_p'?"),
    ("division by zero", GS, [("mechanism.legs.0.base", ["R_b / (R_p - R_p)", 0, 0])], "mechanism.legs[0].base[0]",
     "division by zero in 'R_b / (R_p - R_p)'"),
    ("division by zero in a pattern", GS, [("mechanism.legs.0.pattern.split", {"base": "split_b / (R_b - 0.5)", "platform": "split_p"})],
     "mechanism.legs[0].pattern", "division by zero"),
    ("square root of a negative number", DELTA, [("mechanism.legs.0.platform", ["sqrt(r - R)", 0, 0])],
     "mechanism.legs[0].platform[0]", "square root of a negative number"),
    ("singular description", GS, [("mechanism.legs.0.platform", [0, 0, 0])], "mechanism.legs",
     "the Jacobian is singular"),
    ("singular: pairs that coincide", GS, [("mechanism.legs.0.pattern.split", 0)], "mechanism.legs",
     "the Jacobian is singular"),
    ("python code", GS, [("mechanism.legs.0.base", ["__import__('os').getcwd()", 0, 0])], "mechanism.legs[0].base[0]",
     "only plain function calls"),
    ("attribute access", GS, [("mechanism.legs.0.base", ["R_b.__class__", 0, 0])], "mechanism.legs[0].base[0]",
     "attribute access is not allowed"),
    ("boolean expression", GS, [("mechanism.legs.0.base", [True, 0, 0])], "mechanism.legs[0].base[0]", "got a boolean"),
    ("vector of two", GS, [("mechanism.legs.0.base", ["R_b", 0])], "mechanism.legs[0].base", "expected a list of 3"),
    ("unknown key", GS, [("mechanism.legs.0.rodd", 0.3)], "mechanism.legs[0].rodd", "unknown key"),
    ("rod on a strut", GS, [("mechanism.legs.0.rod", 0.3)], "mechanism.legs[0].rod", "unknown key"),
    ("missing rod", DELTA, [("mechanism.legs.0.rod", _DELETE)], "mechanism.legs[0].rod", "missing required key"),
    ("missing axis", DELTA, [("mechanism.legs.0.axis", _DELETE)], "mechanism.legs[0].axis", "missing required key"),
    ("reference along the axis", DELTA, [("mechanism.legs.0.reference", [0, 2, 0])], "mechanism.legs[0].reference",
     "parallel to the axis"),
    ("zero axis", DELTA, [("mechanism.legs.0.axis", [0, 0, 0])], "mechanism.legs[0].axis", "zero length"),
    ("negative rod", DELTA, [("mechanism.legs.0.rod.length", "-L_b")], "mechanism.legs[0].rod",
     "expected a positive rod length"),
    ("bad branch", DELTA, [("mechanism.legs.0.branch", "elbow_up")], "mechanism.legs[0].branch", "expected one of"),
    ("too few legs", GS, [("mechanism.legs.0.pattern.angles", [0, 120])], "mechanism.legs", "4 legs for a pose of 6"),
    ("unknown pose type", GS, [("mechanism.pose.type", "helical")], "mechanism.pose.type", "unknown pose type"),
    ("home of an unknown coordinate", GS, [("mechanism.pose.home", {"w": 0.7})], "mechanism.pose.home.w", "unknown pose coordinate"),
    ("pattern unit", GS, [("mechanism.legs.0.pattern.unit", "grad")], "mechanism.legs[0].pattern.unit", "expected one of deg, rad"),
    ("parameter kind", GS, [("mechanism.parameters.R_b", "lenght")], "mechanism.parameters.R_b.kind", "did you mean 'length'?"),
    ("parameter named like a function", GS, [("mechanism.parameters.sin", "length")], "mechanism.parameters.sin",
     "function or constant"),
    ("fixed parameter without default", GS, [("mechanism.parameters.m_platform", {"kind": "mass"})],
     "mechanism.parameters.m_platform.default", "needs a default"),
    ("duplicate actuators", GS, [("mechanism.legs.0.actuator", _DELETE), ("mechanism.legs.0.actuators", ["a", "a", "b", "c", "d", "e"])], "mechanism.legs",
     "used twice"),
    ("angular_velocity with two angles", GS, [("mechanism.pose", {"type": "rotation", "angles": ["roll", "pitch"],
                                                                  "jacobian": "angular_velocity"})],
     "mechanism.pose.jacobian", "needs all three angles"),
    ("huge number", GS, [("mechanism.legs.0.base", [1e300, 0, 0])], "mechanism.legs[0].base[0]", "sensible size"),
    ("overflow", GS, [("mechanism.legs.0.base", ["10 ** (R_b * 1000)", 0, 0])], "mechanism.legs[0].base[0]", "overflow"),
    ("description not a mapping of legs", GS, [("mechanism.legs", {"kind": "strut"})], "mechanism.legs", "expected a list"),
    ("deeply nested", GS, [("mechanism.legs.0.lower", {"mass": {"a": {"b": {"c": [[[[[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]]]]]}}}})],
     "mechanism.legs[0].lower.mass.a.b.c[0]*", "nested deeper"),
    ("actuator and actuators", GS, [("mechanism.legs.0.actuators", ["a", "b", "c", "d", "e", "f"])], "mechanism.legs[0].actuator",
     "not both"),
    ("inertia mapping key", GS, [("mechanism.platform.inertia", {"xx": 1, "ww": 2})], "mechanism.platform.inertia.ww",
     "unknown key"),
    ("masses without a platform mass", DELTA, [("mechanism.platform", {"inertia": [1, 1, 1]})], "mechanism.platform.mass",
     "legs have masses"),
    ("leg masses of a design that divides by zero", DELTA, [("mechanism.legs.0.crank.mass", "m_crank / (L_a - 0.25)")],
     "mechanism.legs[0].crank.mass", "division by zero"),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("command", [["validate-config"], ["evaluate"], ["ik", "--design", "reference", "0", "0", "0"]])
def test_hostile_description(tmp_path, case, command):
    _, base, edits, key, fragment = case
    cfg = copy.deepcopy(base)
    for path, value in edits:
        _set(cfg, path, value)
    f = tmp_path / "hostile.yaml"
    f.write_text(yaml.safe_dump(cfg, sort_keys=False))
    argv = [command[0], str(f)] + command[1:]
    rc, out, err = run_cli_in(tmp_path, argv)
    lines = err.strip().splitlines()
    assert rc == 2, (rc, out, err)
    assert len(lines) == 1, err
    assert "Traceback" not in err
    head = f"optdesign: error: {f}: {key[:-1]}" if key.endswith("*") else f"optdesign: error: {f}: {key}: "
    assert lines[0].startswith(head), lines[0]
    assert fragment in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hostile.yaml"]


def test_alias_bomb_in_a_description(tmp_path):
    text = (ROOT / "configs" / "gough_stewart.yaml").read_text()
    bomb = "bomb:\n  a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"  {chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}, *{chr(97 + i)}]\n"
        for i in range(8))
    text = text.replace("mechanism:\n  name: gough_stewart\n", "mechanism:\n  name: gough_stewart\n  " + bomb.replace("\n", "\n  ").rstrip() + "\n")
    f = tmp_path / "bomb.yaml"
    f.write_text(text)
    rc, out, err = run_cli_in(tmp_path, ["validate-config", str(f)])
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert f"{f}: mechanism" in err
