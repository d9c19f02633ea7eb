"""Mistakes in chain descriptions (docs/lower-mobility.md): each is one line,
exit status 2, naming the file and the key, never a traceback; the mobility
message says the mobility, how it was found, what was expected and the leg."""
from __future__ import annotations

import copy
from pathlib import Path

import pytest
import yaml
from cli_helpers import run_cli_in

ROOT = Path(__file__).resolve().parents[1]
BASE = yaml.safe_load((ROOT / "configs" / "prs3.yaml").read_text())


def _joints(c):
    return c["mechanism"]["legs"][0]["joints"]


def _pus(c):
    _joints(c)[1] = {"type": "U", "axis": [0, 1, 0], "axis2": [1, 0, 0], "at": ["R_b", 0, 0]}


def _four(c):
    c["mechanism"]["pose"]["independent"] = ["z", "roll", "pitch", "yaw"]
    c["mechanism"]["legs"].append({"kind": "strut", "actuator": "l", "base": [0.4, 0.4, 0], "platform": [0.1, 0.1, 0]})


def _set(path, value):
    def f(c):
        node = c["mechanism"]
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value
    return f


CASES = [
    ("type", lambda c: _joints(c)[1].update(type="Rr"), "legs[0].joints[1].type",
     ["unknown joint type 'Rr' (did you mean 'R'?)"]),
    ("key", lambda c: _joints(c)[1].update(axes=[0, 1, 0]), "legs[0].joints[1].axes", ["did you mean 'axis'?"]),
    ("two actuated", lambda c: _joints(c)[1].update(actuated=True), "legs[0].joints[1].actuated",
     ["at most one actuated joint"]),
    ("S actuated", lambda c: _joints(c)[2].update(actuated=True), "legs[0].joints[2].actuated", ["cannot be actuated"]),
    ("zero axis", lambda c: _joints(c)[1].update(axis=[0, 0, 0]), "legs[0].joints[1].axis", ["zero length"]),
    ("mass on the S", lambda c: _joints(c)[2].update(mass=1), "legs[0].joints[2].mass", ["is the platform"]),
    ("independent typo", _set(["pose", "independent"], ["z", "rol", "pitch"]), "pose.independent[1]",
     ["did you mean 'roll'?"]),
    ("no home", lambda c: c["design_variables"].update(L={"value": 0.05}), "legs[0]",
     ["cannot close at the home pose", "leg q1"]),
    ("P-U-S", _pus, "legs[0]", ["mobility is 6", "rank 0 of the constraint wrenches", "twist systems",
                                "3 independent coordinates (z, roll, pitch)", "leg q1 (joints P-U-S)",
                                "rank 6, so it constrains nothing"]),
    ("four coordinates", _four, "legs[0]", ["mobility is 3", "4 independent coordinates",
                                            "leg q1 (joints P-R-S)", "without it the mobility would be 4"]),
    ("x y z independent", _set(["pose", "independent"], ["x", "y", "z"]), "pose.independent",
     ["cannot parametrize the motion", "(roll, pitch, yaw)"]),
    ("passive with a name", lambda c: _joints(c)[0].update(actuated=False), "legs[0].actuator",
     ["a passive leg (no actuated joint) has no actuator name"]),
    ("actuated count", lambda c: (_joints(c)[0].update(actuated=False), c["mechanism"]["legs"][0].pop("actuator")),
     "legs", ["0 actuated legs for 3 independent pose coordinates"]),
    ("negative link mass", lambda c: _joints(c)[1].update(mass=-0.3), "legs[0].joints[1].mass",
     ["expected a mass >= 0 kg, got -0.3"]),
    ("C actuated true", lambda c: _joints(c)[0].update(type="C"), "legs[0].joints[0].actuated",
     ["expected slide or turn"]),
    ("map without new names", _set(["pose", "map"], {"z": "2 * z"}), "pose.independent[0]",
     ["a mapped coordinate needs a new name"]),
    ("map unused name", lambda c: c["mechanism"]["pose"].update(independent=["h", "a", "b"],
                                                              map={"z": "h", "roll": "a", "pitch": "a"}),
     "pose.map", ["'b' appears in no expression"]),
]


@pytest.mark.parametrize("name,edit,key,words", CASES, ids=[c[0] for c in CASES])
def test_chain_mistakes(tmp_path, name, edit, key, words):
    cfg = copy.deepcopy(BASE)
    edit(cfg)
    path = tmp_path / "x.yaml"
    path.write_text(yaml.safe_dump(cfg))
    rc, out, err = run_cli_in(tmp_path, ["validate-config", "x.yaml"])
    assert rc == 2, (out, err)
    line = err.strip()
    assert "\n" not in line and "Traceback" not in line
    assert line.startswith(f"optdesign: error: x.yaml: mechanism.{key}: "), line
    for w in words:
        assert w in line, (w, line)
