"""The chain mechanisms' compiled path (the engine's chain kernel,
optdesign/engine/chain_kernels.py) against their numpy path
(docs/lower-mobility.md): the shipped chain configs at random designs and
poses (statistics, reach masks, local values), the kernel's routines against
chain_solve's (the closures' system and its derivatives, the continuation),
independence of the thread count, and the kernels' digest."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from optdesign import fast
from optdesign.config import IndexSpec, load_config
from optdesign.engine.chain_layout import F_P0
from optdesign.evaluate import build, evaluate, index_requests, workspace_of
from optdesign.workspace import Workspace

pytest.importorskip("numba")

ROOT = Path(__file__).resolve().parents[1]

#: (config, the _opt config whose bounds the designs are drawn in)
CONFIGS = [("prs3.yaml", "prs3_opt.yaml"), ("prs3_opt.yaml", "prs3_opt.yaml"), ("upu3.yaml", "upu3_opt.yaml"),
           ("upu3_opt.yaml", "upu3_opt.yaml"), ("ups_upr_s_legs.yaml", "ups_upr_s_opt.yaml"),
           ("cpr_rrr_legs.yaml", "cpr_rrr_opt.yaml")]

KINDS = {
    "dyn": ("dynamic", None, {}),
    "st": ("stiffness", "lambda_min_K", {"k": 2.0}),
    "iso": ("isotropy", "frobenius", {}),
    "iso2": ("isotropy", "two_norm", {}),
    "dexn": ("dexterity", "normalized", {}),
    "man": ("manipulability", None, {}),
    "ax1": ("axis_stiffness", None, {"axis": 1}),
}


def _case(name, opt, D, N, seed, all_kinds=False):
    cfg = load_config(ROOT / "configs" / name)
    if all_kinds:
        dyn = cfg.mechanism_class.description.has_dynamics
        cfg = dataclasses.replace(cfg, indices={n: IndexSpec(n, k, c, "min", dict(o)) for n, (k, c, o) in KINDS.items()
                                                if dyn or k != "dynamic"})
    box = {k: dv.bounds for k, dv in load_config(ROOT / "configs" / opt).design_variables.items()
           if dv.bounds is not None and k in cfg.design_variables}
    rng = np.random.default_rng(seed)
    designs = {k: np.full(D, float(dv.value)) for k, dv in cfg.design_variables.items()}
    designs.update({k: rng.uniform(a, b, D) for k, (a, b) in box.items()})
    X0 = workspace_of(cfg).X
    lo, hi = X0.min(axis=0), X0.max(axis=0)
    X = lo + (hi - lo) * rng.random((N, X0.shape[1]))
    ws = Workspace(spec=cfg.workspace, names=cfg.mechanism_class.pose_names, X=X)
    return cfg, designs, ws


def _compare(cfg, designs, ws, tol=1e-10):
    with fast.disabled():
        ref = evaluate(cfg, designs, ws)
    got = evaluate(cfg, designs, ws)
    assert np.array_equal(got.reachable, ref.reachable)
    for name in cfg.indices:
        for s in ("mean", "min", "max", "std"):
            a, b = got.summary[name][s], ref.summary[name][s]
            assert np.array_equal(np.isnan(a), np.isnan(b)), (name, s)
            scale = np.maximum(np.abs(b), np.abs(ref.summary[name]["mean"]))
            with np.errstate(invalid="ignore"):
                rel = np.where(np.isfinite(b), np.abs(a - b) / np.where(scale > 0, scale, 1.0), 0.0)
            assert np.all(rel <= tol), (name, s, float(np.max(rel)))
    return got


def _calls(monkeypatch):
    """Count the chain kernel's runs (the compiled path did answer)."""
    from optdesign.engine import chain

    calls = []
    run = chain.run_chain
    monkeypatch.setattr(chain, "run_chain", lambda *a, **k: calls.append(1) or run(*a, **k))
    return calls


@pytest.mark.parametrize("name,opt", CONFIGS)
def test_the_shipped_chain_configs_agree_with_the_numpy_path(name, opt, monkeypatch):
    calls = _calls(monkeypatch)
    cfg, designs, ws = _case(name, opt, 3, 200, 7)
    _compare(cfg, designs, ws)
    assert calls, "the chain kernel did not run"


@pytest.mark.parametrize("name,opt", [CONFIGS[0], CONFIGS[4], CONFIGS[5]])
def test_every_index_kind(name, opt, monkeypatch):
    calls = _calls(monkeypatch)
    cfg, designs, ws = _case(name, opt, 2, 150, 3, all_kinds=True)
    _compare(cfg, designs, ws)
    assert calls


def test_the_switch_turns_the_chain_kernel_off(monkeypatch):
    calls = _calls(monkeypatch)
    monkeypatch.setenv("OPTDESIGN_CHAIN_ENGINE", "0")
    cfg, designs, ws = _case("prs3.yaml", "prs3_opt.yaml", 2, 50, 1)
    evaluate(cfg, designs, ws)
    assert not calls


