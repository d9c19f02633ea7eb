"""optdesign.batch.summary: the rows read back from run folders, the
statistics across seeds against the CSV a user reads, and the summarize
command's errors."""
from __future__ import annotations

import csv
import math
import re
import shutil

import numpy as np
import pytest

from optdesign.batch.summary import collect_folders, group_stats, row_from_folder
from optdesign.batch.tasks import plan
from optdesign.cli import main
from optdesign.config import parse_config
from optdesign.optimize.pipeline import Interrupted, run_pipeline
from optdesign.runs import RunFolder

from conftest import BATCH_SMALL as SMALL


def test_summary_statistics_match_the_rows(small_batches, tmp_path):
    tasks, root, rows1, _ = small_batches
    # an interrupted third run shows up in the table but not in the statistics
    out = tmp_path / "runs"
    shutil.copytree(root / "jobs1", out)
    t3 = plan([str(SMALL)], seeds=[3])[0]
    folder = RunFolder.create(out, t3.folder_name, t3.config_text, t3.seed, t3.key, exact=True)
    folder.update_manifest(name=t3.name)
    with pytest.raises(Interrupted):
        run_pipeline(parse_config(t3.config_text), folder, t3.seed, stop_after=2)

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
