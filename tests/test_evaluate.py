"""optdesign.evaluate: the one place that builds mechanisms; the Evaluator the
optimizer calls (design vectors -> index values, extra objectives and
constraint quantities in one pass), checked against quantities computed here
independently from the mechanism's public numpy methods and optdesign.linalg."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from optdesign import fast
from optdesign.config import ConfigError, load_config, parse_config
from optdesign.evaluate import Evaluator, build, evaluate, index_requests, mechanism_class, workspace_of
from optdesign.indices import global_summary, local_index
from optdesign.linalg import cond_2
from optdesign.mechanisms.base import IndexRequest

from conftest import CONFIGS, DATA


def _random_vectors(ev: Evaluator, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return ev.xl + (ev.xu - ev.xl) * rng.random((n, len(ev.free)))


def test_build_and_class():
    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    assert mechanism_class(cfg).name == "p4s"
    m = build(cfg, "after")
    assert float(m.r_a) == pytest.approx(0.21) and float(m.m_platform) == 4.16
    m2 = build(cfg, {**cfg.design("after"), "r_b": 0.7})
    assert float(m2.r_b) == 0.7


def test_index_requests_are_plain_data():
    cfg = load_config(CONFIGS / "sps_s_opt.yaml")
    reqs = index_requests(cfg)
    assert [r.name for r in reqs] == list(cfg.indices)
    st = [r for r in reqs if r.kind == "stiffness"][0]
    assert st == IndexRequest("stiffness", "stiffness", "lambda_min_K", (("k", 1000.0),))
    assert st.option_dict() == {"k": 1000.0}


def test_vectors_and_designs_round_trip():
    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    ev = Evaluator.from_config(cfg)
    assert ev.free == ["r_a", "r_b", "phi"]
    np.testing.assert_allclose(ev.xl, [0.21, 0.63, np.radians(25)])
    X = _random_vectors(ev, 5)
    d = ev.designs(X)
    assert set(d) == set(cfg.design_variables) and np.all(d["L"] == 0.38)
    for i in range(5):
        np.testing.assert_array_equal(ev.vector({k: v[i] for k, v in d.items()}), X[i])


def test_values_equal_evaluate_and_constraints_equal_independent_ones():
    """At the samples (worst_case off, no margin) the constraints are the
    sampled ones; with the defaults (the worst case over W, margin 0.1 %)
    the singularity constraint is never below them."""
    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    cfg_wc = load_config(CONFIGS / "p4s_paper.yaml")
    cfg.optimizer = dataclasses.replace(cfg.optimizer, worst_case=False, constraint_margin=0.0)
    ev = Evaluator.from_config(cfg)
    X = _random_vectors(ev, 12, seed=3)
    out = ev(X)
    out_wc = Evaluator.from_config(cfg_wc)(X)
    assert ev.constraint_names == ["reach", "singularity", "finite"]
    e2 = evaluate(cfg, ev.designs(X))
    for k in cfg.indices:
        np.testing.assert_array_equal(out["values"][k], e2.summary[k]["mean"])
    # independently: the numpy model's reachability and its Jacobian's 2-norm...
    # the config's isotropy index is the Frobenius condition number: its max over W
    mech = mechanism_class(cfg)(**{**cfg.parameters, **{k: v[:, None] for k, v in ev.designs(X).items()}})
    ws = workspace_of(cfg)
    with fast.disabled(), np.errstate(all="ignore"):
        reach = mech.reachable(ws.X)
        from optdesign.linalg import cond_fro

        cf = cond_fro(mech.jacobian(ws.X))
    np.testing.assert_array_equal(out["reachable_fraction"], reach.mean(axis=-1))
    np.testing.assert_array_equal(out["constraints"]["reach"], 1 - reach.mean(axis=-1))
    cmax = np.max(np.where(reach, cf, -np.inf), axis=-1)
    ok = np.isfinite(cmax)
    np.testing.assert_allclose(out["constraints"]["singularity"][ok], cmax[ok] / cfg.optimizer.singularity_threshold - 1,
                               rtol=1e-12)
    assert np.all(out["constraints"]["finite"] == 0.0)
    assert np.all(out_wc["constraints"]["singularity"][ok] >= cmax[ok] / 999.0 - 1 - 1e-12)
    np.testing.assert_array_equal(out_wc["constraints"]["reach"], out["constraints"]["reach"])


def test_worst_conditioning_without_an_isotropy_index():
    """A config without an isotropy index: the singularity constraint comes from
    cond_2(J) over the reachable points (0 where a design reaches none),
    computed in the same pass, and the hidden request is not among the values."""
    cfg = parse_config((DATA / "p4s_small.yaml").read_text().replace(
        "indices: {dynamic: {}, stiffness: {}, isotropy: {}}", "indices: {dynamic: {}, stiffness: {}}").replace(
        "  before: {dynamic: 29.9205, stiffness: 0.1373, isotropy: 10.0075}\n  after: {dynamic: 15.2434, stiffness: 0.3522, isotropy: 4.5370}",
        "  before: {dynamic: 29.9205}").replace("optimizer: {worst_case: false, ",
                                             "optimizer: {worst_case: false, constraint_margin: 0, "),
        "p4s_small.yaml")
    assert "isotropy" not in cfg.indices
    ev = Evaluator.from_config(cfg)
    X = np.vstack([_random_vectors(ev, 6, seed=5), [[0.01, 0.02, 0.3]]])   # the last reaches nothing
    out = ev(X)
    assert set(out["values"]) == {"dynamic", "stiffness"}
    mech = mechanism_class(cfg)(**{**cfg.parameters, **{k: v[:, None] for k, v in ev.designs(X).items()}})
    ws = workspace_of(cfg)
    with fast.disabled(), np.errstate(all="ignore"):
        reach = mech.reachable(ws.X)
        c = cond_2(mech.jacobian(ws.X))
    cmax = np.max(np.where(reach, c, 0.0), axis=-1)
    assert cmax[-1] == 0.0 and out["reachable_fraction"][-1] == 0.0
    want = np.where(np.isfinite(cmax), cmax / cfg.optimizer.singularity_threshold - 1, 1.0)
    np.testing.assert_allclose(out["constraints"]["singularity"], want, rtol=1e-12)
    assert out["constraints"]["finite"][-1] == 1.0


def test_compiled_and_numpy_paths_agree():
    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    ev = Evaluator.from_config(cfg)
    X = _random_vectors(ev, 20, seed=8)
    a = ev(X)
    with fast.disabled():
        b = ev(X)
    for part in ("values", "constraints"):
        for k in a[part]:
            np.testing.assert_allclose(a[part][k], b[part][k], rtol=1e-12, atol=0, err_msg=k)
    np.testing.assert_array_equal(a["reachable_fraction"], b["reachable_fraction"])


def test_extra_objectives_come_from_the_mechanism():
    cfg = load_config(CONFIGS / "p4s_tradeoff.yaml")
    ev = Evaluator.from_config(cfg)
    assert set(ev.extra) == {"base_radius"} and ev.extra["base_radius"].sense == "min"
    X = _random_vectors(ev, 4)
    out = ev(X)
    np.testing.assert_array_equal(out["values"]["base_radius"], ev.designs(X)["r_b"])
    assert ev.extra_range("base_radius", {"r_b": (0.55, 0.75)}) == (0.55, 0.75)
    with pytest.raises(ConfigError, match="extra_objectives"):
        parse_config((CONFIGS / "p4s_tradeoff.yaml").read_text().replace("[base_radius]", "[waist]"), "t.yaml")


def test_stroke_limits_from_inverse_kinematics():
    text = (DATA / "p4s_small.yaml").read_text().replace(
        "optimizer: {", "optimizer: {stroke_limits: [0.40, 0.45], ")
    cfg = parse_config(text.replace("worst_case: false, ", "worst_case: false, constraint_margin: 0, "), "s.yaml")
    ev = Evaluator.from_config(cfg)
    assert ev.constraint_names[-2:] == ["stroke_low", "stroke_high"]
    X = _random_vectors(ev, 5, seed=2)
    out = ev(X)
    mech = mechanism_class(cfg)(**{**cfg.parameters, **{k: v[:, None] for k, v in ev.designs(X).items()}})
    with fast.disabled(), np.errstate(all="ignore"):
        Q = mech.inverse(workspace_of(cfg).X)
    np.testing.assert_allclose(out["constraints"]["stroke_low"], 0.40 - np.nanmin(Q, axis=(-1, -2)), rtol=0, atol=1e-15)
    np.testing.assert_allclose(out["constraints"]["stroke_high"], np.nanmax(Q, axis=(-1, -2)) - 0.45, rtol=0, atol=1e-15)
    # the worst case over W (no margin): never below the samples, and at the extreme stroke of a dense grid
    wide = parse_config(text.replace("[0.40, 0.45]", "[0.0, 1.0]").replace("optimizer: {", "optimizer: {constraint_margin: 0, "),
                        "s.yaml")
    ev_wc = Evaluator.from_config(wide)
    out_wc = ev_wc(X)
    spec = ev_wc.workspace.spec
    g = np.linspace(-1, 1, 201)
    a, b = np.meshgrid(g, g, indexing="ij")
    P = np.stack([spec.axes["x"][0] + (a.ravel() + 1) / 2 * (spec.axes["x"][1] - spec.axes["x"][0]),
                  spec.axes["y"][0] + (b.ravel() + 1) / 2 * (spec.axes["y"][1] - spec.axes["y"][0]),
                  np.full(a.size, spec.axes["z"][0])], axis=1)
    with np.errstate(all="ignore"):
        Qd = mech.inverse(P)
    searched = (out_wc["constraints"]["singularity"] <= 0) & (out_wc["constraints"]["reach"] <= 0)
    assert searched.any()
    hi_wc = out_wc["constraints"]["stroke_high"] + 1.0
    assert np.all(hi_wc >= np.nanmax(Q, axis=(-1, -2)) - 1e-15)
    np.testing.assert_allclose(hi_wc[searched], np.nanmax(Qd, axis=(-1, -2))[searched], rtol=1e-6)


def test_keep_local_gives_the_local_values_behind_the_summary():
    cfg = load_config(CONFIGS / "cpr_rrr.yaml")
    names = [n for n in cfg.designs]
    e = evaluate(cfg, [cfg.design(n) for n in names], keep_local=True)
    mech = mechanism_class(cfg)(**{**cfg.parameters, **{k: np.array([cfg.design(n)[k] for n in names])[:, None]
                                                       for k in cfg.design_variables}})
    with np.errstate(all="ignore"):
        J = mech.jacobian(e.workspace.X)
    for k, spec in cfg.indices.items():
        vals = local_index(spec.kind, J=J, convention=spec.convention, options=spec.options)
        want = global_summary(np.broadcast_to(vals, e.reachable.shape), e.reachable)
        np.testing.assert_allclose(e.summary[k]["mean"], want["mean"], rtol=1e-13)
        np.testing.assert_array_equal(np.isnan(e.local[k]), ~e.reachable)


def test_no_free_variable_is_a_config_error():
    cfg = load_config(CONFIGS / "cpr_rrr.yaml")
    with pytest.raises(ConfigError, match="no free design variable"):
        Evaluator.from_config(cfg)
