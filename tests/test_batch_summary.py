"""optdesign.report.summary: the rows read back from run folders, the
statistics across seeds against the CSV a user reads, and the summarize
command's errors."""
from __future__ import annotations

import csv
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from optdesign.report.summary import collect_folders, group_stats, row_from_folder
from optdesign.batch.tasks import plan
from optdesign.cli import main
from optdesign.config import parse_config
from optdesign.optimize.pipeline import Interrupted
from optdesign.runner import run_in_folder
from optdesign.runs import RunFolder

from conftest import BATCH_SMALL as SMALL


@pytest.mark.slow
def test_summary_statistics_match_the_rows(small_batch, tmp_path):
    tasks, root, rows1 = small_batch
    # an interrupted third run shows up in the table but not in the statistics
    out = tmp_path / "runs"
    shutil.copytree(root / "jobs1", out)
    t3 = plan([str(SMALL)], seeds=[3])[0]
    folder = RunFolder.create(out, t3.folder_name, t3.config_text, t3.seed, t3.key, exact=True)
    folder.update_manifest(name=t3.name)
    with pytest.raises(Interrupted):
        run_in_folder(parse_config(t3.config_text), folder, t3.seed, stop_after=2, reports=False)

    assert main(["summarize", str(out)]) == 0
    with open(out / "summary.csv", newline="") as fh:
        table = list(csv.DictReader(fh))
    assert [r["seed"] for r in table] == ["1", "2", "3"]
    assert [r["status"] for r in table] == ["complete", "complete", "interrupted"]
    assert table[2]["objective"] == ""
    assert (out / "summary.png").stat().st_size > 1000

    rows = [row_from_folder(f) for f in collect_folders([out])]
    (g,) = group_stats(rows)
    assert g["runs"] == 3 and g["complete"] == 2 and g["seeds"] == [1, 2, 3]
    for q in ("objective_pooled", "objective", "opt_r_a", "dynamic", "stiffness", "isotropy", "wall_time_s"):
        v = np.array([float(r[q]) for r in table[:2]])          # from the CSV, as a user would
        s = g["stats"][q]
        assert s["mean"] == pytest.approx(v.mean(), rel=1e-12, abs=1e-300)
        assert s["std"] == pytest.approx(v.std(ddof=1), rel=1e-12, abs=1e-300)
        assert (s["min"], s["max"]) == (v.min(), v.max())
        # the best run on the pooled scale (ties: the lower seed)
        best = min(range(2), key=lambda i: (float(table[i]["objective_pooled"]), int(table[i]["seed"])))
        assert s["best"] == v[best]
    assert g["best_seed"] == int(table[best]["seed"])
    md = (out / "summary.md").read_text()
    mean, sd = g["stats"]["objective"]["mean"], g["stats"]["objective"]["std"]
    assert re.search(rf"\| objective +\| +{re.escape(f'{mean:.6g}')} \| +{re.escape(f'{sd:.6g}')} \|", md)
    assert "pooled over the 2 complete runs" in md
    assert "Runs not complete" in md and "interrupted" in md


def test_summarize_usage_errors(tmp_path, capsys):
    assert main(["summarize", str(tmp_path / "nope")]) == 2
    assert "no such directory" in capsys.readouterr().err
    assert main(["summarize", str(tmp_path)]) == 2
    assert "no run folders" in capsys.readouterr().err
    assert math.isnan(group_stats([{"config": "x", "config_key": "k", "seed": 1, "status": "failed",
                                     "objective": None}])[0]["stats"]["objective"]["mean"])


def _space_config(name: str, optimizer: str) -> str:
    """batch_small.yaml's design space under another name and optimizer section."""
    from conftest import edited_text

    return edited_text(SMALL.read_text(), {"name: batch_small": f"name: {name}",
                                           "optimizer: {worst_case: false, polish: 1, extremes: {starts: 1, scan: 256}, population: 12, generations: 5, seed: 1}":
                                           f"optimizer: {optimizer}"})


