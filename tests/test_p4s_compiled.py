"""The 3-P(4S)'s compiled path (optdesign.mechanisms.p4s.compiled) against the numpy model.

* local values at random designs and poses (unreachable, near-singular and the
  double eigenvalue at the workspace centre included) equal the numpy path's
  to 1e-12 relative: the closed form itself where cond(J) < 1000, LAPACK (the
  kernel hands those points over) beyond, where both lose about eps cond(J);
* per-design mean/min/max/std over the reachable points, the reachable mask
  (bitwise) and the counts equal those of ``global_summary``;
* results do not depend on the number of threads;
* with the kernels forced off (set_enabled, OPTDESIGN_FAST=0, a failed import)
  evaluate() takes the numpy path;
* the public methods (inverse, jacobian, forward) take the compiled path and
  equal the numpy model (bitwise for inverse kinematics and the Jacobian).
No timing here: speed is measured by ``benchmarks/`` (``optdesign bench --list``).
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from optdesign import fast
from optdesign.mechanisms.p4s import compiled
from optdesign.config import load_config, parse_config
from optdesign.evaluate import evaluate, index_requests
from optdesign.indices import cond_2, cond_fro, sigma_max, sigma_min
from optdesign.mechanisms.p4s import P4S
from optdesign.workspace import Workspace

from conftest import CONFIGS

PAPER = CONFIGS / "p4s_paper.yaml"
EPS = np.finfo(float).eps

pytestmark = pytest.mark.skipif(not compiled.LOCAL.available(), reason=f"numba kernels unavailable: {compiled.LOCAL.error}")


def _designs(rng, D):
    r_a = rng.uniform(0.18, 0.32, D)
    return dict(r_a=r_a, r_b=rng.uniform(0.58, 0.76, D), L=rng.uniform(0.34, 0.42, D),
                d=rng.uniform(0.05, 0.15, D), phi=np.radians(rng.uniform(20, 40, D)))


def _poses(rng, N):
    X = np.c_[rng.uniform(-0.12, 0.12, N), rng.uniform(-0.12, 0.12, N), rng.uniform(0.40, 0.70, N)]
    X[0] = [0.0, 0.0, 0.57]      # workspace centre: double eigenvalues by symmetry
    X[1] = [0.0, 0.0, 0.50]
    return X


def _mech(des):
    return P4S(**{k: np.asarray(v)[:, None] for k, v in des.items()})


def _reference(mech, X):
    with np.errstate(all="ignore"), fast.disabled():
        reach = mech.reachable(X)
        J = mech.jacobian(X)
        M = mech.mass_matrix(X)
        smin = sigma_min(J)
        ref = {"dynamic": sigma_max(M), "sigma_min_sq": smin ** 2, "sigma_min": smin,
               "cond_fro": cond_fro(J), "cond_2": cond_2(J)}
    return ref, reach, cond_2(J)


@pytest.mark.slow
def test_local_values_match_numpy():
    rng = np.random.default_rng(5)
    des = _designs(rng, 12)
    X = _poses(rng, 1500)
    mech = _mech(des)
    vals, reach = compiled.p4s_local(mech, X)
    ref, reach0, cond = _reference(mech, X)
    assert np.array_equal(reach, reach0)
    assert 0.2 < reach.mean() < 0.95       # unreachable poses are part of the sample
    assert np.nanmax(cond[reach]) > 1e3    # and near-singular ones
    for name, r in ref.items():
        a, b = vals[name][reach], r[reach]
        fin = np.isfinite(b)
        assert np.array_equal(a[~fin], b[~fin])
        rel = np.abs(a[fin] - b[fin]) / np.abs(b[fin])
        assert np.max(rel) < 1e-12, name
    assert np.all(np.isnan(vals["dynamic"][~reach]))


def test_raw_kernel_accuracy_near_singularities():
    """The closed form alone (no LAPACK hand-off): 1e-12 where cond(J) < 1000 and
    within 50 eps cond(J) beyond (the SVD's own accuracy); the kernel flags
    (code 2) every point with cond(J) >= 1000 for the LAPACK path."""
    rng = np.random.default_rng(5)
    mech = _mech(_designs(rng, 12))
    X = _poses(rng, 1500)
    k = compiled.LOCAL.get()
    raw, codes = k.p4s_local(compiled.design_constants(mech), np.ascontiguousarray(X), True)
    ref, reach, cond = _reference(mech, X)
    assert np.array_equal(codes != 0, reach)
    assert np.all(codes[reach & (cond >= 1000)] == 2)
    good = reach & np.isfinite(cond)
    tol = np.maximum(1e-12, 50 * EPS * cond[good])
    for i, name in enumerate(compiled.VALUE_NAMES):
        a, b = raw[i][good], ref[name][good]
        rel = np.abs(a - b) / np.abs(b)
        assert np.all(rel <= tol), (name, np.max(rel / tol))
        wc = cond[good] < 1000
        assert wc.sum() > 1000 and np.max(rel[wc]) < 1e-12, name


def test_double_eigenvalue_at_the_centre():
    """At the centre of a symmetric design the indices sit on a double
    eigenvalue; the closed form keeps 1e-14 there."""
    des = dict(r_a=np.array([0.25, 0.21]), r_b=np.array([0.67, 0.71]), L=np.array([0.38, 0.38]),
               d=np.array([0.12, 0.12]), phi=np.radians([30.0, 35.0]))
    mech = _mech(des)
    X = np.array([[0.0, 0.0, z] for z in np.linspace(0.5, 0.62, 13)])
    vals, reach = compiled.p4s_local(mech, X)
    ref, reach0, _ = _reference(mech, X)
    assert reach.all() and reach0.all()
    for name, r in ref.items():
        assert np.max(np.abs(vals[name] - r) / r) < 2e-14, name


def test_lambda_max_closed_form():
    k = compiled.LOCAL.get()
    rng = np.random.default_rng(2)
    cases = []
    for _ in range(200):
        Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        lam = rng.uniform(0.1, 10.0, 3)
        kind = rng.integers(4)
        if kind == 1:
            lam[1] = lam[0]                    # double
        elif kind == 2:
            lam[:] = lam[0]                    # triple
        elif kind == 3:
            lam[1] = lam[0] * (1 + 1e-9)       # nearly double
        cases.append(Q @ np.diag(lam) @ Q.T)
    cases.append(np.diag([2.0, 2.0, 1.0]))
    cases.append(np.diag([1.0, 1.0, 2.0]))
    cases.append(np.zeros((3, 3)))
    for A in cases:
        A = 0.5 * (A + A.T)
        got = k.lambda_max_psd(A[0, 0], A[1, 1], A[2, 2], A[0, 1], A[0, 2], A[1, 2])
        want = np.linalg.eigvalsh(A)[-1]
        assert abs(got - want) <= 1e-14 * max(abs(want), 1e-300) + 1e-300, (A, got, want)


def test_exactly_singular_and_unreachable():
    """Vertical rails (m = z), no offset, L = 1/2: at x = 1/2 the rods lie in the
    rails' plane exactly (s = 0): dynamic inf, stiffness 0, isotropy inf."""
    k = compiled.LOCAL.get()
    P = np.zeros((1, 15))
    P[0, 1], P[0, 2] = 0.5, 0.25
    P[0, 3], P[0, 4], P[0, 5] = 4.0, 1.0, 0.1
    P[0, 8] = P[0, 11] = P[0, 14] = 1.0
    xs = np.array([0.5, 0.25, 0.75])
    ys = np.zeros(3)
    zs = np.ones(3)
    vals, codes = k.p4s_local(P, np.ascontiguousarray(np.c_[xs, ys, zs]), True)
    assert codes[0, 0] == 2 and codes[0, 1] != 0 and codes[0, 2] == 0   # singular: left to LAPACK
    assert vals[0, 0, 0] == np.inf and vals[1, 0, 0] == 0.0 and vals[2, 0, 0] == 0.0
    assert vals[3, 0, 0] == np.inf and vals[4, 0, 0] == np.inf


# ----------------------------------------------------------------------------- evaluate()
def _config(**changes):
    d = yaml.safe_load(PAPER.read_text())
    for path, v in changes.items():
        node = d
        keys = path.split("__")
        for key in keys[:-1]:
            node = node[key]
        node[keys[-1]] = v
    return parse_config(yaml.safe_dump(d))


def _workspace(cfg, X):
    return Workspace(spec=cfg.workspace, names=("x", "y", "z"), X=X)


def _compare(cfg, designs, ws, rtol=None):
    """Fast and numpy evaluate() agree: mask and counts exactly, statistics to
    1e-12 relative (or to ``rtol`` (D,): designs whose workspace comes close to
    a singularity, where the numpy path's SVD of J is only cond(J) eps accurate)."""
    fast.set_enabled(True)
    try:
        ev_fast = evaluate(cfg, designs, ws)
        with fast.disabled():
            ev_np = evaluate(cfg, designs, ws)
    finally:
        fast.set_enabled(None)
    assert np.array_equal(ev_fast.reachable, ev_np.reachable)
    assert np.array_equal(ev_fast.reachable_fraction, ev_np.reachable_fraction)
    for name in cfg.indices:
        a, b = ev_fast.summary[name], ev_np.summary[name]
        assert np.array_equal(a["count"], b["count"])
        for stat in ("mean", "min", "max", "std"):
            x, y = np.asarray(a[stat]), np.asarray(b[stat])
            assert np.array_equal(np.isnan(x), np.isnan(y)), (name, stat)
            fin = np.isfinite(y)
            assert np.array_equal(x[~fin & ~np.isnan(y)], y[~fin & ~np.isnan(y)])
            tol = np.full(x.shape, 1e-12 if stat != "std" else 1e-10) if rtol is None else rtol[name][stat]
            rel = np.abs(x[fin] - y[fin]) / np.abs(y[fin])
            assert np.all(rel <= tol[fin]), (name, stat, np.max(rel / tol[fin]))
    return ev_fast, ev_np


def test_evaluate_fast_equals_numpy_paper_config():
    cfg = load_config(PAPER)
    assert P4S(**cfg.design("after"), **cfg.parameters).global_statistics(
        index_requests(cfg, list(cfg.indices)), np.zeros((1, 3))) is not None
    rng = np.random.default_rng(11)
    D = 40
    designs = {"r_a": rng.uniform(0.21, 0.29, D), "r_b": rng.uniform(0.63, 0.71, D),
               "phi": np.radians(rng.uniform(25, 35, D))}
    from optdesign.evaluate import workspace_of

    _compare(cfg, designs, workspace_of(cfg))
    _compare(cfg, [cfg.design("before"), cfg.design("after")], workspace_of(cfg))


@pytest.mark.parametrize("stiff,iso,k", [("lambda_min_K", "frobenius", 1.0),
                                          ("sqrt_lambda_min_K", "two_norm", 2.5),
                                          ("lambda_min_K", "two_norm", 3.0)])
def test_evaluate_fast_equals_numpy_conventions(stiff, iso, k):
    cfg = _config(indices__stiffness={"kind": "stiffness", "convention": stiff, "options": {"k": k}},
                  indices__isotropy={"kind": "isotropy", "convention": iso})
    rng = np.random.default_rng(3)
    D = 25
    designs = {"r_a": rng.uniform(0.18, 0.32, D), "r_b": rng.uniform(0.55, 0.80, D),
               "phi": np.radians(rng.uniform(20, 40, D))}
    X = _poses(rng, 1300)   # more than two chunks, with unreachable points
    ev, _ = _compare(cfg, designs, _workspace(cfg, X))
    frac = ev.reachable_fraction
    assert frac.min() < 1.0 and frac.max() > 0.0


def test_evaluate_fast_equals_numpy_well_conditioned():
    """A workspace around the centre of the paper's design box: every statistic to 1e-12."""
    cfg = _config(indices__stiffness={"kind": "stiffness", "convention": "sqrt_lambda_min_K", "options": {"k": 2.0}},
                  indices__isotropy={"kind": "isotropy", "convention": "two_norm"})
    rng = np.random.default_rng(9)
    D = 30
    designs = {"r_a": rng.uniform(0.21, 0.29, D), "r_b": rng.uniform(0.63, 0.71, D),
               "phi": np.radians(rng.uniform(25, 35, D))}
    X = np.c_[rng.uniform(-0.06, 0.06, 1100), rng.uniform(-0.06, 0.06, 1100), rng.uniform(0.5, 0.62, 1100)]
    _compare(cfg, designs, _workspace(cfg, X))


def test_design_without_reachable_points_gives_nan():
    cfg = load_config(PAPER)
    X = np.array([[0.0, 0.0, 5.0], [1.0, 1.0, 0.57]])  # far out of reach
    ev, _ = _compare(cfg, [cfg.design("after"), cfg.design("before")], _workspace(cfg, X))
    for name in cfg.indices:
        assert np.all(np.isnan(ev.summary[name]["mean"])) and np.all(ev.summary[name]["count"] == 0)


def test_unsupported_index_takes_numpy_path():
    """The kernel answers the indices it computes and leaves the others to the
    numpy path (with its reachable mask); evaluate() then equals the numpy path
    for every index."""
    cfg = _config(indices__dexterity={"kind": "dexterity"}, indices__manip={"kind": "manipulability"},
                  optimizer__weights__dexterity=0, optimizer__weights__manip=0)
    mech = P4S(**cfg.design("after"), **cfg.parameters)
    ans = mech.global_statistics(index_requests(cfg, list(cfg.indices)), np.zeros((1, 3)))
    assert set(ans[0]) == {"dynamic", "stiffness", "isotropy"}
    assert mech.global_statistics(index_requests(cfg, ["dexterity", "manip"]), np.zeros((1, 3))) is None
    assert mech.global_statistics(index_requests(cfg, ["dynamic", "isotropy"]), np.zeros((1, 3))) is not None
    rng = np.random.default_rng(4)
    designs = {"r_a": rng.uniform(0.18, 0.32, 20), "r_b": rng.uniform(0.55, 0.80, 20),
               "phi": np.radians(rng.uniform(20, 40, 20))}
    _compare(cfg, designs, _workspace(cfg, _poses(rng, 700)))


# ----------------------------------------------------------------------------- threads, fallback
def test_results_do_not_depend_on_thread_count():
    import numba

    rng = np.random.default_rng(8)
    mech = _mech(_designs(rng, 30))
    X = _poses(rng, 2000)
    old = numba.get_num_threads()
    try:
        out = []
        for nt in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS), numba.config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(nt)
            stats, counts, reach = compiled.p4s_summary(mech, X)
            vals, reach2 = compiled.p4s_local(mech, X)
            one = P4S(r_a=0.21, r_b=0.71, L=0.38, d=0.12, phi=np.radians(35.0))
            with np.errstate(all="ignore"):
                fk = one.forward(one.inverse(np.tile(X[:500], (10, 1))))
            out.append((stats, counts, reach, vals, reach2, fk))
    finally:
        numba.set_num_threads(old)
    for o in out[1:]:
        for a, b in zip(out[0], o):
            if isinstance(a, dict):
                for key in a:
                    np.testing.assert_array_equal(a[key], b[key])
            else:
                np.testing.assert_array_equal(a, b)


