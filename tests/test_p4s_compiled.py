"""The 3-P(4S)'s compiled path (optdesign.mechanisms.p4s.compiled: the one
engine on the mechanism's description) against the numpy model
(optdesign.mechanisms.p4s.model, written from the paper independently).

* local values at random designs and poses (unreachable, near-singular and the
  double eigenvalue at the workspace centre included) equal the numpy path's
  to 1e-12 relative (the engine hands points with cond(J) >= 1000 to the
  description's numpy path), each design at shared points and at its own;
* evaluate(): per-design mean/min/max/std over the reachable points, the
  reachable mask (bitwise) and the counts equal the numpy path's;
* results do not depend on the number of threads;
* with the engine forced off (set_enabled, OPTDESIGN_FAST=0, a failed import)
  evaluate() takes the numpy path;
* forward kinematics (closed form, numpy) round-trips the inverse.
No timing here: speed is measured by ``benchmarks/`` (``optdesign bench --list``).
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from optdesign import engine, fast
from optdesign.config import IndexSpec
from optdesign.mechanisms.base import IndexRequest
from optdesign.mechanisms.p4s import compiled
from optdesign.config import load_config, parse_config
from optdesign.evaluate import evaluate, index_requests
from optdesign.indices import cond_2, cond_fro, sigma_max, sigma_min
from optdesign.mechanisms.p4s import P4S
from optdesign.workspace import Workspace

from conftest import CONFIGS

PAPER = CONFIGS / "p4s_paper.yaml"
EPS = np.finfo(float).eps

# a string condition: evaluated as a test of this file is set up, not at collection, where loading the
# kernel module would start the engine's first-compile helper (optdesign.engine.warmup) in every test worker
pytestmark = pytest.mark.skipif("not engine.KERNELS.available()", reason="numba kernels unavailable")

#: the engine's values of the fused kernel the mechanism had before (names as the reference's)
REQUESTS = [IndexRequest("dynamic", "dynamic", None), IndexRequest("sigma_min_sq", "stiffness", "lambda_min_K"),
            IndexRequest("sigma_min", "stiffness", "sqrt_lambda_min_K"),
            IndexRequest("cond_fro", "isotropy", "frobenius"), IndexRequest("cond_2", "isotropy", "two_norm")]


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


def test_local_values_match_numpy():
    """Every local value at random designs and poses, unreachable and
    near-singular ones included: shared points (local_values) and each design
    at its own (local_values_at)."""
    rng = np.random.default_rng(5)
    des = _designs(rng, 12)
    X = _poses(rng, 1500)
    mech = _mech(des)
    ref, reach0, cond = _reference(mech, X)
    assert 0.2 < reach0.mean() < 0.95       # unreachable poses are part of the sample
    assert np.nanmax(cond[reach0]) > 1e3    # and near-singular ones
    shared = mech.local_values(REQUESTS, X)
    own = mech.local_values_at(REQUESTS, np.ascontiguousarray(np.broadcast_to(X, (12,) + X.shape)))
    # both paths are exact to eps cond(J) (each on its own J, which differ in
    # their last bits): 1e-12, or 64 eps cond(J) where that is more
    tol = np.maximum(1e-12, 64 * EPS * np.where(np.isfinite(cond), cond, 0.0))
    for vals, reach in (shared, own):
        assert np.array_equal(reach, reach0)
        for name, r in ref.items():
            a, b = vals[name][reach], r[reach]
            fin = np.isfinite(b)
            assert np.array_equal(a[~fin], b[~fin])
            rel = np.abs(a[fin] - b[fin]) / np.abs(b[fin])
            assert np.all(rel <= tol[reach][fin]), (name, float(np.max(rel / tol[reach][fin])))
            assert np.max(rel[cond[reach][fin] < 1e3]) < 1e-12, name
        assert np.all(np.isnan(vals["dynamic"][~reach]))


def test_double_eigenvalue_at_the_centre():
    """At the centre of a symmetric design the indices sit on a double
    eigenvalue; the closed forms keep 1e-14 there."""
    des = dict(r_a=np.array([0.25, 0.21]), r_b=np.array([0.67, 0.71]), L=np.array([0.38, 0.38]),
               d=np.array([0.12, 0.12]), phi=np.radians([30.0, 35.0]))
    mech = _mech(des)
    X = np.array([[0.0, 0.0, z] for z in np.linspace(0.5, 0.62, 13)])
    vals, reach = mech.local_values(REQUESTS, X)
    ref, reach0, _ = _reference(mech, X)
    assert reach.all() and reach0.all()
    for name, r in ref.items():
        assert np.max(np.abs(vals[name] - r) / r) < 2e-14, name


def test_exactly_singular_and_unreachable():
    """Vertical rails (phi = 90 deg), L = 1/2: at a pose where the rods lie in
    the rails' plane (s = 0) the dynamic index is inf, the stiffness 0 and the
    isotropy inf, as on the numpy path; beyond it, unreachable."""
    mech = P4S(r_a=0.25, r_b=0.25 * np.cos(np.arcsin(0.12 / 0.5)), L=0.5, d=0.12, phi=np.pi / 2)
    X = np.array([[0.5, 0.0, 1.0], [0.25, 0.0, 1.0], [0.75, 0.0, 1.0]])
    vals, reach = mech.local_values(REQUESTS, X)
    ref, reach0, _ = _reference(mech, X)
    assert np.array_equal(reach[0], reach0) and list(reach0) == [True, True, False]
    for name in ref:
        assert np.array_equal(vals[name][0, :2], ref[name][:2]), name
    assert vals["dynamic"][0, 0] == np.inf and vals["sigma_min"][0, 0] == 0.0 and vals["cond_2"][0, 0] == np.inf


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


def _cond_rtol(cfg, designs, ws):
    """Per-design tolerances of _compare: 1e-12, or 64 eps times the largest
    cond(J) over the design's reachable points where that is more (both paths
    are exact to eps cond(J) there, each on its own J; cond(J)^2 for the Gram
    determinants of the numpy path)."""
    params = {k: np.asarray(v, dtype=float)[:, None] for k, v in designs.items()}
    mech = P4S(**{**cfg.parameters, **{k: v for k, v in cfg.design("after").items() if k not in params}, **params})
    with np.errstate(all="ignore"), fast.disabled():
        c = np.where(mech.reachable(ws.X), cond_2(mech.jacobian(ws.X)), 0.0)
    cmax = np.max(np.where(np.isfinite(c), c, 0.0), axis=-1)
    tol = np.maximum(1e-12, 64 * EPS * cmax)
    # the numpy path's Gram determinants (manipulability, driving) lose eps cond^2
    det = np.maximum(1e-12, 64 * EPS * cmax ** 2)
    return {n: {st: np.maximum(det if s.kind in ("manipulability", "driving") else tol, 1e-10 if st == "std" else 0.0)
                for st in ("mean", "min", "max", "std")} for n, s in cfg.indices.items()}


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
    ws = _workspace(cfg, X)
    ev, _ = _compare(cfg, designs, ws, _cond_rtol(cfg, designs, ws))
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
    """The engine answers the requests it computes (here every kind the config
    names) and leaves the others (a stiffness with k <= 0: no kernel column)
    to the numpy path (with its reachable mask); evaluate() then equals the
    numpy path for every index."""
    cfg = _config(indices__dexterity={"kind": "dexterity"}, indices__manip={"kind": "manipulability"},
                  optimizer__weights__dexterity=0, optimizer__weights__manip=0)
    mech = P4S(**cfg.design("after"), **cfg.parameters)
    ans = mech.global_statistics(index_requests(cfg, list(cfg.indices)), np.zeros((1, 3)))
    assert set(ans[0]) == {"dynamic", "stiffness", "isotropy", "dexterity", "manip"}
    odd = [IndexRequest("soft", "stiffness", None, (("k", -1.0),))]
    assert mech.global_statistics(odd, np.zeros((1, 3))) is None
    assert set(mech.global_statistics(odd + index_requests(cfg, ["dynamic"]), np.zeros((1, 3)))[0]) == {"dynamic"}
    rng = np.random.default_rng(4)
    designs = {"r_a": rng.uniform(0.18, 0.32, 20), "r_b": rng.uniform(0.55, 0.80, 20),
               "phi": np.radians(rng.uniform(20, 40, 20))}
    ws = _workspace(cfg, _poses(rng, 700))
    _compare(cfg, designs, ws, _cond_rtol(cfg, designs, ws))


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
            summary, reach = mech.global_statistics(REQUESTS, X)
            vals, reach2 = mech.local_values(REQUESTS, X)
            out.append((summary, reach, vals, reach2))
    finally:
        numba.set_num_threads(old)
    for o in out[1:]:
        for a, b in zip(out[0], o):
            if isinstance(a, dict):
                for key in a:
                    if isinstance(a[key], dict):
                        for stat in a[key]:
                            np.testing.assert_array_equal(a[key][stat], b[key][stat])
                    else:
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
    monkeypatch.setattr(engine.KERNELS, "module", None)
    monkeypatch.setattr(engine.KERNELS, "error", ImportError("no numba"))
    assert not engine.KERNELS.available()
    assert mech.global_statistics(index_requests(cfg, names), X) is None
    assert mech.local_values(REQUESTS, X) is None
    ev = evaluate(cfg, [cfg.design("after")])
    assert 15.0 < ev.summary["dynamic"]["mean"][0] < 16.5


# ----------------------------------------------------------------------------- forward kinematics
def test_forward_kinematics_round_trip():
    """Round trip inverse -> forward to 1e-12 m where J is not nearly singular;
    the caller's output array; NaN where the spheres do not meet."""
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
        wc = cond < 1e3
        assert np.max(np.abs(P - X).max(axis=-1)[wc]) <= 1e-12
    out = np.full(Q.shape, 7.0)
    assert mech.forward(Q, out=out) is out
    np.testing.assert_array_equal(out, P)
    np.testing.assert_array_equal(mech.forward(np.asfortranarray(Q)), P)
    Qbad = np.array([[0.0, 0.0, 2.0], [2.0, -2.0, 0.0]])
    with np.errstate(all="ignore"):
        assert np.all(np.isnan(mech.forward(Qbad)))


