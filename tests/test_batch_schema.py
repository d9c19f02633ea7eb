"""optdesign.batch.schema: batch files (a base config, seeds, a grid or zip
sweep) resolve to validated configs, and every mistake in one is a one-line
error naming the file and the key."""
from __future__ import annotations

import json

import pytest

from optdesign.batch.schema import load_batch_file
from optdesign.report.summary import collect_folders, group_stats, row_from_folder
from optdesign.batch.tasks import plan
from optdesign.cli import main
from optdesign.config import ConfigError, parse_config

from conftest import BATCH_SMALL as SMALL, CONFIGS, DATA


@pytest.mark.slow
def test_sweep_grid_zip_and_resolved_configs(tmp_path):
    tasks = plan([str(DATA / "batch_sweep.yaml")])
    assert len(tasks) == 8 and len({t.key for t in tasks}) == 8          # 2 masses × 2 widths × 2 seeds
    got = sorted((parse_config(t.config_text).parameters["m_platform"],
                  parse_config(t.config_text).workspace.axes["x"], t.seed) for t in tasks)
    assert got == sorted((m, x, s) for m in (4.16, 6.0) for x in ((-0.03, 0.03), (-0.05, 0.05)) for s in (1, 2))
    assert len(plan([str(DATA / "batch_sweep.yaml")], n_seeds=1)) == 4     # --seeds overrides the file's seeds

    zipf = tmp_path / "zip.yaml"
    zipf.write_text(f"base: {SMALL}\nmode: zip\nsweep:\n  parameters.m_platform: [4.16, 6.0]\n"
                    "  workspace.axes.x: [[-0.03, 0.03], [-0.05, 0.05]]\n")
    bf = load_batch_file(zipf)
    assert [c[2] for c in bf.combinations] == [{"parameters.m_platform": 4.16, "workspace.axes.x": [-0.03, 0.03]},
                                                {"parameters.m_platform": 6.0, "workspace.axes.x": [-0.05, 0.05]}]
    out = tmp_path / "runs"
    assert main(["batch", str(zipf), "--jobs", "1", "--out", str(out)]) == 0
    folders = collect_folders([out])
    assert len(folders) == 2
    for f, t in zip(sorted(folders), sorted(plan([str(zipf)]), key=lambda t: t.folder_name)):
        assert (f / "config.yaml").read_text() == t.config_text      # the resolved config is what ran
        assert json.loads((f / "manifest.json").read_text())["sweep"] == t.sweep
    groups = group_stats([row_from_folder(f) for f in folders])
    assert [g["sweep"] for g in groups] == ["m_platform=4.16, x=-0.03..0.03", "m_platform=6, x=-0.05..0.05"]
    assert groups[0]["stats"]["dynamic"]["mean"] != groups[1]["stats"]["dynamic"]["mean"]


@pytest.mark.parametrize("body, where", [
    ("sweep: {parameters.m_platform: [1]}", "base: missing required key"),
    ("base: nothere.yaml\n", "base: config file not found"),
    ("base: {small}\nsweeps: {{}}\n", "sweeps: unknown key"),
    ("base: {small}\nsweep: {{parameters.m_platform: 4.0}}\n", "sweep.parameters.m_platform: expected a non-empty list"),
    ("base: {small}\nsweep: {{workspace.axis.x: [[0, 1]]}}\n", "sweep.workspace.axis.x: "),
    ("base: {small}\nsweep: {{mechanism.x: [1]}}\n", "sweep.mechanism.x: can only change keys under"),
    ("base: {small}\nsweep: {{optimizer.seed: [1, 2]}}\n", "sweep.optimizer.seed: the seed is not swept here"),
    ("base: {small}\nsweep: {{parameters.m_platform: [4.0, -1.0]}}\n", "sweep.parameters.m_platform: value -1.0 gives"),
    ("base: {small}\nsweep: {{workspace.axes.x: [[0.05, -0.05]]}}\n", "sweep.workspace.axes.x: value [0.05, -0.05] gives"),
    ("base: {small}\nmode: zip\nsweep: {{parameters.m_platform: [4, 5], parameters.g: [9.81]}}\n", "sweep: zip mode needs lists of equal length"),
    ("base: {small}\nmode: cartesian\n", "mode: expected grid or zip"),
    ("base: {small}\nseeds: [1, -2]\n", "seeds[1]: expected an integer"),
    ("base: {small}\nset: {{optimizer.population: 2}}\n", "set: the resolved config gives optimizer.population"),
])
def test_batch_file_errors_are_one_line(tmp_path, capsys, body, where):
    f = tmp_path / "b.yaml"
    f.write_text(body.format(small=SMALL) if "{small}" in body else body)
    with pytest.raises(ConfigError) as exc:
        load_batch_file(f)
    msg = str(exc.value)
    assert msg.startswith(f"{f}: ") and "\n" not in msg
    assert where in msg, msg
    assert main(["batch", str(f), "--out", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"optdesign: error: {msg}"]
    assert not (tmp_path / "runs").exists()


def test_validate_config_accepts_batch_files(capsys):
    assert main(["validate-config", str(CONFIGS / "batch_example.yaml")]) == 0
    assert "batch file" in capsys.readouterr().out
