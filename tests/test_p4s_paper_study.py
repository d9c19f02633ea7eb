"""Where the paper's design box decides the answer (optdesign.studies.p4s_paper):
on an exhaustive grid over the assumed bounds (with the constraints) every
index of the 3-P(4S) is best at Table 3's after design, a corner of the box;
a box where that corner is not best, or a config without the fitted W, gets
a note that says so."""
from __future__ import annotations

import numpy as np
import pytest

from optdesign.config import load_config
from optdesign.evaluate import evaluate
from optdesign.studies.p4s_paper import bounds_decide, box_grid_extremes, table3_note

from conftest import CONFIGS, PAPER


@pytest.fixture(scope="module")
def paper_facts():
    cfg = load_config(PAPER)
    return cfg, bounds_decide(cfg, points_per_axis=21)


def test_after_design_is_the_corner_where_every_index_is_best(paper_facts):
    cfg, f = paper_facts
    assert f["corner"] == {"r_a": "lower", "r_b": "upper", "phi": "upper"}
    assert f["decided_by_box"] and all(f["best_everywhere"].values())
    after = evaluate(cfg, [cfg.design("after")], errors=False)
    g = f["grid"]
    assert g["designs"] == 21 ** 3 and 0.8 * g["designs"] < g["feasible"] < g["designs"]
    for k in cfg.indices:
        value, where = g["best"][k]
        assert value == after.summary[k]["mean"][0]
        assert where == pytest.approx({"r_a": 0.21, "r_b": 0.71, "phi": np.radians(35.0)}, rel=1e-12)
        # the worst feasible design is far worse: the indices do not trade off inside this box
        worst = g["worst"][k][0]
        assert (worst > 5 * value) if cfg.indices[k].sense == "min" else (worst < 0.2 * value)


def test_the_grid_is_exhaustive_every_feasible_design_is_no_better(paper_facts):
    """An independent pass over a finer random sample of the box finds nothing
    better than the corner (the grid's claim is not an artefact of its spacing)."""
    cfg, f = paper_facts
    from optdesign.evaluate import Evaluator

    ev = Evaluator.from_config(cfg)
    rng = np.random.default_rng(7)
    X = ev.xl + (ev.xu - ev.xl) * rng.random((20000, 3))
    with np.errstate(all="ignore"):
        r = ev(X)
    feas = np.all([c <= 0 for c in r["constraints"].values()], axis=0)
    for k, spec in cfg.indices.items():
        v = r["values"][k][feas]
        best = f["values"][k]
        assert np.all(v >= best) if spec.sense == "min" else np.all(v <= best)


@pytest.mark.slow
def test_table3_note_says_fit_and_checks(paper_facts):
    cfg, f = paper_facts
    text = table3_note(cfg, f)
    assert "follows from the assumed bounds" in text
    assert "a fit, not a check" in text
    assert "Independent checks of the paper" in text and "f_min = 0.137" in text
    assert "dynamic index (+3.37 %" in text and "dynamic -19.22 %" in text
    # the fitted values agree on the 11 x 11 grid, the integral over W does not
    assert "stiffness (+0.02 %)" in text and "isotropy (+0.02 %)" in text
    assert "stiffness +1.38 %" in text


def test_note_when_the_box_does_not_decide(edited_copy):
    """With r_b in [0.71, 0.75] the after design is still a corner (r_b at its
    lower bound) but no longer the best: the note says the bounds do not decide."""
    path = edited_copy(PAPER, {"r_b: {value: 0.67, bounds: [0.63, 0.71]}": "r_b: {value: 0.72, bounds: [0.71, 0.75]}"},
                       "shifted.yaml")
    cfg = load_config(path)
    f = bounds_decide(cfg, points_per_axis=9)
    assert f["corner"] == {"r_a": "lower", "r_b": "lower", "phi": "upper"}
    assert not f["decided_by_box"]
    assert f["grid"]["best"]["stiffness"][1]["r_b"] == pytest.approx(0.75)
    text = table3_note(cfg, f)
    assert "do not decide the answer alone" in text and "follows from the assumed bounds" not in text


def test_note_without_the_fitted_w_and_for_other_configs(edited_copy):
    path = edited_copy(PAPER, {"z: 0.57}": "z: 0.56}"}, "z056.yaml")
    text = table3_note(load_config(path), None)
    assert "follows from the assumed bounds" in text and "a fit, not a check" not in text
    assert table3_note(load_config(CONFIGS / "p4s_wide.yaml")) is None     # the after design is inside its box
    assert table3_note(load_config(CONFIGS / "sps_s_opt.yaml")) is None


def test_box_grid_extremes_of_a_config_without_a_corner_optimum():
    cfg = load_config(CONFIGS / "sps_s_opt.yaml")
    g = box_grid_extremes(cfg, points_per_axis=3)
    assert g["designs"] == 81 and g["feasible"] > 0
    for k in cfg.indices:
        assert g["best"][k][0] >= g["worst"][k][0]      # all maximized