def test_the_description_is_the_mechanism():
    """The description the engine runs on has the model's kinematics: strokes,
    the Jacobian and the mass matrix agree to round-off (1e-14), for one design
    and a population."""
    rng = np.random.default_rng(12)
    X = _poses(rng, 500)
    for mech in (P4S(**{k: float(v[0]) for k, v in _designs(rng, 1).items()}), _mech(_designs(rng, 9))):
        desc = compiled.described(mech)
        with np.errstate(all="ignore"), fast.disabled():
            q0, q1 = mech.inverse(X), desc.inverse(X)
            assert np.array_equal(np.isnan(q0), np.isnan(q1))
            ok = ~np.isnan(q0[..., 0])
            assert np.max(np.abs(q0 - q1)[ok]) < 1e-14
            J0, J1 = mech.jacobian(X)[ok], desc.jacobian(X)[ok]
            M0, M1 = mech.mass_matrix(X)[ok], desc.mass_matrix(X)[ok]
        # J: the strokes' discriminant L^2 - |w|^2 + (m.w)^2 loses digits where a
        # leg nears its own singularity (measured: 3.5e-13 at cond 26); M = J^-T
        # M_p to eps cond(J)^2 (M_p's terms grow like |J|^2, J^-T of each model's own J)
        c = cond_2(J0)
        good = c < 100
        assert np.all(np.abs(J0 - J1)[good] <= 1e-12 * np.abs(J0[good]).max(axis=(1, 2))[:, None, None])
        scale = 10 * EPS * c ** 2 * np.abs(M0).max(axis=(1, 2))
        assert np.all(np.abs(M0 - M1).max(axis=(1, 2)) <= scale)


