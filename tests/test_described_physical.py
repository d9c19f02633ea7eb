"""Physically impossible values in a description are refused at load (one
line naming the file and the key, exit 2), at the named designs and at the
corners of the bounds; a design of the box where one is impossible anyway
(an expression that is not monotone) is infeasible in an evaluation, never a
finite index."""
from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

from optdesign.config import ConfigError, load_config, parse_config
from optdesign.mechanisms.described.physical import MAX_COUNT, MAX_GRAVITY

from cli_helpers import run_main
from conftest import ROOT

LEGS = yaml.safe_load((ROOT / "configs" / "p4s_legs.yaml").read_text())


def _edit(path, value):
    data = copy.deepcopy(LEGS)
    node = data
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return data


def _leg(key, value):
    return _edit(["mechanism", "legs", 0, *key], value)


BAD = [
    ("platform-mass-negated", _edit(["mechanism", "platform", "mass"], "-m_platform"), "mechanism.platform.mass",
     "expected a mass >= 0 kg, got -4.16"),
    ("platform-mass-negative-number", _edit(["mechanism", "platform", "mass"], -4.16), "mechanism.platform.mass",
     "got -4.16"),
    ("platform-inertia-negative", _edit(["mechanism", "platform", "inertia"], [0.1, -0.2, 0.1]),
     "mechanism.platform.inertia", "positive semi-definite"),
    ("rod-mass-negative", _leg(["rod", "mass"], "-m_rod"), "mechanism.legs[0].rod.mass", "got -1.59"),
    ("slider-mass-negative", _leg(["slider", "mass"], -2.57), "mechanism.legs[0].slider.mass", "got -2.57"),
    ("rod-inertia-negative", _leg(["rod", "inertia"], "-rod_Ixx"), "mechanism.legs[0].rod.inertia", "inertia >= 0"),
    ("rod-count-negative", _leg(["rod", "count"], -2), "mechanism.legs[0].rod.count", f"from 1 to {MAX_COUNT}, got -2"),
    ("rod-count-fraction", _leg(["rod", "count"], "2/3"), "mechanism.legs[0].rod.count", "whole number"),
    ("rod-count-huge", _leg(["rod", "count"], 1e12), "mechanism.legs[0].rod.count", "got 1e+12"),
    ("rod-centre-5", _leg(["rod", "centre"], 5), "mechanism.legs[0].rod.centre", "[0, 1], got 5"),
    ("rod-centre-minus-1", _leg(["rod", "centre"], -1), "mechanism.legs[0].rod.centre", "[0, 1], got -1"),
    ("gravity-negated", _edit(["mechanism", "gravity"], "-g"), "mechanism.gravity",
     f"[0, {MAX_GRAVITY:g}] m/s^2, got -9.81"),
    ("gravity-absurd", _edit(["mechanism", "gravity"], 1e12), "mechanism.gravity", "got 1e+12"),
    ("mass-default-negative", _edit(["mechanism", "parameters", "m_platform"], {"kind": "mass", "default": -4.16}),
     "mechanism.parameters.m_platform.default", "expected a mass >= 0 kg, got -4.16"),
    ("mass-negative-at-a-corner", _edit(["mechanism", "platform", "mass"], "m_platform * (r_a - 0.22) * 100"),
     "mechanism.platform.mass", "at the corner r_a = 0.21"),
]


@pytest.mark.parametrize("name,data,key,words", BAD, ids=[b[0] for b in BAD])
def test_impossible_physical_values_are_refused_at_load(tmp_path, capsys, name, data, key, words):
    if name == "mass-default-negative":
        data["parameters"].pop("m_platform")       # the default is the value used
    if name == "mass-negative-at-a-corner":
        data["designs"].pop("after")                # r_a = 0.21: only the corner of the bounds is left
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    rc, out, err = run_main(capsys, ["validate-config", str(path)])
    assert rc == 2 and out == ""
    (line,) = err.strip().splitlines()
    assert line.startswith(f"optdesign: error: {path}: {key}: ") and words in line, line


def test_the_shipped_description_passes():
    assert load_config(ROOT / "configs" / "p4s_legs.yaml").mechanism_class.description.has_dynamics


def test_a_design_of_the_box_with_an_impossible_mass_is_infeasible():
    """Positive at every corner and at the named designs, negative around
    r_a = 0.25: the load passes, the evaluation gives no finite index there and
    the optimizer's constraint marks it infeasible."""
    from optdesign import fast
    from optdesign.evaluate import Evaluator, evaluate

    data = _edit(["mechanism", "platform", "mass"], "m_platform * ((r_a - 0.25)**2 * 1e4 - 1)")
    data["design_variables"]["r_a"]["value"] = 0.28
    data["designs"] = {"after": data["designs"]["after"]}
    data["workspace"]["step"] = 0.05
    cfg = parse_config(yaml.safe_dump(data, sort_keys=False), source="hump.yaml")
    good, bad = dict(cfg.design("after")), dict(cfg.design("after"), r_a=0.25)
    with fast.disabled():
        ev = evaluate(cfg, [good, bad])
        assert np.isfinite(ev.summary["dynamic"]["mean"][0]) and np.isnan(ev.summary["dynamic"]["mean"][1])
        assert np.all(np.isnan([ev.summary[k]["mean"][1] for k in cfg.indices]))
        E = Evaluator.from_config(cfg)
        out = E(np.array([E.vector(good), E.vector(bad)]))
    assert out["constraints"]["finite"].tolist() == [0.0, 1.0]
    with pytest.raises(ConfigError, match=r"mechanism\.platform\.mass: expected a mass >= 0 kg.*design 'before'"):
        data["designs"]["before"] = {"r_a": 0.25}
        parse_config(yaml.safe_dump(data, sort_keys=False), source="hump.yaml")
