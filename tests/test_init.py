"""optdesign init: for every registered mechanism the commented config it
writes validates and runs as it is (with a small budget)."""
from __future__ import annotations

import json

import pytest
import yaml

from optdesign.mechanisms import available

from cli_helpers import run_cli_in


@pytest.mark.slow
@pytest.mark.parametrize("mech", available())
def test_init_config_validates_and_runs(tmp_path, mech):
    rc, out, err = run_cli_in(tmp_path, ["init", mech, "c.yaml"])
    assert rc == 0, err
    text = (tmp_path / "c.yaml").read_text()
    assert f"mechanism: {mech}" in text and "# " in text
    rc, out, err = run_cli_in(tmp_path, ["validate-config", "c.yaml"])
    assert rc == 0 and "ok" in out, err
    small = (text.replace("population: 30", "population: 8").replace("generations: 30", "generations: 2")
             .replace("population: 40, generations: 40", "population: 8, generations: 2"))
    assert small != text
    # what is checked is that the template runs to the end: the constraints at the samples, one start
    # per extreme and one polish, small proofs and coarse integrals (tests/test_worstcase.py, test_polish.py
    # and test_certify*.py check those parts)
    data = yaml.safe_load(small)
    data["optimizer"].update(worst_case=False, polish=1, extremes={"starts": 1, "scan": 256})
    data["checks"] = {"certificate_budget": 400, "integral_tolerance": 0.05, "integral_max_points": 500}
    (tmp_path / "small.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    rc, out, err = run_cli_in(tmp_path, ["run", "small.yaml", "--quiet", "--jobs", "1", "--out", "runs"])
    assert rc == 0, err
    folder = next((tmp_path / "runs").iterdir())
    res = json.loads((folder / "results.json").read_text())
    assert res["status"] == "complete" and res["mechanism"] == mech


def test_init_refuses_to_overwrite_and_unknown_names(tmp_path):
    (tmp_path / "c.yaml").write_text("keep me")
    rc, _, err = run_cli_in(tmp_path, ["init", "p4s", "c.yaml"])
    assert rc == 2 and "exists" in err and (tmp_path / "c.yaml").read_text() == "keep me"
    rc, _, err = run_cli_in(tmp_path, ["init", "p4z"])
    assert rc == 2 and "did you mean 'p4s'" in err and len(err.strip().splitlines()) == 1
