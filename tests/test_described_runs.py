"""optdesign run on the Gough-Stewart and Delta optimization configs with a tiny
budget: the runs finish, and the same seed gives the same results (with one
process and with a worker process, which receives the described mechanism by
pickling the config)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from cli_helpers import run_cli_in

ROOT = Path(__file__).resolve().parents[1]


def _tiny(tmp_path, name):
    cfg = yaml.safe_load((ROOT / "configs" / name).read_text())
    cfg["workspace"]["points"] = 64
    # the worst case over W on, as shipped: the compiled pose search (Mechanism.local_values_at); the
    # Gough-Stewart's seed-free extremes multi-start is off (each of its SLSQP trial designs runs a 6-D
    # search: 75 of the 95 s of one tiny run, measured), and so is its polish (SLSQP on finite
    # differences of the 6-D search: 21 of the remaining 44 s); the Delta's runs polish, with one start
    # of the extremes and at most 10 steps of the walk along the singularity wall (300 as shipped)
    gs = name.startswith("gough")
    starts = 0 if gs else 1
    cfg["optimizer"].update(population=6, generations=2, elites=1, polish=0 if gs else 1,
                            extremes={"starts": starts, "scan": 256, "walk": 10},
                            pareto={"algorithms": ["nsga2"], "population": 6, "generations": 2})
    # small proofs and coarse integrals: what is checked here is that the run finishes and repeats
    cfg["checks"] = {"certificate_budget": 400, "integral_tolerance": 0.05, "integral_max_points": 500}
    f = tmp_path / name
    f.write_text(yaml.safe_dump(cfg, sort_keys=False))
    return f


def _results(folder: Path):
    runs = list(folder.iterdir())
    assert len(runs) == 1
    res = json.loads((runs[0] / "results.json").read_text())
    for k in ("wall_time_s",):
        res.pop(k, None)
    pop = (runs[0] / "population.csv").read_text()
    return res, pop


@pytest.mark.slow
@pytest.mark.parametrize("name", ["gough_stewart_opt.yaml", "delta_opt.yaml"])
def test_run_finishes_and_is_reproducible(tmp_path, name):
    f = _tiny(tmp_path, name)
    outs = []
    # the second run (--jobs 2) runs some stages again in this process and the others in a worker
    # process: the same results show both that a repeat in one process and a fresh process agree
    for sub, jobs in (("a", "1"), ("c", "2")):
        rc, out, err = run_cli_in(tmp_path, ["run", str(f), "--out", str(tmp_path / sub), "--quiet", "--jobs", jobs,
                                             "--seed", "3"])
        assert rc == 0, err
        assert "complete" in out
        outs.append(_results(tmp_path / sub))
    assert outs[0] == outs[1]
    for sub in ("a", "c"):
        run = next((tmp_path / sub).iterdir())
        assert (run / "report.html").exists() and not (run / "report-error.txt").exists()
    res = outs[0][0]
    assert res["status"] == "complete" and res["seed"] == 3
    assert all(v == v for v in res["global_indices"].values())  # finite, not NaN


def test_history_csv_quotes_a_unit_with_a_comma():
    """A column whose unit has a comma (an index of mixed units: 'SI, mixed')
    is quoted, so the CSV reads back with its columns (the HTML report reads
    the histories this way)."""
    import csv

    from optdesign.optimize.results import rows_csv
    from optdesign.units import MIXED

    col = f"best_dynamic [{MIXED}]"
    text = rows_csv([{"generation": 1, col: 15.5}, {"generation": 2, col: 0.1}])
    rows = list(csv.reader(text.splitlines()))
    assert rows[0] == ["generation", col]
    assert [float(r[1]) for r in rows[1:]] == [15.5, 0.1]