@pytest.mark.slow
def test_seeds_are_ranked_on_the_extremes_pooled_over_the_design_space(tmp_path, capsys):
    """Three seeds of a config whose single-objective searches are tiny (no
    pre-scan, no polish, 4 x 1: poor extremes) and one run of a config of the
    same design space with the pre-scan and the polish: the extremes are pooled
    over the four, every objective is re-expressed on them, and the seeds are
    ranked on that scale; a seed whose own extremes are narrowed so that it
    scores 0 on its own scale is not made the best by it."""
    from optdesign.report.summary import pooled_rows

    poor = _space_config("poor", "{worst_case: false, population: 4, generations: 1, prescan: 0, polish: 0, seed: 1}")
    good = _space_config("good", "{worst_case: false, population: 8, generations: 3, seed: 1}")
    out = tmp_path / "runs"
    for name, text, seeds in (("poor", poor, (1, 2, 3)), ("good", good, (1,))):
        for s in seeds:
            f = RunFolder.create(out, f"{name}-s{s}", text, s, f"k{s}", exact=True)
            f.update_manifest(name=name)
            run_in_folder(parse_config(text, source=f"{name}.yaml"), f, s, pareto=False, reports=False)
    rows = [row_from_folder(f) for f in collect_folders([out])]
    assert len({r["design_space"] for r in rows}) == 1 and len({r["config_key"] for r in rows}) == 2
    res = {r["folder"]: json.loads((Path(r["folder"]) / "results.json").read_text()) for r in rows}
    names = list(next(iter(res.values()))["normalization"])
    lo = {k: min(min(r["normalization"][k]["min"], r["global_indices"][k]) for r in res.values()) for k in names}
    hi = {k: max(max(r["normalization"][k]["max"], r["global_indices"][k]) for r in res.values()) for k in names}
    good_norm = next(r for f, r in res.items() if "good" in f)["normalization"]
    for r in res.values():                          # the poor runs' own extremes lie inside the pooled ones
        if r["config"] == "poor":
            assert any(r["normalization"][k]["max"] - r["normalization"][k]["min"]
                       < 0.9 * (good_norm[k]["max"] - good_norm[k]["min"]) for k in names)

    def on_pool(r):
        f = 0.0
        for k, v in r["normalization"].items():
            t = (r["global_indices"][k] - lo[k]) / (hi[k] - lo[k])
            f += v["weight"] * (1 - t if v["sense"] == "max" else t)
        return f

    pooled = {r["folder"]: r["objective_pooled"] for r in pooled_rows(rows)}
    for f, r in res.items():
        assert pooled[f] == pytest.approx(on_pool(r), rel=1e-12, abs=1e-15)
        assert 0 <= pooled[f] <= sum(v["weight"] for v in r["normalization"].values())
    (g,) = [g for g in group_stats(rows) if g["config"] == "poor"]
    want = min((on_pool(r), r["seed"]) for r in res.values() if r["config"] == "poor")[1]
    assert g["best_seed"] == want

    # narrow the worst seed's own extremes to its optimum: 0 on its own scale, still the worst on the pool's
    worst = max((r for r in res.items() if r[1]["config"] == "poor"), key=lambda fr: on_pool(fr[1]))[0]
    r = res[worst]
    for k, v in r["normalization"].items():
        v["min"] = v["max"] = r["global_indices"][k]
    r["objective"] = 0.0
    (Path(worst) / "results.json").write_text(json.dumps(r))
    rows = [row_from_folder(f) for f in collect_folders([out])]
    (g,) = [g for g in group_stats(rows) if g["config"] == "poor"]
    assert g["best_seed"] == want and g["stats"]["objective"]["min"] == 0.0
    assert main(["summarize", str(out), "--no-plot"]) == 0
    assert "objective_pooled" in capsys.readouterr().out
