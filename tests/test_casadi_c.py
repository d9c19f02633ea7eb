"""The AD route's CasADi function compiled to machine code (optdesign.gradients.casadi_c):
the same bits as CasADi's virtual machine at the poses and designs of every
mechanism with a CasADi model (and at wild inputs: singular, out of reach,
out of scale), the same derivatives end to end, the library cached and loaded
again, and the virtual machine where there is no compiler, a failed compile, a
damaged or foreign library, or the switch is off."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS

from optdesign import fast
from optdesign.config import load_config
from optdesign.evaluate import Evaluator
from optdesign.gradients import casadi_c as C
from optdesign.gradients import casadi_fn
from optdesign.mechanisms import symbolic_model

pytestmark = pytest.mark.skipif(C.compiler() is None, reason="no C compiler (CC, cc, gcc or clang): the AD route "
                                "stays on CasADi's virtual machine")

CONFIGS_AD = ["p4s_paper.yaml", "p4s_wide.yaml", "sps_s_opt.yaml", "ups_upr_s_opt.yaml", "cpr_rrr_opt.yaml"]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty cache folder of this test's own."""
    monkeypatch.setenv(C.CACHE_VAR, str(tmp_path / "cache"))
    monkeypatch.delenv(C.ENV_VAR, raising=False)
    return tmp_path / "cache"


def _function(name):
    ev = Evaluator.from_config(load_config(CONFIGS / name))
    fn, model = casadi_fn.symbolic_function(ev.mechanism.name, symbolic_model(ev.mechanism.name), tuple(ev.free))
    return ev, fn, model


def _inputs(ev, model, seed):
    """(x, q, p) columns as the AD route passes them: 4 designs at the workspace's points, then wild inputs."""
    rng = np.random.default_rng(seed)
    X = ev.xl + (ev.xu - ev.xl) * rng.random((4, len(ev.free)))
    designs = ev.designs(X)
    mech = ev.mechanism(**{**ev.fixed, **{k: v[:, None] for k, v in designs.items()}})
    P = ev.workspace.X[:200]
    with np.errstate(all="ignore"):
        st = mech.state(P)
    D, N = len(X), len(P)
    x, q, p = casadi_fn.arguments(P, np.broadcast_to(st.q, (D, N, model.n_act)), mech.params, model.param_names)
    # wild: zeros (a singular closure), huge and tiny scales, negative lengths, the same value everywhere,
    # NaN and infinite inputs
    k = 64
    wild = [rng.normal(scale=s, size=(a.shape[0], k)) for a, s in ((x, 3.0), (q, 2.0), (p, 1.0))]
    wild[0][:, :4] = 0.0
    wild[1][:, :4] = 0.0
    wild[2][:, 4:8] = 1e150
    wild[2][:, 8:12] = 1e-160
    wild[1][:, 12:16] = 1.0
    wild[1][:, 16:20] = np.nan
    wild[0][:, 20:24] = np.inf
    return [np.ascontiguousarray(np.concatenate([a, w], axis=1)) for a, w in zip((x, q, p), wild)]


@pytest.mark.parametrize("name", CONFIGS_AD)
def test_the_compiled_function_gives_the_virtual_machines_bits(name, cache):
    ev, fn, model = _function(name)
    ext = C.compiled(fn)
    assert ext is not fn, "compiled on this machine (it has a C compiler)"
    args = _inputs(ev, model, 3)
    n = args[0].shape[1]
    with np.errstate(all="ignore"):
        a = fn.map(n)(*args)
        b = ext.map(n)(*args)
    a = a if isinstance(a, (list, tuple)) else [a]
    b = b if isinstance(b, (list, tuple)) else [b]
    assert len(a) == len(b) == fn.n_out()
    nonfinite = 0
    for i, (u, v) in enumerate(zip(a, b)):
        u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
        assert u.shape == v.shape
        assert np.array_equal(u, v, equal_nan=True), (name, fn.name_out(i))
        # NaN where NaN, and the same signs of zeros and infinities
        assert np.array_equal(np.signbit(u[~np.isnan(u)]), np.signbit(v[~np.isnan(v)]))
        nonfinite += int(np.sum(~np.isfinite(u)))
    assert nonfinite > 0, "the wild inputs reach the non-finite results too"


