"""Derivatives of the global indices with respect to the design variables
(optdesign/gradients.py) against things they do not share code with.

* The AD route (CasADi through the closure equations of p4s, 3-SPS-S,
  2-CPR/RRR and UPS+UPR+S) against central differences of the Evaluator
  (the compiled path) at random interior designs.
* The fallback of a described mechanism (central differences of its own
  compiled kernel) against the hand-written 3-P(4S)'s AD derivatives: the same
  mechanism written twice (configs/p4s_legs.yaml and configs/p4s_paper.yaml).
* Each index's closed-form matrix derivative against central differences of
  the index functions of optdesign.indices (singular values by LAPACK).
* The smooth constraints describe the Evaluator's feasible set: the largest
  per-point conditioning constraint is log(max cond / threshold).

Tolerance: 1e-6 of the largest derivative component of the index (the
central differences here have truncation and round-off errors of about
1e-8 relative at these steps).
"""
from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS

from optdesign import worstcase
from optdesign.config import load_config
from optdesign.evaluate import Evaluator
from optdesign.gradients import derivatives
from optdesign.local_derivatives import local_derivative
from optdesign.indices import local_index

RTOL = 1e-6


def _central(ev, X, h_rel=1e-5):
    """Richardson-extrapolated central differences of the Evaluator's values, (D, n) per value."""
    D, n = X.shape
    h = h_rel * (ev.xu - ev.xl)
    out = {}
    cols = []
    for j in range(n):
        for s in (1, -1, 2, -2):
            Y = X.copy()
            Y[:, j] += s * h[j]
            cols.append(Y)
    r = ev(np.concatenate(cols))["values"]
    for k, v in r.items():
        v = v.reshape(n, 4, D)
        g1 = (v[:, 0] - v[:, 1]) / (2 * h[:, None])
        g2 = (v[:, 2] - v[:, 3]) / (4 * h[:, None])
        out[k] = ((4 * g1 - g2) / 3).T
    return out


def _designs(ev, seed, k=3):
    rng = np.random.default_rng(seed)
    return ev.xl + (ev.xu - ev.xl) * (0.15 + 0.7 * rng.random((k, len(ev.free))))


@pytest.mark.parametrize("name", ["p4s_paper.yaml", "p4s_wide.yaml", "sps_s_opt.yaml", "cpr_rrr_opt.yaml",
                                  "ups_upr_s_opt.yaml"])
def test_ad_derivatives_equal_central_differences(name):
    ev = Evaluator.from_config(load_config(CONFIGS / name))
    X = _designs(ev, 7)
    d = derivatives(ev, X)
    assert d.route == "ad", d.reason
    ref = ev(X)["values"]
    fd = _central(ev, X)
    for k in ev.index_names:
        assert np.allclose(d.values[k], ref[k], rtol=1e-12, atol=0), k     # the values are the Evaluator's
        scale = np.max(np.abs(fd[k]), axis=1, keepdims=True)
        assert np.all(scale > 0)
        err = np.max(np.abs(d.grads[k] - fd[k]) / scale)
        assert err < RTOL, (name, k, err)


def test_a_described_mechanism_falls_back_to_checked_differences_that_equal_the_hand_written_ad():
    legs = Evaluator.from_config(load_config(CONFIGS / "p4s_legs.yaml"))
    paper = Evaluator.from_config(load_config(CONFIGS / "p4s_paper.yaml"))
    assert legs.free == paper.free
    X = _designs(paper, 11)
    fd = derivatives(legs, X)
    assert fd.route == "fd" and "no CasADi model" in fd.reason
    ad = derivatives(paper, X)
    assert ad.route == "ad"
    for k in paper.index_names:
        scale = np.max(np.abs(ad.grads[k]), axis=1, keepdims=True)
        assert np.max(np.abs(fd.grads[k] - ad.grads[k]) / scale) < RTOL, k
        # the fallback's own error estimate (steps h and 2h) is small and does bound the difference
        assert np.all(fd.fd_error[k] <= 1e-6 * scale)
        assert np.allclose(fd.values[k], ad.values[k], rtol=1e-10)


CASES = [("dynamic", None, {}), ("stiffness", "lambda_min_K", {"k": 2.0}), ("stiffness", "sqrt_lambda_min_K", {}),
         ("isotropy", "frobenius", {}), ("isotropy", "two_norm", {}), ("dexterity", "plain", {}),
         ("dexterity", "normalized", {}), ("manipulability", None, {}), ("driving", None, {}),
         ("axis_stiffness", None, {"axis": 1, "k": 3.0})]


