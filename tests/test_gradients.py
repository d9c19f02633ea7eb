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
