"""The worst case of the local constraints over the continuous W
(optdesign.worstcase, through the Evaluator): a design whose samples pass but
which is singular between them is infeasible; the search's maximum agrees
with a dense grid; the stated margin tightens the limit the optimizer sees,
while the certificates' limit stays the limit itself."""
import numpy as np
import pytest
import yaml

from conftest import DATA, PAPER
from optdesign.config import load_config, parse_config
from optdesign.evaluate import _COND, Evaluator
from optdesign.linalg import cond_2, cond_fro
from optdesign import fast, worstcase

#: a 3-P(4S) design of the paper's bounds (r_a, r_b in m, phi in rad) whose
#: 11 x 11 samples have cond_F <= 818, while a singular curve crosses W
#: between them (found by scanning the bounds against a 201^2 grid)
BETWEEN = np.array([0.2537, 0.6401, 0.4620])


def _dense(ev, x, n=401):
    """max cond over an n x n grid of W for the design vector x (inf where unreachable)."""
    spec = ev.workspace.spec
    (x0, x1), (y0, y1), (z, _) = spec.axes["x"], spec.axes["y"], spec.axes["z"]
    a, b = np.meshgrid(np.linspace(x0, x1, n), np.linspace(y0, y1, n), indexing="ij")
    P = np.stack([a.ravel(), b.ravel(), np.full(a.size, z)], axis=1)
    d = ev.designs(np.atleast_2d(x))
    m = ev.mechanism(**{**ev.fixed, **{k: v[0] for k, v in d.items()}})
    conv = next(r.convention for r in ev.requests_all if r.kind == "isotropy")
    J = m.index_matrices(P, {"J"})["J"]
    c = cond_fro(J) if conv == "frobenius" else cond_2(J)
    return float(np.max(np.where(m.reachable(P), c, np.inf)))


def test_singular_between_the_samples_is_infeasible():
    ev = Evaluator.from_config(load_config(PAPER))
    assert ev.worst_case and ev.threshold == 1000.0
    ev.worst_case = False
    sampled = ev(BETWEEN[None])["constraints"]
    assert sampled["reach"][0] == 0 and sampled["singularity"][0] < -0.1      # the samples pass by a wide margin
    ev.worst_case = True
    cons = ev(BETWEEN[None])["constraints"]
    assert cons["singularity"][0] > 0                                           # the continuous search rejects it
    assert _dense(ev, BETWEEN) > 1000.0                                         # and a dense grid agrees


@pytest.mark.parametrize("method", ["auto", "ascent"])
@pytest.mark.parametrize("path", [PAPER, DATA / "p4s_tiny.yaml"])
def test_found_maximum_matches_a_dense_grid(path, method):
    """The search's maximum over W against a 401^2 grid, with the config's
    cond convention (the paper: cond_F; p4s_tiny, no isotropy index: cond_2),
    by the default search (the zoom on the compiled path) and by the
    gradient ascent on the numpy path."""
    cfg = load_config(path)
    ev = Evaluator.from_config(cfg)
    req = next(r for r in ev.requests_all if r.kind == "isotropy")
    assert req.convention == ("frobenius" if "isotropy" in cfg.indices else "two_norm")
    X = np.array([[0.25, 0.67, np.deg2rad(30)], [0.29, 0.63, np.deg2rad(25)]])
    d = ev.designs(X)
    mech = ev.mechanism(**{**ev.fixed, **{k: v[:, None] for k, v in d.items()}})
    sampled = worstcase._sampled_cond(mech, ev.workspace.X, req, len(X))
    f = worstcase.local_functions(ev.mechanism, ev.fixed, d, req.kind, req.convention,
                                  compiled=method == "auto")["cond"]
    assert f.compiled == (method == "auto")                  # the 3-P(4S) has a compiled cond: the zoom
    found, pose = worstcase.maximize(f, ev.workspace, sampled, method=method)
    for i in range(len(X)):
        dense = _dense(ev, X[i])
        assert found[i] >= dense * (1 - 1e-4)        # at least what the dense grid sees
        assert found[i] <= dense * (1 + 1e-3)        # and no more than W holds near it
        assert np.isclose(f(np.array([i]))(pose[i][None, None])[0, 0], found[i], rtol=1e-12)   # the pose gives the value
        assert found[i] >= sampled[i].max()