@pytest.mark.parametrize("kind, convention, options", CASES)
def test_each_index_derivative_from_its_matrix(kind, convention, options):
    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 3, 3)) + 2 * np.eye(3)          # (well conditioned, distinct singular values)
    dA = rng.normal(size=(6, 3, 3, 2))
    v, g = local_derivative(kind, convention, options, A, dA, A, dA)
    assert np.allclose(v, local_index(kind, J=A, M=A, convention=convention, options=options), rtol=1e-12)
    h = 1e-6
    for p in range(2):
        f = [local_index(kind, J=A + s * h * dA[..., p], M=A + s * h * dA[..., p], convention=convention,
                         options=options) for s in (1, -1)]
        fd = (f[0] - f[1]) / (2 * h)
        assert np.allclose(g[..., p], fd, rtol=1e-6, atol=1e-9 * np.max(np.abs(fd))), (kind, convention, p)


def test_the_smooth_conditioning_constraint_is_the_evaluators():
    for name in ("p4s_paper.yaml", "sps_s_opt.yaml"):
        ev = Evaluator.from_config(load_config(CONFIGS / name))
        X = _designs(ev, 5, 6)
        d = derivatives(ev, X)
        g = ev(X)["constraints"]["singularity"]
        # per point log(cond / T) and, with the worst case over W (the default), at the local maximum of each
        # hill of W the search climbed, largest first; the largest value is log of the Evaluator's max cond / T
        assert np.allclose(np.max(d.constraints["singularity"], axis=1), np.log1p(g), rtol=1e-10, atol=1e-12)
        assert ev.worst_case
        k = min(worstcase.STARTS, ev.workspace.n)
        assert d.constraints["singularity"].shape == (len(X), ev.workspace.n + k)
        hills = d.constraints["singularity"][:, ev.workspace.n:]
        assert np.all(np.diff(hills, axis=1) <= 0)
        assert np.allclose(hills[:, 0], np.log1p(g), rtol=1e-10, atol=1e-12)


def test_local_derivatives_of_non_finite_or_singular_matrices_are_nan():
    """A NaN Jacobian (an unreachable pose) or an exactly singular one gives
    NaN values and derivatives, never a LinAlgError (LAPACK's SVD does not
    converge on NaN)."""
    rng = np.random.default_rng(0)
    J = rng.normal(size=(4, 3, 3))
    dJ = rng.normal(size=(4, 3, 3, 2))
    J[1] = np.nan
    J[2] = 0.0
    for kind, conv in (("isotropy", "two_norm"), ("isotropy", "frobenius"), ("stiffness", None),
                       ("manipulability", None)):
        v, g = local_derivative(kind, conv, {}, J, dJ, J, dJ)
        assert np.all(np.isfinite(v[[0, 3]])) and np.all(np.isfinite(g[[0, 3]])), kind
        assert np.all(np.isnan(v[1])) and np.all(np.isnan(g[1])), kind


