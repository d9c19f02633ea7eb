"""Issue 20, "Crashes, escapes and races": each case failed on the main of that day."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _legs_with_d_bounds(tmp_path) -> Path:
    """configs/p4s_legs.yaml with d free over [0.05, 0.6] m: d > 2 r_a (theta =
    asin(d / 2 r_a)) is impossible geometry for part of the box."""
    text = (ROOT / "configs" / "p4s_legs.yaml").read_text()
    text, n = re.subn(r"^  d:   \{value: 0\.12\}", "  d:   {value: 0.12, bounds: [0.05, 0.6]}", text, flags=re.M)
    assert n == 1
    text = text.replace("step: 0.01", "step: 0.05")
    p = tmp_path / "legs_d.yaml"
    p.write_text(text)
    return p


@pytest.mark.slow
def test_the_optimality_measure_survives_impossible_geometry_next_to_the_design(tmp_path):
    """At d = 2 r_a the model's derivative is not finite (the optimum of a run
    over that box sits there): the measure says so instead of nnls raising on
    NaN, and a design past it is infeasible."""
    from optdesign.config import load_config
    from optdesign.evaluate import Evaluator
    from optdesign.optimize.polish import optimality
    from optdesign.optimize.problem import DesignProblem, index_term
    from optdesign.optimize.report import optimality_lines

    ev = Evaluator.from_config(load_config(_legs_with_d_bounds(tmp_path)))
    X = np.array([ev.vector({"r_a": 0.25, "r_b": 0.71, "d": d, "phi": np.radians(35)}) for d in (0.3, 0.55)])
    r = ev(X)
    assert all(np.isfinite(r["values"][k][0]) and not np.isfinite(r["values"][k][1]) for k in r["values"])
    assert max(c[1] for c in r["constraints"].values()) > 0          # impossible geometry is infeasible
    assert max(c[0] for c in r["constraints"].values()) <= 0
    edge = ev.vector({"r_a": 0.25, "r_b": 0.71, "d": 0.5, "phi": np.radians(35)})
    o = optimality(DesignProblem(ev, [index_term("dynamic", "min")]), edge, ev.free)
    assert o["measurable"] is False and o["converged"] is False and o["kkt_relative"] is None
    json.dumps(o, allow_nan=False)                                   # results.json stays valid JSON
    lines = optimality_lines(None, {"polish": {"optimality": o, "starts": 1, "objective": 1.0}})
    assert any("not measured" in line for line in lines)
    inside = ev.vector({"r_a": 0.25, "r_b": 0.67, "d": 0.12, "phi": np.radians(30)})
    o = optimality(DesignProblem(ev, [index_term("dynamic", "min")]), inside, ev.free)
    assert o["measurable"] is True and np.isfinite(o["kkt_relative"])