def test_fallback_when_disabled_or_unavailable(monkeypatch):
    cfg = load_config(PAPER)
    mech = P4S(**cfg.design("after"), **cfg.parameters)
    X = np.zeros((1, 3))
    names = list(cfg.indices)
    monkeypatch.setenv(fast.ENV_VAR, "0")
    assert not fast.enabled() and mech.global_statistics(index_requests(cfg, names), X) is None
    monkeypatch.setenv(fast.ENV_VAR, "1")
    assert fast.enabled()
    with fast.disabled():
        assert mech.global_statistics(index_requests(cfg, names), X) is None
    # numba missing: the import failed
    for km in (compiled.LOCAL, compiled.FK, compiled.IK):
        monkeypatch.setattr(km, "module", None)
        monkeypatch.setattr(km, "error", ImportError("no numba"))
    assert not compiled.LOCAL.available() and compiled.FK.get() is None and compiled.IK.get() is None
    assert mech.global_statistics(index_requests(cfg, names), X) is None
    ev = evaluate(cfg, [cfg.design("after")])
    assert 15.0 < ev.summary["dynamic"]["mean"][0] < 16.5
    np.testing.assert_allclose(mech.forward(np.array([[0.4, 0.41, 0.42]])),
                               mech.forward_numpy(np.array([[0.4, 0.41, 0.42]])), rtol=0, atol=0)
    Xp = np.array([[0.01, -0.02, 0.57]])
    assert compiled.inverse(mech, Xp) is None and compiled.jacobian(mech, Xp) is None


