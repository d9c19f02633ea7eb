"""The workspace keys of the quadratures (gauss, rqmc, scramblings): one-line
errors naming the key path, and ``optdesign evaluate`` printing each mean
with its error estimate (text within 80 columns, ``--json``
``global_indices_error`` with the indices' keys)."""
from __future__ import annotations

import pytest


def _ws_edit(**changes):
    from conftest import paper_data

    d = paper_data()
    for k, v in changes.items():
        if v is KeyError:
            d["workspace"].pop(k, None)
        else:
            d["workspace"][k] = v
    return d


WS_MISTAKES = [
    ("gauss-with-step", dict(sampling="gauss"), "workspace.step", "not used by sampling 'gauss'"),
    ("gauss-no-nodes", dict(sampling="gauss", step=KeyError), "workspace.points_per_axis", "missing"),
    ("gauss-one-node", dict(sampling="gauss", step=KeyError, points_per_axis=1), "workspace.points_per_axis", ">= 2"),
    ("gauss-too-many", dict(sampling="gauss", step=KeyError, points_per_axis=9000), "workspace.points_per_axis",
     "at most 10,000,000"),
    ("gauss-seed", dict(sampling="gauss", step=KeyError, points_per_axis=8, seed=3), "workspace.seed", "not random"),
    ("rqmc-no-points", dict(sampling="rqmc", step=KeyError), "workspace.points", "missing"),
    ("rqmc-not-power-of-2", dict(sampling="rqmc", step=KeyError, points=100), "workspace.points", "use 64 or 128"),
    ("rqmc-one-scrambling", dict(sampling="rqmc", step=KeyError, points=64, scramblings=1), "workspace.scramblings",
     ">= 2"),
    ("rqmc-nodes", dict(sampling="rqmc", step=KeyError, points=64, points_per_axis=4), "workspace.points_per_axis",
     "not used by sampling 'rqmc'"),
    ("rqmc-too-many", dict(sampling="rqmc", step=KeyError, points=2 ** 21, scramblings=8), "workspace.points",
     "at most 10,000,000"),
    ("grid-scramblings", dict(scramblings=8), "workspace.scramblings", "only sampling 'rqmc'"),
    ("sampling-typo", dict(sampling="gaus"), "workspace.sampling", "gauss"),
    ("adaptive-zero-tolerance", dict(sampling="adaptive", step=KeyError, tolerance=0), "workspace.tolerance",
     "relative tolerance in [1e-10, 0.5], got 0"),
    ("adaptive-negative-tolerance", dict(sampling="adaptive", step=KeyError, tolerance=-0.01), "workspace.tolerance",
     "relative tolerance"),
    ("adaptive-tolerance-too-large", dict(sampling="adaptive", step=KeyError, tolerance=2), "workspace.tolerance",
     "relative tolerance"),
    ("adaptive-tolerance-text", dict(sampling="adaptive", step=KeyError, tolerance="1e-3x"), "workspace.tolerance",
     "expected a number"),
    ("adaptive-tolerance-inf", dict(sampling="adaptive", step=KeyError, tolerance=float("inf")),
     "workspace.tolerance", "finite"),
    ("adaptive-with-step", dict(sampling="adaptive"), "workspace.step", "not used by sampling 'adaptive'"),
    ("adaptive-with-points", dict(sampling="adaptive", step=KeyError, points=100), "workspace.points", "max_points"),
    ("adaptive-few-points", dict(sampling="adaptive", step=KeyError, max_points=10), "workspace.max_points", ">= 1000"),
    ("adaptive-too-many", dict(sampling="adaptive", step=KeyError, max_points=10 ** 8), "workspace.max_points",
     "<= 10000000"),
    ("grid-tolerance", dict(tolerance=1e-3), "workspace.tolerance", "only sampling 'adaptive'"),
    ("gauss-max-points", dict(sampling="gauss", step=KeyError, points_per_axis=8, max_points=5000),
     "workspace.max_points", "only sampling 'adaptive'"),
]


@pytest.mark.parametrize("name,changes,keypath,words", WS_MISTAKES, ids=[m[0] for m in WS_MISTAKES])
def test_sampling_keys_one_line_errors(write_yaml, capsys, name, changes, keypath, words):
    from cli_helpers import run_main

    path = write_yaml(_ws_edit(**changes), f"{name}.yaml")
    rc, out, err = run_main(capsys, ["validate-config", str(path)])
    assert rc == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("optdesign: error: ") and str(path) in lines[0]
    assert f": {keypath}: " in lines[0] and words in lines[0], lines[0]


@pytest.mark.parametrize("changes", [dict(sampling="gauss", step=KeyError, points_per_axis=8),
                                     dict(sampling="rqmc", step=KeyError, points=256, seed=2)])
def test_evaluate_command_prints_the_error_column_and_json(write_yaml, capsys, changes):
    import json

    from cli_helpers import run_main

    path = write_yaml(_ws_edit(**changes), "w.yaml")
    rc, out, err = run_main(capsys, ["evaluate", str(path)])
    assert rc == 0, err
    head = [ln for ln in out.splitlines() if ln.startswith("| design")][0]
    assert [c.strip() for c in head.strip("|").split("|")][:4] == ["design", "index", "mean", "±"]
    row = [ln for ln in out.splitlines() if ln.startswith("| after ") and "stiffness" in ln][0]
    mean, err = row.split("|")[3:5]
    assert 0.34 < float(mean) < 0.37 and 0 < float(err) < 0.01
    assert all(len(ln) <= 80 for ln in out.splitlines() if ln.startswith("|"))
    rc, out, _ = run_main(capsys, ["evaluate", str(path), "--json"])
    data = json.loads(out)
    assert data["error_method"].startswith("|Q_8 - Q_7|" if changes["sampling"] == "gauss" else "standard error")
    for name, d in data["designs"].items():
        assert set(d["global_indices_error"]) == {"dynamic", "stiffness", "isotropy"}
        for k, e in d["global_indices_error"].items():
            assert 0 < e < 0.05 * d[k]["mean"]