def _mech(cfg, designs):
    return build(cfg, {k: np.asarray(v)[:, None] for k, v in designs.items()})


@pytest.mark.parametrize("name,opt", [CONFIGS[0], CONFIGS[2], CONFIGS[4]])
def test_local_values_at_equal_the_numpy_values(name, opt):
    from optdesign.mechanisms.described.chain_compiled import local_values_at
    from optdesign.mechanisms.described.fallback import numpy_values

    cfg, designs, ws = _case(name, opt, 3, 120, 11)
    mech = _mech(cfg, designs)
    req = index_requests(cfg)
    D, K = 3, 40
    X = ws.X[:D * K].reshape(D, K, -1)
    got = local_values_at(mech, req, X)
    assert got is not None
    vals, reach = got
    dd = np.repeat(np.arange(D), K)
    ref = numpy_values(mech, X.reshape(D * K, -1), dd, np.arange(D * K),
                       [(r.kind, r.convention, dict(r.options)) for r in req])
    for i, r in enumerate(req):
        a, b = vals[r.name].ravel(), ref[i]
        assert np.array_equal(np.isfinite(a), np.isfinite(b) & reach.ravel()), r.name
        ok = np.isfinite(b) & reach.ravel()
        assert np.allclose(a[ok], b[ok], rtol=1e-10, atol=0), r.name
    # the designs at shared points (the seam local_values)
    shared = mech.local_values(req, X[0])
    assert shared is not None
    for r in req:
        a, b = shared[0][r.name], got[0][r.name][0]
        assert np.allclose(a[0], b, rtol=0, atol=0, equal_nan=True), r.name


def test_results_do_not_depend_on_the_thread_count():
    import numba

    from optdesign.engine.chain import run_chain
    from optdesign.formulas import DYN, FRO, NVAL, SMIN, TWO
    from optdesign.mechanisms.described.chain_compiled import _flags, pack, points

    cfg, designs, ws = _case("prs3.yaml", "prs3_opt.yaml", 3, 700, 5)
    mech = _mech(cfg, designs)
    ints, arrays, D, _ = pack(mech)
    want = np.zeros(NVAL, dtype=np.bool_)
    want[[DYN, FRO, SMIN, TWO]] = True
    PX = points(mech, ws.X, False, D)
    out = []
    nt = numba.get_num_threads()
    try:
        for t in sorted({1, nt, 2} & set(range(1, numba.config.NUMBA_NUM_THREADS + 1))):
            numba.set_num_threads(t)
            keep = np.zeros((D, NVAL, ws.X.shape[0]))
            st, cnt, cd = run_chain(ints, *arrays, PX, want, _flags(want), keep)
            out.append((st, cnt, cd, keep))
    finally:
        numba.set_num_threads(nt)
    for o in out[1:]:
        for a, b in zip(out[0], o):
            assert np.array_equal(a, b, equal_nan=True)


# ---------------------------------------------------------------------- the routines
def _system_case(name, opt, D=4, seed=2):
    from optdesign.mechanisms.described.chain_compiled import pack

    cfg, designs, _ = _case(name, opt, D, 1, seed)
    mech = _mech(cfg, designs)
    ints, (VF, LF, SF, BF, GF, UH), D, _ = pack(mech)
    return mech, ints, VF, LF, GF, UH


@pytest.mark.parametrize("name,opt", [CONFIGS[0], CONFIGS[2], CONFIGS[4], CONFIGS[5]])
def test_the_system_and_its_derivatives(name, opt):
    from optdesign.engine.chain import CHAIN_KERNELS
    from optdesign.mechanisms.described.chain_solve import flat_constants, ik_system

    CK = CHAIN_KERNELS.require()
    mech, ints, VF, LF, GF, UH = _system_case(name, opt)
    D, nu = UH.shape
    n = ints[0][2]
    rng = np.random.default_rng(0)
    U = UH + 0.05 * rng.standard_normal(UH.shape)
    P = GF[:, F_P0:F_P0 + n] + 0.02 * rng.standard_normal((D, n))
    F, Fu, Fp = CK.system_stack(ints, VF, LF, GF, U, P)
    fc = flat_constants(mech.chain_constants, np.arange(D))
    F0, Fu0, Fp0 = ik_system(mech.description, fc, U, P)
    assert np.allclose(F, F0, rtol=0, atol=1e-14)
    assert np.allclose(Fu, Fu0, rtol=0, atol=1e-14)
    assert np.allclose(Fp, Fp0, rtol=0, atol=1e-14)
    # Fu, Fp against central differences where the rows are exact derivatives (position rows; all at a solution)
    pos = np.concatenate([np.arange(r, r + 3) for r in ints[3][:, 4]])
    h = 1e-6
    for c in range(nu):
        e = np.zeros(nu)
        e[c] = h
        fd = (CK.system_stack(ints, VF, LF, GF, U + e, P)[0] - CK.system_stack(ints, VF, LF, GF, U - e, P)[0]) / (2 * h)
        assert np.allclose(Fu[:, pos, c], fd[:, pos], rtol=0, atol=1e-8)
    for c in range(n):
        e = np.zeros(n)
        e[c] = h
        fd = (CK.system_stack(ints, VF, LF, GF, U, P + e)[0] - CK.system_stack(ints, VF, LF, GF, U, P - e)[0]) / (2 * h)
        assert np.allclose(Fp[:, pos, c], fd[:, pos], rtol=0, atol=1e-8)


