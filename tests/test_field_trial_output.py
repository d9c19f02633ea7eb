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