def test_the_derivatives_are_the_same_with_the_compiled_function(cache, monkeypatch):
    """derivatives() on the AD route, end to end, with and without the compiled function: the same bits."""
    from optdesign.gradients import derivatives

    out = []
    for flag in ("0", "1"):
        monkeypatch.setenv(C.ENV_VAR, flag)
        monkeypatch.setattr(casadi_fn, "_FUNCTIONS", {})
        monkeypatch.setattr(casadi_fn, "_MAPS", {})
        ev = Evaluator.from_config(load_config(CONFIGS / "p4s_paper.yaml"))
        X = ev.xl + (ev.xu - ev.xl) * np.random.default_rng(5).random((3, len(ev.free)))
        d = derivatives(ev, X, "ad")
        fn = casadi_fn._FUNCTIONS[(ev.mechanism.name, tuple(ev.free))][0]
        out.append((d, fn.class_name()))
    (d0, kind0), (d1, kind1) = out
    assert (kind0, kind1) == ("SXFunction", "External")
    for k in d0.values:
        assert np.array_equal(d0.values[k], d1.values[k], equal_nan=True), k
        assert np.array_equal(d0.grads[k], d1.grads[k], equal_nan=True), k
    for k in d0.constraints:
        assert np.array_equal(d0.constraints[k], d1.constraints[k], equal_nan=True), k


def test_the_library_is_compiled_once_then_loaded(cache):
    _, fn, _ = _function("sps_s_opt.yaml")
    before = len(C.compiles)
    first = C.compiled(fn)
    assert len(C.compiles) == before + 1 and first is not fn
    libs = sorted(p.name for p in cache.iterdir())
    assert len(libs) == 1 and libs[0].startswith(f"casadi_{fn.name()}_") and libs[0].endswith(".so")
    second = C.compiled(fn)
    assert len(C.compiles) == before + 1, "loaded from the cache, not compiled again"
    assert second is not fn and C.same_bits(fn, second)
    assert sorted(p.name for p in cache.iterdir()) == libs       # no temporary file left


@pytest.mark.parametrize("content", ["not a library", "an empty file", "another function's library"])
def test_a_damaged_or_foreign_library_is_compiled_again(content, cache):
    """A file under the library's name that CasADi cannot load, or that holds
    another function: compiled again (the file is placed before this process
    loads that name: a loaded library is the process's own from then on)."""
    _, fn, _ = _function("sps_s_opt.yaml")
    _, other, _ = _function("ups_upr_s_opt.yaml")
    _, _, target = C.library(fn)
    if content == "another function's library":
        C.compiled(other)
        (foreign,) = cache.iterdir()
        target.write_bytes(foreign.read_bytes())
    else:
        target.write_bytes(content.encode() if content != "an empty file" else b"")
    before = len(C.compiles)
    got = C.compiled(fn)
    assert got is not fn and C.same_bits(fn, got)
    assert C.compiles[before:] == [fn.name()]


@pytest.mark.parametrize("how", ["no compiler", "a compiler that fails", "switched off", "OPTDESIGN_FAST=0"])
def test_otherwise_the_virtual_machine_runs(how, cache, monkeypatch, tmp_path):
    _, fn, _ = _function("cpr_rrr_opt.yaml")
    if how == "no compiler":
        monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    elif how == "a compiler that fails":
        monkeypatch.setenv("CC", "false")
    elif how == "switched off":
        monkeypatch.setenv(C.ENV_VAR, "0")
    else:
        monkeypatch.setattr(fast, "_override", False)
    assert C.compiled(fn) is fn
    assert not cache.exists() or not any(cache.iterdir())


def test_same_bits_tells_apart_functions_one_ulp_apart():
    import casadi as ca

    x = ca.SX.sym("x", 3)
    three_up = np.nextafter(3.0, 4.0)
    f = ca.Function("f", [x], [x * 3.0])
    g = ca.Function("f", [x], [x * three_up])
    h = ca.Function("f", [x], [x * 3.0])
    probe = C._probe(f)[0]
    assert np.any(probe * 3.0 != probe * three_up)       # they differ at the probe
    assert C.same_bits(f, h)
    assert not C.same_bits(f, g)
    assert not C.same_bits(f, ca.Function("f", [x], [x[:2] * 3.0]))