@pytest.mark.parametrize("name,opt", [CONFIGS[0], CONFIGS[2], CONFIGS[4], CONFIGS[5]])
def test_the_continuation_follows_the_numpy_branch(name, opt):
    from optdesign.engine.chain import CHAIN_KERNELS
    from optdesign.mechanisms.described.chain_compiled import points
    from optdesign.mechanisms.described.chain_solve import (
        continuation,
        flat_constants,
        ik_system,
    )

    CK = CHAIN_KERNELS.require()
    mech, ints, VF, LF, GF, UH = _system_case(name, opt, D=1)
    cfg = load_config(ROOT / "configs" / name)
    X0 = workspace_of(cfg).X
    rng = np.random.default_rng(4)
    lo, hi = X0.min(axis=0), X0.max(axis=0)
    X = lo + (hi - lo) * rng.random((60, X0.shape[1]))
    n = ints[0][2]
    P1 = points(mech, X, False, 1)[0, :, :n]
    K = len(P1)
    rep = lambda a: np.ascontiguousarray(np.repeat(a, K, axis=0))  # noqa: E731
    u, ok = CK.continuation_stack(ints, rep(VF), rep(LF), rep(GF), rep(UH), np.ascontiguousarray(P1))
    fc = flat_constants(mech.chain_constants, np.zeros(K, dtype=int))
    p0 = np.broadcast_to(GF[0, F_P0:F_P0 + n], P1.shape)
    u0, ok0 = continuation(lambda c, x, q: ik_system(mech.description, c, x, q), fc, rep(UH), p0, P1,
                           mech._weights(fc))
    assert np.array_equal(ok, ok0)
    assert ok.any()
    assert np.allclose(u[ok], u0[ok], rtol=0, atol=1e-12)


def test_the_digest_of_the_compiled_sources_is_current():
    """chain_kernels.py records the digest of the files compiled into its kernels
    (numba's cache watches that file only)."""
    from optdesign.engine import chain_kernels as CK

    assert CK.CHAIN_DIGEST == CK.chain_digest(), \
        f"set CHAIN_DIGEST in optdesign/engine/chain_kernels.py to {CK.chain_digest()!r}"


def test_points_left_to_the_numpy_path_get_its_values(monkeypatch):
    """Points the kernel flags (code 2) are evaluated by the numpy path (J and
    M from the chain mechanism's own formulas): here every third point is
    flagged by hand, and the values stay the numpy path's."""
    from optdesign.engine import chain
    from optdesign.mechanisms.described.chain_compiled import local_values_at
    from optdesign.mechanisms.described.fallback import numpy_values

    cfg, designs, ws = _case("prs3.yaml", "prs3_opt.yaml", 2, 60, 9)
    mech = _mech(cfg, designs)
    req = index_requests(cfg)
    X = ws.X.reshape(2, 30, -1)
    run = chain.run_chain

    def flagged(*a, **k):
        st, cnt, cd = run(*a, **k)
        cd[:, ::3] = np.where(cd[:, ::3] == 1, 2, cd[:, ::3])
        return st, cnt, cd

    monkeypatch.setattr(chain, "run_chain", flagged)
    vals, reach = local_values_at(mech, req, X)
    ref = numpy_values(mech, X.reshape(60, -1), np.repeat(np.arange(2), 30), np.arange(60),
                       [(r.kind, r.convention, dict(r.options)) for r in req])
    for i, r in enumerate(req):
        a, b = vals[r.name].ravel(), ref[i]
        assert np.allclose(a, b, rtol=1e-10, atol=0, equal_nan=True), r.name
        assert np.array_equal(a[::3], b[::3], equal_nan=True), r.name


def test_one_compiled_code_serves_every_chain_shape():
    """The kernel reads the shape from its arrays: mechanisms of different
    shapes (pose types, joints, sizes, a coordinate map, shorthand legs) run
    on one compiled signature, so a new chain shape does not compile again."""
    from optdesign.engine.chain import CHAIN_KERNELS

    CK = CHAIN_KERNELS.require()
    for name, opt in (CONFIGS[0], CONFIGS[2], CONFIGS[4], CONFIGS[5]):
        cfg, designs, ws = _case(name, opt, 2, 20, 1)
        mech = _mech(cfg, designs)
        assert mech.global_statistics(index_requests(cfg), ws.X) is not None
        assert mech.local_values_at(index_requests(cfg), ws.X.reshape(2, 10, -1)) is not None
    assert len(CK.run_tasks.signatures) == 1