def test_the_margin_tightens_the_limit():
    data = yaml.safe_load(PAPER.read_text())
    x = np.array([[0.25, 0.67, np.deg2rad(30)]])
    c = Evaluator.from_config(load_config(PAPER))(x)["constraints"]["singularity"][0]
    cmax = (c + 1.0) * 999.0                       # the worst cond_F over W (default margin 0.1 %)
    margin = 0.01
    data["optimizer"]["singularity_threshold"] = float(cmax / (1 - margin / 2))   # cmax inside the margin band
    data["optimizer"]["constraint_margin"] = margin
    ev = Evaluator.from_config(parse_config(yaml.safe_dump(data)))
    assert ev.limit == pytest.approx(ev.threshold * (1 - margin))
    assert ev(x)["constraints"]["singularity"][0] > 0          # infeasible against limit (1 - margin)
    data["optimizer"]["constraint_margin"] = 0.0
    ev0 = Evaluator.from_config(parse_config(yaml.safe_dump(data)))
    assert ev0(x)["constraints"]["singularity"][0] <= 0        # feasible against the limit itself
    assert ev.threshold == ev0.threshold                       # the certificates' limit is the limit


def test_worst_case_off_keeps_the_sampled_maximum():
    data = yaml.safe_load(PAPER.read_text())
    data["optimizer"]["worst_case"] = False
    data["optimizer"]["constraint_margin"] = 0.0
    ev = Evaluator.from_config(parse_config(yaml.safe_dump(data)))
    c = ev(BETWEEN[None])["constraints"]["singularity"][0]
    d = ev.designs(BETWEEN[None])
    m = ev.mechanism(**{**ev.fixed, **{k: v[0] for k, v in d.items()}})
    assert c == pytest.approx(cond_fro(m.jacobian(ev.workspace.X)).max() / 1000.0 - 1.0, rel=1e-12)


def test_projection_stays_in_a_disc():
    u = np.array([[1.0, 1.0], [0.5, 0.9], [0.0, 0.5]])
    p = worstcase._project(u, {"disc": (0.0, 0.0, 1.0)})
    assert np.all(np.sum((p - 0.5) ** 2, axis=1) <= 0.25 + 1e-12)
    assert np.allclose(p[1:], u[1:])


def test_compiled_quantity_equals_the_numpy_path():
    """The search's cond from the compiled path (each design at its own poses,
    Mechanism.local_values_at) equals the numpy path's, inf where a pose is
    not reachable (a pose outside the workspace's bounds included)."""
    ev = Evaluator.from_config(load_config(PAPER))
    req = next(r for r in ev.requests_all if r.kind == "isotropy")
    X = np.array([[0.25, 0.67, np.deg2rad(30)], BETWEEN, [0.29, 0.63, np.deg2rad(28.7)]])
    d = ev.designs(X)
    idx = np.array([0, 1, 2, 1])
    rng = np.random.default_rng(0)
    P = np.concatenate([rng.uniform(-0.05, 0.05, (7, 4, 2)), np.full((7, 4, 1), 0.57)], axis=2)
    P[0, 0, :2] = 1.0                                            # far outside: not reachable
    f = {c: worstcase.local_functions(ev.mechanism, ev.fixed, d, req.kind, req.convention, compiled=c)["cond"](idx)
         for c in (True, False)}
    m = ev.mechanism(**{**ev.fixed, **{k: v[idx] for k, v in d.items()}})
    if fast.enabled():
        assert m.local_values_at([req], np.swapaxes(P, 0, 1)) is not None    # the compiled path answers
    a, b = f[True](P), f[False](P)
    assert np.isinf(a[0, 0]) and np.array_equal(np.isinf(a), np.isinf(b))
    assert np.allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-12, atol=0)


