"""The compiled path of described mechanisms against the numpy path: every
index kind and convention, every leg kind on every pose type, populations of
designs, points handed to LAPACK, and independence of the thread count."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from described_helpers import CASES, description

from optdesign import fast
from optdesign.config import IndexSpec, load_config
from optdesign.evaluate import build, evaluate, workspace_of
from optdesign.workspace import Workspace

ROOT = Path(__file__).resolve().parents[1]

KINDS = {
    "dyn": ("dynamic", None, {}),
    "st": ("stiffness", "lambda_min_K", {"k": 2.0}),
    "st_sqrt": ("stiffness", "sqrt_lambda_min_K", {}),
    "iso": ("isotropy", "frobenius", {}),
    "iso2": ("isotropy", "two_norm", {}),
    "dex": ("dexterity", "plain", {}),
    "dexn": ("dexterity", "normalized", {}),
    "man": ("manipulability", None, {}),
    "drv": ("driving", None, {}),
    "ax0": ("axis_stiffness", None, {"axis": 0, "k": 3.0}),
    "ax1": ("axis_stiffness", None, {"axis": 1}),
}


def _with_indices(cfg, dynamic=True):
    idx = {n: IndexSpec(n, k, c, "min", dict(o)) for n, (k, c, o) in KINDS.items() if dynamic or k != "dynamic"}
    return dataclasses.replace(cfg, indices=idx)


def _compare(cfg, designs, ws=None, tol=1e-12):
    with fast.disabled():
        ref = evaluate(cfg, designs, ws)
    got = evaluate(cfg, designs, ws)
    assert np.array_equal(got.reachable, ref.reachable)
    worst = 0.0
    for name in cfg.indices:
        for s in ("mean", "min", "max", "std"):
            a, b = got.summary[name][s], ref.summary[name][s]
            assert np.array_equal(np.isnan(a), np.isnan(b)), (name, s)
            scale = np.maximum(np.abs(b), np.abs(ref.summary[name]["mean"]))
            with np.errstate(invalid="ignore"):
                rel = np.where(np.isfinite(b), np.abs(a - b) / np.where(scale > 0, scale, 1.0), 0.0)
            worst = max(worst, float(np.max(rel)))
            assert np.all(rel <= tol), (name, s, float(np.max(rel)))
    return worst


def _uses_kernel(cfg, designs, ws=None):
    from optdesign.evaluate import index_requests

    ws = ws or workspace_of(cfg)
    kw = dict(cfg.parameters)
    kw.update({k: np.atleast_1d(np.asarray(v, float))[:, None] for k, v in designs.items()})
    from optdesign.mechanisms import get

    mech = get(cfg.mechanism)(**kw)
    return mech.global_statistics(index_requests(cfg), ws.X) is not None


def _random_designs(cfg, rng, D):
    out = {}
    for k, dv in cfg.design_variables.items():
        lo, hi = dv.bounds if dv.bounds else (0.9 * dv.value, 1.1 * dv.value) if dv.value else (-0.01, 0.01)
        out[k] = rng.uniform(lo, hi, D)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name,spread", [("p4s_legs.yaml", None), ("gough_stewart.yaml", 0.1), ("delta.yaml", 0.1),
                                         ("sps_s_legs.yaml", 0.2)])
def test_configs_all_index_kinds(name, spread):
    cfg = load_config(ROOT / "configs" / name)
    cfg = _with_indices(cfg, dynamic=build(cfg, next(iter(cfg.designs))).description.has_dynamics)
    rng = np.random.default_rng(5)
    D = 8
    if spread is None:
        des = _random_designs(cfg, rng, D)
    else:
        des = {k: dv.value * rng.uniform(1 - spread, 1 + spread, D) for k, dv in cfg.design_variables.items()}
    assert _uses_kernel(cfg, des)
    _compare(cfg, des)


@pytest.mark.parametrize("kind,ptype", CASES)
def test_every_leg_kind_and_pose_type(kind, ptype):
    from optdesign.config import parse_config

    import yaml

    desc = description(kind, ptype, masses=True)
    desc["parameters"] = {"unused": {"kind": "number", "default": 1.0}}
    from optdesign.mechanisms.described import build_class

    mech = build_class(desc)()
    spec = mech.pose_spec
    axes = {}
    for nme, role, h in zip(spec.names, spec.roles, spec.home):
        span = 0.03 if role in ("x", "y", "z") else 0.08
        axes[nme] = [h - span, h + span]
    cfg_text = yaml.safe_dump({"mechanism": desc, "design_variables": {"unused": 1.0},
                               "workspace": {"type": "box", "axes": axes, "sampling": "sobol", "points": 700},
                               "indices": {"iso": {"kind": "isotropy"}}})
    cfg = _with_indices(parse_config(cfg_text))
    assert _uses_kernel(cfg, {"unused": np.array([1.0])})
    _compare(cfg, [{"unused": 1.0}])


def test_points_handed_to_lapack_and_unreachable_points():
    """A Delta workspace reaching past the edge: unreachable points and points
    near the boundary singularity.  For n <= 3 the kernel keeps them (its
    adjugate inverse is exact to a few ulps at any conditioning; it hands over
    only singular or non-finite points and beyond cond_F 1e12): on the poses
    up to cond_2(J) 1e6 the statistics equal the numpy path's to the numpy
    path's own accuracy there: 64 eps cond for the singular-value kinds, 64
    eps cond^2 for the Gram determinants (manipulability, driving) of the
    numpy path, which lose the square (the kernel's |det J| does not:
    test_the_kernels_determinant_is_exact_where_the_gram_determinant_is_not)."""
    from optdesign.indices import cond_2
    from optdesign.mechanisms.described.compiled import reach_codes

    cfg = _with_indices(load_config(ROOT / "configs" / "delta.yaml"))
    g = np.linspace(-0.6, 0.6, 61)
    X = np.stack(np.meshgrid(g, [0.0, 0.013], np.linspace(-0.9, -0.1, 41), indexing="ij"), -1).reshape(-1, 3)
    designs = {"R": np.array([0.2, 0.21]), "r": np.array([0.05, 0.05]), "L_a": np.array([0.25, 0.26]),
               "L_b": np.array([0.6, 0.58])}
    mech = build(cfg, "reference").__class__(**{**cfg.parameters, **{k: v[:, None] for k, v in designs.items()}})
    codes = reach_codes(mech, X)
    assert (codes == 0).sum() > 100 and (codes == 1).sum() > 1000
    with np.errstate(all="ignore"), fast.disabled():
        c = np.where(mech.reachable(X), cond_2(mech.jacobian(X)), 0.0)
    c = np.where(np.isfinite(c), c, np.inf)
    assert np.max(c[np.isfinite(c)]) > 1e7                    # near-singular poses are part of the sample
    keep = np.all(c <= 1e6, axis=0)                           # unreachable ones too (c = 0)
    cmax = np.max(c[:, keep])
    assert 1e3 < cmax and (~np.all(c[:, keep] > 0, axis=0)).sum() > 100
    ws = Workspace(spec=cfg.workspace, names=("x", "y", "z"), X=X[keep])
    det_kinds = [n for n, s in cfg.indices.items() if s.kind in ("manipulability", "driving")]
    eps = np.finfo(float).eps
    _compare(dataclasses.replace(cfg, indices={n: s for n, s in cfg.indices.items() if n not in det_kinds}),
             designs, ws, tol=64 * eps * cmax)
    _compare(dataclasses.replace(cfg, indices={n: cfg.indices[n] for n in det_kinds}), designs, ws,
             tol=64 * eps * cmax ** 2)


def test_the_kernels_determinant_is_exact_where_the_gram_determinant_is_not():
    """|det J| of the kernel (the adjugate's compensated determinant) at the
    most ill-conditioned reachable poses of a Delta grid (cond_2 up to ~1e8)
    against the exact determinant (50 digits) of the numpy path's J: within
    16 eps cond(J) (the two paths' J may differ in their last bits, which the
    determinant amplifies by cond(J)), while the numpy path's
    driving index sqrt(det(J^T J)) at the worst pose is off by more than a percent."""
    mp = pytest.importorskip("mpmath")
    import optdesign.formulas as F
    from optdesign.indices import cond_2
    from optdesign.mechanisms.base import IndexRequest

    mp.mp.dps = 50
    cfg = load_config(ROOT / "configs" / "delta.yaml")
    g = np.linspace(-0.6, 0.6, 61)
    X = np.stack(np.meshgrid(g, [0.0, 0.013], np.linspace(-0.9, -0.1, 41), indexing="ij"), -1).reshape(-1, 3)
    mech = build(cfg, "reference").__class__(**{**cfg.parameters, "R": 0.2, "r": 0.05, "L_a": 0.25, "L_b": 0.6})
    vals, reach = mech.local_values_at([IndexRequest("man", "manipulability", None)], X[None])
    with np.errstate(all="ignore"), fast.disabled():
        J = mech.jacobian(X)
        c = np.where(reach[0], cond_2(J), 0.0)
        row, cc, a = F.select("driving", None, {}, 3)
        gram = row.value(F.Operands(J=J), cc, a)
    worst = np.argsort(np.where(np.isfinite(c), c, 0.0))[-6:]
    assert c[worst[-1]] > 1e7
    for k in worst:
        exact = abs(float(mp.det(mp.matrix(J[k].tolist()))))
        assert abs(vals["man"][0, k] - exact) <= 16 * np.finfo(float).eps * c[k] * exact, (k, c[k])
    k = worst[-1]
    exact = abs(float(mp.det(mp.matrix(J[k].tolist()))))
    assert abs(gram[k] - exact) > 1e-2 * exact


def test_results_do_not_depend_on_the_thread_count():
    import numba

    cfg = _with_indices(load_config(ROOT / "configs" / "gough_stewart.yaml"))
    rng = np.random.default_rng(9)
    des = {k: dv.value * rng.uniform(0.9, 1.1, 6) for k, dv in cfg.design_variables.items()}
    old = numba.get_num_threads()
    try:
        out = []
        for n in sorted({1, numba.config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(n)
            out.append(evaluate(cfg, des).summary)
    finally:
        numba.set_num_threads(old)
    for name in out[0]:
        for s in ("mean", "min", "max", "std"):
            assert np.array_equal(out[0][name][s], out[-1][name][s])


def test_max_cond_and_unsupported_requests():
    from optdesign.mechanisms.described.compiled import IndexRequest

    cfg = load_config(ROOT / "configs" / "gough_stewart.yaml")
    mech = build(cfg, "reference")
    X = workspace_of(cfg).X
    s, reach = mech.global_statistics([IndexRequest("d", "dexterity", "plain", ())], X, want_max_cond=True)
    from optdesign.indices import cond_2

    assert np.isclose(s["_max_cond_2"][0], np.max(cond_2(mech.jacobian(X))), rtol=1e-12)
    assert mech.global_statistics([IndexRequest("x", "stiffness", None, (("zz", 1.0),))], X) is None
    with fast.disabled():
        assert mech.global_statistics([IndexRequest("d", "dexterity", "plain", ())], X) is None


@pytest.mark.parametrize("name", ["gough_stewart.yaml", "delta.yaml", "sps_s_legs.yaml"])
def test_local_values_at_shared_points_equal_the_numpy_values(name):
    """The seam local_values (weighted quadratures, the adaptive cubature of
    the reported designs' integrals) answers on the engine for a described
    mechanism, with the numpy path's reachable mask and its values to 1e-12
    of the index's scale."""
    from optdesign.evaluate import index_requests
    from optdesign.mechanisms import get
    from optdesign.statistics import local_values

    cfg = load_config(ROOT / "configs" / name)
    cfg = _with_indices(cfg, dynamic=build(cfg, next(iter(cfg.designs))).description.has_dynamics)
    rng = np.random.default_rng(11)
    D = 4
    des = {k: dv.value * rng.uniform(0.9, 1.1, (D, 1)) for k, dv in cfg.design_variables.items()}
    mech = get(cfg.mechanism)(**{**cfg.parameters, **des})
    X = workspace_of(cfg).X[:300]
    req = index_requests(cfg)
    got = mech.local_values(req, X)
    assert got is not None
    with fast.disabled():
        ref, ref_reach = local_values(mech, X, req, D)
    vals, reach = got
    assert np.array_equal(reach, ref_reach)
    assert reach.any()
    for r in req:
        a, b = vals[r.name], np.where(ref_reach, ref[r.name], np.nan)
        assert np.array_equal(np.isfinite(a), np.isfinite(b)), r.name
        ok = np.isfinite(b)
        assert ok.any(), r.name
        # relative to the index's scale over the points (as _compare): near-singular poses (the
        # 3-SPS-S's condition numbers reach 1e4) round differently in the last bits
        assert np.allclose(a[ok], b[ok], rtol=1e-12, atol=1e-12 * np.abs(b[ok]).max()), r.name


def _shipped_engine_configs():
    from optdesign.evaluate import mechanism_class
    from optdesign.mechanisms.described.mechanism import DescribedMechanism
    from optdesign.mechanisms.described.packing import description_codes

    out = []
    from optdesign.config import ConfigError

    for path in sorted((ROOT / "configs").glob("*.yaml")):
        try:
            cfg = load_config(path)
        except ConfigError:         # a batch file
            continue
        cls = mechanism_class(cfg)
        if not issubclass(cls, DescribedMechanism):
            continue
        try:
            description_codes(cls.description)
        except ValueError:          # chain legs: the chain kernel's packing
            continue
        out.append(path.name)
    return out


@pytest.mark.parametrize("name", _shipped_engine_configs())
def test_a_subset_of_designs_packs_as_the_rows_of_its_population(name):
    """The worst-case search's mechanisms of some designs of a population
    (Mechanism.rows_of) take the rows of the population's packing: the same
    bits as packing them anew, for random designs in the box and any index
    (repeats, one design, all); and a mechanism of (D, 1) parameters, or of a
    fixed parameter given per design, hits the memo of the same designs given
    as (D,)."""
    from optdesign.evaluate import mechanism_class
    from optdesign.mechanisms.described import packing
    from optdesign.mechanisms.described.memo import pack_key

    cfg = load_config(ROOT / "configs" / name)
    cls = mechanism_class(cfg)
    rng = np.random.default_rng(len(name))
    D = 23
    des = {}
    for k, dv in cfg.design_variables.items():
        lo, hi = dv.bounds if dv.bounds else (0.9 * dv.value, 1.1 * dv.value) if dv.value else (-0.01, 0.01)
        des[k] = rng.uniform(lo, hi, D)
    population = cls(**{**cfg.parameters, **des})
    for index in (np.array([4]), np.array([5, 5, 5, 9]), np.arange(D)[::-3], rng.integers(0, D, 40)):
        fresh = packing._pack(cls(**{**cfg.parameters, **{k: v[index] for k, v in des.items()}}))
        sub = cls(**{**cfg.parameters, **{k: v[index] for k, v in des.items()}})
        sub.rows_of(population, index)
        got = packing.pack(sub)
        assert got[3] == fresh[3] == len(index)
        for a, b in zip(got[0], fresh[0]):
            assert np.array_equal(a, b)
        assert np.array_equal(got[1], fresh[1], equal_nan=True) and np.array_equal(got[2], fresh[2], equal_nan=True)
    column = cls(**{**cfg.parameters, **{k: v[:, None] for k, v in des.items()}})
    assert pack_key(column) == pack_key(population)
    # a parameter given once or per design, alike
    every = {k: np.full(D, float(v)) for k, v in population.params.items() if k not in des and np.ndim(v) == 0}
    assert every
    assert pack_key(cls(**{**cfg.parameters, **des, **every})) == pack_key(population)
    again, ref = packing._pack(cls(**{**cfg.parameters, **des, **every})), packing._pack(population)
    assert np.array_equal(again[1], ref[1]) and np.array_equal(again[2], ref[2])     # equal keys, equal packings
    assert pack_key(cls(**{**cfg.parameters, **{k: v[::-1] for k, v in des.items()}})) != pack_key(population)


def test_the_packing_memo_keeps_small_populations_only():
    """PACKS keeps the packings of at most PACK_DESIGNS designs (the polish's and
    the search's, evaluated again), not a GA population's thousands."""
    from optdesign.evaluate import mechanism_class
    from optdesign.mechanisms.described import packing
    from optdesign.mechanisms.described.memo import PACK_DESIGNS, PACKS, pack_key

    cfg = load_config(ROOT / "configs" / "delta.yaml")
    cls = mechanism_class(cfg)
    for D, kept in ((PACK_DESIGNS, True), (PACK_DESIGNS + 1, False)):
        des = {k: dv.value * np.linspace(0.95, 1.05, D) for k, dv in cfg.design_variables.items()}
        mech = cls(**{**cfg.parameters, **des})
        packing.pack(mech)
        assert (PACKS.get(pack_key(mech)) is not None) == kept, D
