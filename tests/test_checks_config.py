"""The config's ``checks`` section: its keys are validated (one line naming
the file and the key, exit 2), a certificate budget of 0 leaves every
reported design ``unknown`` with nothing proved (never ``certified``), and
``integral_tolerance: 0`` records no integrals."""
from __future__ import annotations

import json

import pytest
from cli_helpers import run_cli_in
from conftest import DATA


@pytest.mark.parametrize("checks, key", [
    ("{certificate_budget: -1}", "checks.certificate_budget"),
    ("{certificate_budget: 2.5}", "checks.certificate_budget"),
    ("{integral_tolerance: 0.9}", "checks.integral_tolerance"),
    ("{integral_tolerance: -1e-3}", "checks.integral_tolerance"),
    ("{integral_max_points: 10}", "checks.integral_max_points"),
    ("{certificate_bugdet: 10}", "checks.certificate_bugdet"),
    ("[1, 2]", "checks"),
])
def test_bad_checks_are_one_line(tmp_path, checks, key):
    f = tmp_path / "c.yaml"
    f.write_text((DATA / "p4s_tiny.yaml").read_text() + f"checks: {checks}\n")
    rc, out, err = run_cli_in(tmp_path, ["validate-config", str(f)])
    assert rc == 2 and err.count("\n") == 1 and "c.yaml" in err and key in err, err


def test_checks_are_read(tmp_path):
    from optdesign.config import load_config

    f = tmp_path / "c.yaml"
    f.write_text((DATA / "p4s_tiny.yaml").read_text()
                 + "checks: {certificate_budget: 123, integral_tolerance: 1e-3, integral_max_points: 5000}\n")
    c = load_config(f).checks
    assert (c.certificate_budget, c.integral_tolerance, c.integral_max_points) == (123, 1e-3, 5000)
    assert load_config(DATA / "p4s_tiny.yaml").checks.certificate_budget == 300_000


def test_no_budget_proves_nothing_and_says_so(tmp_path):
    f = tmp_path / "c.yaml"
    f.write_text((DATA / "p4s_tiny.yaml").read_text() + "checks: {certificate_budget: 0, integral_tolerance: 0}\n")
    rc, out, err = run_cli_in(tmp_path, ["run", str(f), "--quiet", "--jobs", "1", "--out", "runs"])
    assert rc == 0, err
    (folder,) = list((tmp_path / "runs").iterdir())
    res = json.loads((folder / "results.json").read_text())
    certs = res["certificates"]
    assert certs and all(c["status"] == "unknown" and c["share_proved"] == 0 for c in certs.values())
    assert "integrals" not in res
    md = (folder / "results.md").read_text()
    assert "unknown (0.0 % of W proved)" in md and "Every reported design is certified" not in md