def test_a_design_seen_before_is_not_searched_again(monkeypatch):
    ev = Evaluator.from_config(load_config(PAPER))
    rows = []
    real = worstcase.worst_over_w
    monkeypatch.setattr(worstcase, "worst_over_w", lambda m, fx, designs, *a, **k: (
        rows.append(len(next(iter(designs.values())))), real(m, fx, designs, *a, **k))[1])
    X = np.array([BETWEEN, [0.25, 0.67, np.deg2rad(30)]])
    first = ev(X)["constraints"]["singularity"]
    again = ev(np.array([[0.25, 0.67, np.deg2rad(30)], BETWEEN, [0.26, 0.67, np.deg2rad(30)]]))["constraints"]
    assert rows == [2, 1]                                        # only the new design is searched
    assert np.array_equal(again["singularity"][:2], first[::-1]) and first[0] > 0


def test_fd_route_differentiates_the_maximum_at_its_pose():
    """With the worst case on, the central-difference route's singularity
    constraint is, in its first row, the maximum over W found by the search
    (through :func:`smooth_singularity`), and its derivative that of cond
    at the pose of the maximum (the envelope theorem): it equals the AD
    route's derivative of the constraint it adds at that pose (CasADi, an
    independent derivative; that constraint is log(cond / limit)).  The
    other rows are the other hills' maxima, none above the first."""
    from optdesign.gradients import derivatives, smooth_singularity

    ev = Evaluator.from_config(load_config(PAPER.parent / "p4s_tradeoff.yaml"))
    assert ev.worst_case
    X = np.clip(np.array([[0.25, 0.67, np.deg2rad(30)], [0.27, 0.66, np.deg2rad(24)]]), ev.xl, ev.xu)
    fd = derivatives(ev, X, route="fd")
    ad = derivatives(ev, X, route="ad")
    rows = fd.constraints["singularity"]
    assert rows.shape[1] > 1 and np.all(rows[:, 1:] <= rows[:, :1])
    c = rows[:, 0]
    assert np.all(c < 0)                                              # feasible designs: a smooth maximum
    cond = ev(X)["cond_max"]
    assert np.array_equal(c, smooth_singularity(cond, ev.limit))
    top = ev.workspace.X.shape[0]            # the AD route's rows: every sample, then the hills, largest first
    assert ad.constraints["singularity"].shape[1] == top + rows.shape[1]
    assert np.allclose(np.log(cond / ev.limit), ad.constraints["singularity"][:, top], rtol=1e-9, atol=1e-12)
    slope = np.where(2.0 * cond >= ev.limit, 2.0 * (ev.limit / cond) ** 2, 8.0)      # d smooth / d log cond
    g_ad = ad.constraint_grads["singularity"][:, top] * slope[:, None]
    assert np.allclose(fd.constraint_grads["singularity"][:, 0], g_ad, rtol=1e-5, atol=1e-9)


def test_smooth_singularity_has_the_feasible_set_of_the_limit_and_counts_the_unreachable_as_violated():
    from optdesign.gradients import smooth_singularity
    from optdesign.gradients.fd import _singularity

    L = 1000.0
    c = np.array([1.0, 100.0, 499.0, 500.0, 501.0, 999.0, 1000.0, 1001.0, 1e9])
    t = smooth_singularity(c, L)
    assert np.array_equal(t <= 0, c <= L) and t[6] == 0.0
    assert np.all(np.diff(t) > 0)                                       # increasing in cond
    assert np.all(smooth_singularity(np.array([np.inf, np.nan, 0.0]), L) == 1.0)   # singular, unreachable
    h = 1e-6                                                            # C1 where the two forms meet
    lo, hi = smooth_singularity(np.array([L / 2 - h, L / 2 + h]), L)
    assert abs((hi - lo) / (2 * h) - 8.0 / (L / 2)) < 1e-6
    # a design with an unreachable sample is violated, whatever cond is over the points it reaches
    res = {"cond_max": np.array([5.0, 5.0]), "reachable_fraction": np.array([1.0, 0.99])}
    assert np.array_equal(_singularity(res, L) > 0, [False, True])