# ----------------------------------------------------------------------------- forward kinematics
def test_forward_kinematics_kernel():
    """Round trip inverse -> forward to 1e-12 m and the numpy forward to 1e-12 m
    where J is not nearly singular; near singularities the problem itself is
    ill-conditioned and both paths lose the same digits."""
    rng = np.random.default_rng(4)
    for _ in range(5):
        d = {k: float(v[0]) for k, v in _designs(rng, 1).items()}
        mech = P4S(**d)
        X = _poses(rng, 4000)
        with np.errstate(all="ignore"):
            Q = mech.inverse(X)
            cond = cond_2(mech.jacobian(X))
        ok = np.all(np.isfinite(Q), axis=-1)
        Q, X, cond = Q[ok], X[ok], cond[ok]
        P = mech.forward(Q)
        with np.errstate(all="ignore"):
            P0 = mech.forward_numpy(Q)
        err, err0 = np.abs(P - X).max(axis=-1), np.abs(P0 - X).max(axis=-1)
        wc = cond < 1e3
        assert np.max(err[wc]) <= 1e-12 and np.max(np.abs(P - P0)[wc]) <= 1e-12
        assert np.all(err <= 2 * err0 + 1e-13)
    # a caller's output array, a non-contiguous input: the same values
    out = np.full(Q.shape, 7.0)
    assert mech.forward(Q, out=out) is out
    np.testing.assert_array_equal(out, P)
    np.testing.assert_array_equal(mech.forward(np.asfortranarray(Q)), P)
    # in place, and a pose's result does not depend on where it falls (vectorized
    # loop, scalar remainder, the scalar loop taken when out aliases Q)
    Q2 = Q.copy()
    np.testing.assert_array_equal(mech.forward(Q2, out=Q2), P)
    np.testing.assert_array_equal(mech.forward(Q[3:]), P[3:])
    np.testing.assert_array_equal(np.concatenate([mech.forward(Q[k:k + 1]) for k in range(20)]), P[:20])
    with pytest.raises(ValueError):
        mech.forward(Q, out=np.empty((len(Q), 3), order="F"))
    # spheres that do not meet: NaN as the numpy path
    Qbad = np.array([[0.0, 0.0, 2.0], [2.0, -2.0, 0.0]])
    with np.errstate(all="ignore"):
        assert np.array_equal(np.isnan(mech.forward(Qbad)), np.isnan(mech.forward_numpy(Qbad)))


def test_public_inverse_and_jacobian_are_the_numpy_models_bitwise():
    """P4S.inverse / reachable / jacobian through the compiled kernel equal the
    numpy model bit for bit, for one design and for a population (D, 1), at
    reachable and unreachable poses."""
    rng = np.random.default_rng(12)
    X = np.concatenate([_poses(rng, 3000), np.c_[rng.uniform(-0.5, 0.5, (300, 2)), rng.uniform(0.8, 1.2, 300)]])
    for mech in (P4S(**{k: float(v[0]) for k, v in _designs(rng, 1).items()}), _mech(_designs(rng, 9))):
        got = (mech.inverse(X), mech.reachable(X), mech.jacobian(X))
        with fast.disabled():
            want = (mech.inverse(X), mech.reachable(X), mech.jacobian(X))
        assert compiled.inverse(mech, X) is not None and compiled.jacobian(mech, X) is not None
        for a, b in zip(got, want):
            assert a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
        assert 0.1 < got[1].mean() < 0.95 and np.isnan(got[0]).any()