# ---------------------------------------------------------------------- values only, compiled path
def test_values_only_from_the_compiled_path_equal_the_numpy_matrices_to_round_off():
    """SLSQP's values-only calls take the engine's local values (W and the
    hills' poses, optdesign.gradients._compiled_values); with the engine off
    the same call takes the numpy matrices.  Random designs of the paper's
    box, the worst case over W on: the index means, the singularity rows (W
    and the hills) and the reachable fraction agree to 1e-12 relative, the
    shapes (no derivative columns) the same."""
    from optdesign import fast
    from optdesign.evaluate import workspace_of
    from optdesign.gradients import _compiled_values

    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    assert ev.worst_case
    rng = np.random.default_rng(7)
    X = ev.xl + (ev.xu - ev.xl) * rng.random((6, len(ev.xl)))
    hills = []
    for x in X:
        assert _compiled_values(ev, x[None]) is not None       # the compiled path answers here
        got = derivatives(ev, x[None], "auto", values_only=True)
        with fast.disabled():
            assert _compiled_values(ev, x[None]) is None
            ref = derivatives(ev, x[None], "auto", values_only=True)
        assert got.route == ref.route == "ad"
        assert set(got.values) == set(ref.values) and set(got.constraints) == set(ref.constraints)
        for k in ref.values:
            assert got.grads[k].shape == ref.grads[k].shape
            np.testing.assert_allclose(got.values[k], ref.values[k], rtol=1e-12, atol=0)
        for k in ref.constraints:
            assert got.constraints[k].shape == ref.constraints[k].shape
            assert got.constraint_grads[k].shape == ref.constraint_grads[k].shape
            # log(cond / limit): near 0 where cond is near the limit, so compared absolutely
            np.testing.assert_allclose(got.constraints[k], ref.constraints[k], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(got.reach, ref.reach)
        hills.append(int(np.sum(ref.constraints["singularity"][0, len(ev.workspace.X):] > -10.0)))   # climbed
    assert sum(hills) > 0          # climbed hills compared too, not only W's points


def test_the_rows_at_the_hills_of_one_design_take_its_own_mechanism_with_the_same_bits():
    """A polish step asks for one design: the rows at its hills are computed
    on the mechanism already built for its workspace points
    (``_hill_constraints(..., mech)``) instead of a new one of the same
    parameters, which costs a construction and the engine's packing per
    step.  Both ways give the same bits, on the compiled values and on the
    numpy matrices with CasADi's derivatives, at random designs of the
    paper's box with the worst case over W on."""
    from optdesign.evaluate import workspace_of
    from optdesign.gradients import _COND, _compiled_local, _hill_constraints, _numpy_local

    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    req = next(r for r in ev.requests_all if r.name == (ev._cond if ev._cond is not None else _COND))
    limit = getattr(ev, "limit", ev.threshold)
    rng = np.random.default_rng(11)
    climbed = 0
    for x in ev.xl + (ev.xu - ev.xl) * rng.random((4, len(ev.xl))):
        designs = ev.designs(x[None])
        mech = ev.mechanism(**{**ev.fixed, **{k: v[:, None] for k, v in designs.items()}})
        vals, reach = mech.local_values([req], ev.workspace.X)
        sampled = np.where(np.asarray(reach, bool), np.asarray(vals[req.name], float), np.inf)
        hills = worstcase.worst_poses(ev.mechanism, ev.fixed, designs, ev.workspace, req, sampled, limit, hills=True)
        for local, n in ((_compiled_local(req), 0), (_numpy_local(ev, req, False), len(ev.free))):
            a = _hill_constraints(ev, designs, hills, limit, n, local, mech)
            b = _hill_constraints(ev, designs, hills, limit, n, local)
            for u, v in zip(a, b):
                assert u.tobytes() == v.tobytes()
        climbed += int(np.sum(a[0] > -10.0))
    assert climbed > 0            # rows at climbed hills compared, not only inactive ones


def test_values_only_keep_the_numpy_path_where_the_compiled_one_does_not_apply():
    """Stroke limits (constraints on the actuators, which the compiled values
    do not give) and a mechanism without an AD route (a described one, whose
    polish takes central differences) never take the compiled values."""
    from optdesign.evaluate import workspace_of
    from optdesign.gradients import _compiled_values

    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    x = 0.5 * (ev.xl + ev.xu)
    assert _compiled_values(ev, x[None]) is not None
    ev.stroke_limits = (-1.0, 1.0)
    assert _compiled_values(ev, x[None]) is None
    d = load_config(CONFIGS / "delta_opt.yaml")
    evd = Evaluator.from_config(d, workspace_of(d))
    assert _compiled_values(evd, (0.5 * (evd.xl + evd.xu))[None]) is None
    assert derivatives(evd, (0.5 * (evd.xl + evd.xu))[None], "auto", values_only=True).route == "fd"


def test_a_repeated_request_is_answered_from_the_memo_and_a_changed_setting_is_not():
    """derivatives keeps its last answers per Evaluator: the same design, route
    and values_only give the same object (SLSQP and the optimality measure ask
    again); the compiled paths switched off, a changed constraint setting or
    another design compute afresh, and equal what a fresh Evaluator gives."""
    from optdesign import fast
    from optdesign import gradients
    from optdesign.evaluate import workspace_of

    cfg = load_config(CONFIGS / "p4s_paper.yaml")
    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    x = (0.5 * (ev.xl + ev.xu))[None]
    a = derivatives(ev, x, "auto", values_only=True)
    assert derivatives(ev, x.copy(), "auto", values_only=True) is a
    full = derivatives(ev, x, "auto")
    assert full is not a and full.grads[next(iter(full.grads))].shape[-1] == len(ev.free)
    with fast.disabled():
        b = derivatives(ev, x, "auto", values_only=True)
    assert b is not a
    ev.stroke_limits = (-1.0, 1.0)
    c = derivatives(ev, x, "auto", values_only=True)
    assert c is not a and "stroke_high" in c.constraints
    y = x + 1e-3 * (ev.xu - ev.xl)
    d = derivatives(ev, y, "auto", values_only=True)
    fresh = derivatives(Evaluator.from_config(cfg, workspace_of(cfg)), y, "auto", values_only=True)
    for k in fresh.values:
        assert np.array_equal(d.values[k], fresh.values[k])
    # bounded: the oldest answers leave
    for i in range(gradients.MEMO + 5):
        derivatives(ev, x + i * 1e-6 * (ev.xu - ev.xl), "auto", values_only=True)
    assert len(gradients._MEMOS[ev]) == gradients.MEMO