def test_the_search_refines_a_steep_maximum_next_to_the_limit_to_a_dense_grid():
    """A Delta design next to a reach boundary (the seed-5 weighted-sum
    optimum of configs/delta_opt.yaml before the refinement): its largest
    cond lies on W's bottom rim, a peak so steep that the coarse zoom found
    998.964 (below the limit 999, so it passed) where a dense grid of the
    rim finds 999.007.  The refined search agrees with the grid."""
    ev = Evaluator.from_config(load_config(PAPER.parent / "delta_opt.yaml"))
    x = np.array([0.29975261553421956, 0.030359356647004253, 0.1996229139888836, 0.6163984628124797])
    got = float(ev(x[None])["cond_max"][0])
    th = np.linspace(0.0, 2.0 * np.pi, 200001)
    rim = np.stack([0.15 * np.cos(th), 0.15 * np.sin(th), np.full_like(th, -0.7)], axis=1)
    req = next(r for r in ev.requests_all if r.name == (ev._cond or _COND))
    f = worstcase.local_functions(ev.mechanism, ev.fixed, ev.designs(x[None]), req.kind, req.convention)["cond"]
    dense = float(np.max(np.asarray(f(np.zeros(1, int))(rim[:, None, :]), float)))
    assert dense > ev.limit                            # infeasible: the refined search must say so
    assert got >= dense * (1 - 1e-9) and got > ev.limit
    assert ev(x[None])["constraints"]["singularity"][0] > 0


@pytest.mark.parametrize("name", ["gough_stewart_opt", "delta_opt", "sps_s_legs_opt"])
def test_described_local_values_at_equal_the_numpy_path(name):
    """A described mechanism's compiled local values, each design at its own
    poses (the worst-case search's quantity), equal the numpy path's formulas
    on its own Jacobian and mass matrix for every index of the config, with the
    same reachable mask (random designs of the bounds, poses around W's samples)."""
    from optdesign.indices import local_index

    ev = Evaluator.from_config(load_config(PAPER.parent / f"{name}.yaml"))
    rng = np.random.default_rng(7)
    d = ev.designs(ev.xl + (ev.xu - ev.xl) * rng.random((5, len(ev.xl))))
    idx = np.array([0, 1, 2, 3, 4, 2])
    Xw = ev.workspace.X
    P = Xw[rng.integers(0, len(Xw), (9, idx.size))]
    P = P + 0.02 * rng.standard_normal(P.shape) * (np.ptp(Xw, axis=0) > 0)
    m = ev.mechanism(**{**ev.fixed, **{k: v[idx] for k, v in d.items()}})
    reach = np.asarray(m.reachable(P), bool).T
    for req in ev.requests_all:
        got = m.local_values_at([req], np.swapaxes(P, 0, 1))
        if not fast.enabled():
            assert got is None
            continue
        vals, r = got
        assert np.array_equal(r, reach)
        mats = m.index_matrices(P, {"J"} | ({"M"} if req.kind == "dynamic" else set()))
        ref = np.asarray(local_index(req.kind, J=mats["J"], M=mats.get("M"), convention=req.convention,
                                     options=dict(req.options or ())), float).T
        a = vals[req.name]
        assert np.all(np.isnan(a[~reach]))
        assert np.allclose(a[reach], ref[reach], rtol=1e-12, atol=0), req.name