def test_a_subset_of_designs_packs_as_the_rows_of_its_population(monkeypatch):
    """P4S.rows_of (the worst-case search's mechanisms of some designs of a
    population): the engine's packing is the rows of the population's, the
    same bits as packing the subset anew, for random designs in the box; and
    the search gives the same maxima with and without it."""
    from optdesign.mechanisms.described.packing import pack
    from optdesign.worstcase import local_functions, maximize

    cfg = load_config(PAPER)
    rng = np.random.default_rng(17)
    D = 19
    des = {k: rng.uniform(*dv.bounds, D) if dv.bounds else np.full(D, dv.value)
           for k, dv in cfg.design_variables.items()}
    population = P4S(**{**cfg.parameters, **des})
    for index in (np.array([0]), np.array([3, 3, 8]), rng.integers(0, D, 30)):
        sub = P4S(**{**cfg.parameters, **{k: v[index] for k, v in des.items()}})
        sub.rows_of(population, index)
        fresh = compiled.pack(P4S(**{**cfg.parameters, **{k: v[index] for k, v in des.items()}}))
        got = pack(compiled.described(sub))
        assert got[3] == fresh[3] == len(index)
        assert np.array_equal(got[1], fresh[1]) and np.array_equal(got[2], fresh[2])
    from optdesign.evaluate import workspace_of

    ws = workspace_of(cfg)
    req = IndexRequest("c", "isotropy", "two_norm")
    with np.errstate(all="ignore"):
        vals, reach = population.local_values([req], ws.X)
    sampled = np.where(reach, vals["c"], np.inf)
    a = maximize(local_functions(P4S, cfg.parameters, des)["cond"], ws, sampled.copy(), hills=True)
    monkeypatch.setattr(P4S, "rows_of", lambda self, population, index: None)   # every mechanism packed anew
    b = maximize(local_functions(P4S, cfg.parameters, des)["cond"], ws, sampled.copy(), hills=True)
    assert np.isfinite(a[0]).any()
    for x, y in zip(a, b):
        assert np.array_equal(x, y, equal_nan=True)
