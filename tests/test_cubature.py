"""Adaptive cubature of the mean over W (optdesign/cubature.py, ``sampling: adaptive``):
the rules are exact to their degree, the stated error covers the distance to a
fine reference integral for regular 3-P(4S) designs, and a design singular
inside W is reported unbounded, never as a finite mean."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from optdesign.cubature import gauss_kronrod, genz_malik, integrate
from optdesign.workspace import WorkspaceSpec, sample

#: the design of issue 19 whose cond_F is 999.99 at the 121 grid points and unbounded between them
SINGULAR = {"r_a": 0.2846, "r_b": 0.6462, "phi": math.radians(27.91)}


def _monomial_mean(a) -> float:
    """The mean of prod x_i^a_i over [-1, 1]^d."""
    return float(np.prod([1.0 / (k + 1) if k % 2 == 0 else 0.0 for k in a]))


@pytest.mark.parametrize("d", [2, 3, 6])
def test_genz_malik_is_exact_to_degree_7_and_its_embedded_rule_to_5(d):
    X, w7, w5 = genz_malik(d)
    assert X.shape[0] == 2 ** d + 2 * d * d + 2 * d + 1
    rng = np.random.default_rng(d)
    for deg in range(9):
        for _ in range(6):
            a = np.zeros(d, int)
            for i in rng.integers(0, d, deg):
                a[i] += 1
            v = np.prod(X ** a, axis=1)
            exact = _monomial_mean(a)
            if deg <= 7:
                assert w7 @ v == pytest.approx(exact, abs=1e-13), a
            if deg <= 5:
                assert w5 @ v == pytest.approx(exact, abs=1e-13), a
    # degree 8 is beyond the rule: x1^8 is not integrated exactly
    a = np.zeros(d, int)
    a[0] = 8
    assert abs(w7 @ np.prod(X ** a, axis=1) - _monomial_mean(a)) > 1e-4


def test_gauss_kronrod_pair():
    x, wk, wg = gauss_kronrod()
    for k in range(23):
        assert wk @ x[:, 0] ** k == pytest.approx(_monomial_mean([k]), abs=1e-14), k
    for k in range(14):
        assert wg @ x[:, 0] ** k == pytest.approx(_monomial_mean([k]), abs=1e-14), k
    assert abs(wg @ x[:, 0] ** 14 - _monomial_mean([14])) > 1e-6


def test_mean_over_a_reachable_part_of_a_disc():
    """A cylinder (polar coordinates with the Jacobian r) with a reach boundary
    inside it: the mean of r^2 over the reachable disc of radius 0.3 is 0.045,
    the reachable share 0.36; the stated error covers the distance."""
    spec = WorkspaceSpec(type="cylinder", axes={"z": (0.5, 0.5)}, radius=0.5, center=(0.1, 0.0),
                         sampling="adaptive", tolerance=1e-5)

    def local(X):
        r2 = (X[:, 0] - 0.1) ** 2 + X[:, 1] ** 2
        return {"a": r2[None, :]}, (r2 < 0.09)[None, :]

    res = integrate(local, spec, ("x", "y", "z"), 1, ["a"], 1e-5, 200_000)
    assert res.status["a"][0] == "converged"
    assert abs(res.mean["a"][0] - 0.045) <= res.error["a"][0] <= 1e-5 * 0.045
    assert res.reachable_fraction[0] == pytest.approx(0.36, rel=1e-4)


def test_a_1d_workspace_uses_gauss_kronrod():
    spec = WorkspaceSpec(type="box", axes={"x": (0.0, 2.0), "y": (1.0, 1.0)}, sampling="adaptive", tolerance=1e-8)
    res = integrate(lambda X: ({"a": np.exp(X[:, 0])[None, :]}, np.ones((1, X.shape[0]), bool)),
                    spec, ("x", "y"), 1, ["a"], 1e-8, 10_000)
    exact = (math.exp(2.0) - 1.0) / 2.0
    assert res.status["a"][0] == "converged"
    assert abs(res.mean["a"][0] - exact) <= res.error["a"][0] <= 1e-8 * exact


def _adaptive(cfg, tolerance, **kw):
    spec = dataclasses.replace(cfg.workspace, sampling="adaptive", step=None, tolerance=tolerance, **kw)
    from optdesign.evaluate import workspace_of

    return sample(spec, workspace_of(cfg).names)


@pytest.mark.slow
@pytest.mark.parametrize("tolerance", [1e-3, 1e-5])
def test_the_stated_error_covers_a_fine_reference_integral(paper_config, tolerance):
    """Regular designs (before, after and two inside the box): the distance of
    the adaptive mean to a 401 x 401 Gauss-Legendre integral is within the
    stated error, and the stated error within the tolerance."""
    from optdesign.evaluate import evaluate, workspace_of

    cfg = paper_config
    designs = [cfg.design("before"), cfg.design("after"),
               {**cfg.design("before"), "r_a": 0.27, "r_b": 0.65, "phi": math.radians(33.0)},
               {**cfg.design("before"), "r_a": 0.23, "r_b": 0.69, "phi": math.radians(26.0)}]
    ref_ws = sample(dataclasses.replace(cfg.workspace, sampling="gauss", step=None, points_per_axis=401),
                    workspace_of(cfg).names)
    ref = evaluate(cfg, designs, ref_ws, errors=False)
    ev = evaluate(cfg, designs, _adaptive(cfg, tolerance))
    for k in cfg.indices:
        assert list(ev.status[k]) == ["converged"] * 4
        dist = np.abs(ev.summary[k]["mean"] - ref.summary[k]["mean"])
        assert np.all(dist <= ev.error[k]), (k, dist, ev.error[k])
        assert np.all(ev.error[k] <= tolerance * np.abs(ev.summary[k]["mean"]))
    assert np.all(ev.reachable_fraction == 1.0)


def test_a_singular_design_is_unbounded_not_a_finite_mean(paper_config):
    """cond_F -> inf on a curve inside W: the isotropy and dynamic integrals are
    unbounded (mean inf, error inf); the stiffness lambda_min(K) -> 0 there stays
    a bounded, converged integral; the Evaluator makes the design infeasible."""
    from optdesign.evaluate import Evaluator, evaluate

    cfg = paper_config
    ws = _adaptive(cfg, 1e-3, max_points=20_000)
    ev = evaluate(cfg, [{**cfg.design("after"), **SINGULAR}, cfg.design("after")], ws)
    for k in ("dynamic", "isotropy"):
        assert list(ev.status[k]) == ["unbounded", "converged"], (k, ev.status[k])
        assert ev.summary[k]["mean"][0] == np.inf and ev.error[k][0] == np.inf
        assert np.isfinite(ev.summary[k]["mean"][1])
        assert ev.summary[k]["max"][0] > 1e6      # the singular poses it found
    assert ev.status["stiffness"][0] == "converged" and np.isfinite(ev.summary["stiffness"]["mean"][0])
    evaluator = Evaluator.from_config(cfg, ws)
    r = evaluator(np.array([[SINGULAR[k] for k in evaluator.free], [cfg.design("after")[k] for k in evaluator.free]]))
    assert r["constraints"]["finite"][0] == 1.0 and r["constraints"]["singularity"][0] > 0
    assert r["constraints"]["finite"][1] == 0.0 and r["constraints"]["reach"][1] == 0.0


def test_a_budget_too_small_is_not_converged_and_says_so(paper_config):
    """A tolerance the budget cannot reach: the status says not_converged, the
    mean stays finite with its (larger than requested) error."""
    from optdesign.evaluate import evaluate

    cfg = paper_config
    ev = evaluate(cfg, [cfg.design("before")], _adaptive(cfg, 1e-10, max_points=1000))
    assert ev.status["dynamic"][0] == "not_converged"
    assert np.isfinite(ev.summary["dynamic"]["mean"][0])
    assert ev.error["dynamic"][0] > 1e-10 * ev.summary["dynamic"]["mean"][0]


def test_evaluate_command_shows_unbounded(write_yaml, capsys):
    import json

    from cli_helpers import run_main
    from conftest import paper_data

    d = paper_data()
    d["workspace"].pop("step")
    d["workspace"].update(sampling="adaptive", tolerance=1e-3, max_points=20_000)
    d["designs"]["singular"] = {"r_a": SINGULAR["r_a"], "r_b": SINGULAR["r_b"], "L": 0.38, "d": 0.12, "phi": 27.91}
    path = write_yaml(d, "adaptive.yaml")
    rc, out, err = run_main(capsys, ["evaluate", str(path), "--design", "singular", "--design", "after"])
    assert rc == 0, err
    rows = [ln for ln in out.splitlines() if ln.startswith("| singular ")]
    assert any("isotropy" in r and "unbounded" in r for r in rows), out
    assert all(len(ln) <= 80 for ln in out.splitlines() if ln.startswith("|"))
    rc, out, _ = run_main(capsys, ["evaluate", str(path), "--json"])
    data = json.loads(out)
    assert data["designs"]["singular"]["global_indices_status"]["isotropy"] == "unbounded"
    assert data["designs"]["after"]["global_indices_status"]["isotropy"] == "converged"
    assert data["error_method"].startswith("adaptive cubature")


def test_reported_designs_get_their_integral_beside_the_grid(paper_config):
    """results.json["integrals"]: the optimum, the named designs and the
    extremes, each with the grid's mean and error beside the integral; a
    singular extreme is unbounded (null mean) and results.md says so."""
    from optdesign.evaluate import Evaluator, workspace_of
    from optdesign.optimize.integrals import integrals_of_reported
    from optdesign.report.integrals import integral_lines

    cfg = paper_config
    after, sing = cfg.design("after"), {**cfg.design("after"), **SINGULAR}
    results = {"optimum": after,
               "designs": {n: {"parameters": cfg.design(n)} for n in ("before", "after")},
               "normalization": {"dynamic": {"min_design": after, "max_design": sing}}}
    rec = integrals_of_reported(cfg.checks, Evaluator.from_config(cfg, workspace_of(cfg)), cfg.units(), results)
    assert set(rec["designs"]) == {"optimum", "before", "after", "dynamic.min", "dynamic.max"}
    opt = rec["designs"]["optimum"]
    for k in cfg.indices:
        q, i = opt["quadrature"][k], opt["integral"][k]
        assert i["status"] == "converged" and i["error"] <= rec["tolerance"] * abs(i["mean"])
        assert abs(q["mean"] - i["mean"]) <= q["error"]          # the grid's estimate covers its distance
    top = rec["designs"]["dynamic.max"]
    assert top["integral"]["dynamic"]["status"] == "unbounded" and top["integral"]["dynamic"]["mean"] is None
    assert np.isfinite(top["quadrature"]["dynamic"]["mean"])   # the grid's artifact, kept beside it
    text = "\n".join(integral_lines(cfg.units(), {"integrals": rec}))
    assert "| dynamic.max | dynamic [kg] |" in text and "unbounded" in text and "`dynamic.max`" in text
    # a config whose sampling is adaptive needs no second record
    assert integrals_of_reported(cfg.checks, Evaluator.from_config(cfg, _adaptive(cfg, 1e-3)), cfg.units(), results) is None


def test_a_cylinder_with_a_height_range():
    """Three polar coordinates (Genz-Malik in 3-D): the mean of x^2 z over the
    disc of radius 2 times z in [1, 3] is (R^2 / 4) * 2 = 2."""
    spec = WorkspaceSpec(type="cylinder", axes={"z": (1.0, 3.0)}, radius=2.0, sampling="adaptive", tolerance=1e-9)
    res = integrate(lambda X: ({"a": (X[:, 0] ** 2 * X[:, 2])[None, :]}, np.ones((1, X.shape[0]), bool)),
                    spec, ("x", "y", "z"), 1, ["a"], 1e-9, 100_000)
    assert res.status["a"][0] == "converged" and res.reachable_fraction[0] == 1.0
    assert abs(res.mean["a"][0] - 2.0) <= res.error["a"][0] <= 2e-9
