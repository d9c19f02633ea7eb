"""The engine's two tiers give the same bits: the generic dense routines
(optdesign.engine.inverse, .eigen, .mass: n read at run time, compiled once for every shape)
against the fixed-size code optdesign.engine.codegen writes for one shape
(run here as plain Python: IEEE arithmetic, the same operations), routine by
routine, for every size and the pose-column kinds of every pose type, on
random, scaled, nearly singular and degenerate inputs; the kernel's digest of
the files compiled into it; the engine's thread split and tier choice."""
from __future__ import annotations

import ast
import math
import types
from pathlib import Path

import numpy as np
import pytest

from optdesign import engine
from optdesign.engine import codegen as G
from optdesign.engine import eigen as Dn
from optdesign.engine import layout as Lay

BLK = Lay.BLK
K = pytest.importorskip("optdesign.engine.kernels")


def _pure(fn, **names):
    glb = dict(fn.__globals__)
    glb.update(_u=int, **names)
    return types.FunctionType(fn.__code__, glb)


#: math with numpy's error model (a division by zero or a square root of a
#: negative number gives inf / NaN, as in the compiled code), correctly rounded
_MATH = types.SimpleNamespace(sqrt=lambda x: np.sqrt(np.float64(x)), pi=math.pi)

_count_below = _pure(Dn._count_below)
_bisect = _pure(Dn.bisect_flagged, _count_below=_count_below)
NAMES = {**{k: getattr(Lay, k) for k in G.GLOBALS if hasattr(Lay, k)}, "math": _MATH, "np": np, "_u": int,
         "_lmax3_point": Dn._lmax3_point.py_func,
         "_bisect_flagged": lambda T, out, V, nt, m: _bisect(T, out, V, len(nt), m)}


def _gen(source):
    ns = dict(NAMES)
    exec(compile(source, "<generated>", "exec"), ns)  # noqa: S102 - the generated code, run as plain Python
    fn = ns["impl"]

    def run(*args):
        with np.errstate(all="ignore"):
            return fn(*[np.float64(a) if isinstance(a, float) else a for a in args])
    return run


def _block(M):
    """The rows of a block: entry (r, c) of point j at [(r n + c) BLK + j] (M: (BLK, n, n))."""
    return np.ascontiguousarray(M.reshape(BLK, -1).T).ravel()


def _matrices(rng, n):
    """BLK test matrices: Gaussian, scaled by 1e-3 and 1e3, nearly singular, a repeated column, graded."""
    A = rng.normal(size=(BLK, n, n))
    A[:4] *= 1e-3
    A[4:8] *= 1e3
    if n > 1:
        w = rng.normal(size=(8, n - 1))
        A[8:16, -1] = np.einsum("ki,kij->kj", w, A[8:16, :-1]) + 10.0 ** rng.uniform(-12, -4, (8, 1))
        A[16, :, 0] = A[16, :, -1]
    A[17:20] *= 10.0 ** rng.uniform(-6, 0, (3, 1, n))
    return A


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_inverse_generic_equals_the_generated_code(n):
    """|det|, ||A^-1||_F^2 and U (A^-1, or R^-1 of A = QR for n >= 4: its upper triangle) bit for bit."""
    rng = np.random.default_rng(100 + n)
    A = _matrices(rng, n)
    det, i2, U = K.inverse_stack(np.ascontiguousarray(A), None)
    if n <= 3:   # the adjugate: the same routine in both tiers (there is no generated _inverse)
        assert G.routine_source("_inverse", n) is None
        return
    Ug = np.zeros(n * n * BLK)
    V = np.zeros((Lay.NVS + 3 * n) * BLK)
    _gen(G.routine_source("_inverse", n))(_block(A), Ug, V, (0,) * n, BLK)
    Ug = Ug.reshape(n * n, BLK).T.reshape(BLK, n, n)
    iu = np.triu_indices(n)
    assert np.array_equal(U[:, iu[0], iu[1]], Ug[:, iu[0], iu[1]], equal_nan=True)   # NaN: the singular one
    assert np.array_equal(det, V[Lay.VDET * BLK:][:BLK]) and np.array_equal(i2, V[Lay.VI2 * BLK:][:BLK], equal_nan=True)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
@pytest.mark.parametrize("rows", [False, True])
def test_lambda_max_generic_equals_the_generated_code(n, rows):
    """lambda_max of X^T X and of X X^T (X upper triangular for n >= 4, as the
    inverse leaves it) bit for bit, the bisected points included (a zero
    matrix, a double top eigenvalue)."""
    rng = np.random.default_rng(200 + 10 * n + rows)
    X = _matrices(rng, n)
    X[20] = 0.0
    if n >= 2:
        Q = np.linalg.qr(rng.normal(size=(n, n)))[0]
        X[21] = np.diag(np.r_[1.0, 1.0, rng.uniform(0.1, 0.9, n - 2)]) @ Q.T
    if rows and n >= 4:
        X = np.triu(X)
    got = K.gram_lambda_max_stack(np.ascontiguousarray(X), rows, None)
    out = np.zeros(BLK)
    V = np.zeros((Lay.NVS + 3 * n) * BLK)
    V[Lay.VMASK * BLK:(Lay.VMASK + 1) * BLK] = 1.0
    T = np.zeros(2 * n * BLK)
    _gen(G.routine_source("_lmax_rows" if rows else "_lmax_cols", n))(_block(X), out, T, V, (0,) * n, BLK)
    assert np.array_equal(got, out)
    G_ = X @ np.swapaxes(X, 1, 2) if rows else np.swapaxes(X, 1, 2) @ X
    ref = np.linalg.eigvalsh(G_)[:, -1]
    assert np.all(np.abs(got - ref) <= 2e-13 * np.max(ref))


def _rigid_rows(rng):
    B = np.zeros(Lay.NB * BLK)
    B[:] = rng.normal(size=Lay.NB * BLK)
    B[Lay.BA * BLK:(Lay.BA + 1) * BLK] = rng.uniform(1, 5, BLK)
    return B


@pytest.mark.parametrize("kinds, rods", [((0, 1, 2), True), ((3, 4, 5), False), ((6, 7, 5), False),
                                         ((0, 1, 2, 6, 7, 5), False), ((0, 1, 2, 3, 4, 5), True), ((0, 1, 5), True),
                                         ((0, 2, 6, 7), True), ((1, 6), True), ((5,), False), ((7,), True),
                                         ((0, 1, 2, 3, 4), True), ((6, 7), False)])
def test_dynamic_product_generic_equals_the_generated_code(kinds, rods):
    """W = U^T M_p and M_p itself for the pose-column kinds of every pose type
    (unit twist columns, Euler columns), with and without rods, bit for bit."""
    n = len(kinds)
    rng = np.random.default_rng(sum(kinds) + 17 * n + rods)
    B = _rigid_rows(rng)
    Lg = rng.normal(size=(n, Lay.NLG * BLK))
    J = _block(rng.normal(size=(BLK, n, n)))
    Kp = _block(rng.normal(size=(BLK, n, n)))
    FRb = rng.normal(size=Lay.NFR * BLK)
    U = rng.normal(size=(BLK, n, n))
    if n >= 4:
        U = np.triu(U)
    U = _block(U)
    spec = G.KernelSpec(kinds, rods, True)
    ct = np.array(kinds, dtype=np.int64)
    for mass_only in (False, True):
        got = K.dyn_stack(B, Lg, J, Kp, FRb, U, ct, rods, mass_only, None)
        W = np.zeros(n * n * BLK)
        _gen(G.routine_source("_mass_p" if mass_only else "_dyn_w", n, spec))(B, Lg, J, Kp, FRb, U, W, (0,) * n, None,
                                                                             BLK)
        assert np.array_equal(got, W), mass_only


def test_the_digest_of_the_compiled_sources_is_current():
    """kernels.py records the digest of the files compiled into its kernels
    (numba's cache watches kernels.py only): editing them must change it."""
    assert K.ENGINE_DIGEST == K.engine_digest(), f"set ENGINE_DIGEST in optdesign/engine/kernels.py to {K.engine_digest()!r}"


def test_the_warm_up_compiles_the_signatures_the_kernel_asks_for(monkeypatch):
    """The helper of the first compile (optdesign.engine.warmup) types its calls
    for fixed argument types: those must be the kernel's own on the generic
    tier, for a planar and a spatial mechanism, else the helper's work is lost
    (the kernel would compile the routines again; the results are the same)."""
    from optdesign.config import load_config
    from optdesign.engine import warm_calls as WC
    from optdesign.evaluate import index_requests, mechanism_class, workspace_of

    monkeypatch.setenv(engine.TIER_VAR, "generic")
    for name in ("delta.yaml", "gough_stewart.yaml"):
        cfg = load_config(__import__("conftest").CONFIGS / name)
        X = workspace_of(cfg).X[:300]
        mech = mechanism_class(cfg)(**cfg.parameters, **{k: dv.value for k, dv in cfg.design_variables.items()})
        mech.global_statistics(index_requests(cfg, list(cfg.indices)), X)
    generic = {sig for sig in K.run_tasks.signatures if sig[-2] == WC.KERNEL_TYPES[-2]}
    assert generic == {WC.KERNEL_TYPES}
    assert set(K.combine.signatures) == {WC.COMBINE_TYPES}


def _calls_at_import(tree):
    """The calls a module makes as it is imported: its statements, with the
    decorators and default values of its functions, not their bodies."""
    out = []

    def walk(node):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for n in node.decorator_list + node.args.defaults + node.args.kw_defaults:
                if n is not None:
                    walk(n)
            return
        if isinstance(node, ast.Lambda):
            return
        if isinstance(node, ast.Call):
            out.append(node)
        for child in ast.iter_child_nodes(node):
            walk(child)

    walk(tree)
    return out


def test_collecting_the_tests_loads_no_kernel_module():
    """A kernel module's first load through optdesign.fast.KernelModule starts
    the engine's first-compile helper (optdesign.engine.warmup) when nothing is
    cached: done while collecting, every test worker of a fresh checkout
    started one, compiling the same routines twice.  No test file calls
    ``available()`` or ``get()`` of a kernel module (or ``kernel_module()``)
    as it is imported; a skip condition on the kernels is a string, evaluated
    as a test is set up."""
    found = []
    for path in sorted(Path(__file__).parent.glob("test_*.py")):
        for call in _calls_at_import(ast.parse(path.read_text())):
            f = call.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            owner = ast.unparse(f.value) if isinstance(f, ast.Attribute) else ""
            if name == "kernel_module" or (name in ("available", "get") and "KERNELS" in owner):
                found.append(f"{path.name}:{call.lineno}: {ast.unparse(call)}")
    assert not found, found


def _called_names(fn: ast.FunctionDef) -> set[str]:
    """The plain names a function's body calls (not its decorators')."""
    return {n.func.id for stmt in fn.body for n in ast.walk(stmt)
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}


def test_the_warm_up_calls_every_routine_the_kernel_links():
    """The engine's first compile on two processes (optdesign.engine.warmup)
    compiles the routines run_tasks links before run_tasks compiles, through
    the calls of warm_calls.here_calls and helper_calls: every routine the
    kernel calls (itself or through its inlined helpers) is called there, and
    nothing else is.  The arguments there are made as the kernel makes them,
    so that the signatures agree: benchmarks/bench_engine.py (part 1) records
    numba's compile events of a first compile from an empty cache, where
    run_tasks's own compile must compile none of them (it takes about 20
    CPU-s, a benchmark's time)."""
    import builtins

    from optdesign.engine import kernels, warm_calls

    def defs(module):
        return {f.name: f for f in ast.parse(Path(module.__file__).read_text()).body
                if isinstance(f, ast.FunctionDef)}

    kern = defs(kernels)
    inline = {name for name, f in kern.items() if any("inline" in ast.unparse(d) for d in f.decorator_list)}
    assert {"_block", "tail_j", "tail_w", "tail_codes"} <= inline
    seen, linked, todo = set(), set(), ["run_tasks"]
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            for callee in _called_names(kern[name]):
                if callee in inline:
                    todo.append(callee)
                elif not hasattr(builtins, callee):
                    linked.add(callee)
    warm = defs(warm_calls)
    called = {c for f in ("here_calls", "helper_calls") for c in _called_names(warm[f]) if not hasattr(builtins, c)}
    assert linked == called, (sorted(linked - called), sorted(called - linked))
    assert {"legs", "inverse_sel", "lmax_sel", "dyn_sel", "_chunk_stats"} <= linked


def test_the_routines_cache_files_carry_the_digest_of_their_sources():
    """The engine's routines are cached under names that carry the digest of
    every source compiled into them, so an edit of any of them never loads a
    stale routine; the digest moves with the files' contents."""
    from optdesign.engine import digest, inverse, legs

    key = digest.leaf_key()
    assert legs._leg_strut.__qualname__.endswith(key) and inverse.inverse.__qualname__.endswith(key)
    assert K._carve.__qualname__.endswith(key) and Dn.lmax.__qualname__.endswith(key)
    assert set(digest.LEAF_SOURCES) >= set(K._SOURCES) | {"engine/kernels.py"}
    assert key == digest.sources_digest(digest.LEAF_SOURCES)[:12]


def test_the_sources_digest_moves_with_any_byte_of_any_file(tmp_path):
    from optdesign.engine import digest

    names = ["a.py", "b/c.py"]
    (tmp_path / "b").mkdir()
    (tmp_path / "a.py").write_text("X = 1\n")
    (tmp_path / "b/c.py").write_text("Y = 2\n")
    base = digest.sources_digest(names, tmp_path)
    assert digest.sources_digest(names, tmp_path) == base
    (tmp_path / "b/c.py").write_text("Y = 3\n")
    assert digest.sources_digest(names, tmp_path) != base
    (tmp_path / "b/c.py").write_text("Y = 2\n")
    assert digest.sources_digest(names, tmp_path) == base


def test_the_tier_choice(monkeypatch):
    spec = G.KernelSpec((0, 1, 2), True, False)
    monkeypatch.delenv(engine.TIER_VAR, raising=False)
    assert engine.tier(spec) is None
    monkeypatch.setenv(engine.TIER_VAR, "specialized")
    assert engine.tier(spec) == spec
    monkeypatch.setenv(engine.TIER_VAR, "generic")
    engine.specialize(spec)
    try:
        assert engine.tier(spec) is None
        monkeypatch.setenv(engine.TIER_VAR, "auto")
        assert engine.tier(spec) == spec
    finally:
        engine._SPECIALIZED.discard(spec)


def test_a_large_run_specializes_its_shape(monkeypatch):
    """Evaluator.from_config puts a run whose estimated kernel work reaches
    SPECIALIZE_WORK on the specialized tier of its shape, and leaves a small one."""
    from optdesign.config import load_config
    from optdesign.evaluate import SPECIALIZE_WORK, Evaluator, run_kernel_work, workspace_of
    from optdesign.mechanisms.described.packing import description_codes, kernel_spec

    monkeypatch.delenv(engine.TIER_VAR, raising=False)
    cfg = load_config(__import__("conftest").CONFIGS / "delta_opt.yaml")
    ev = Evaluator.from_config(cfg)
    spec = kernel_spec(description_codes(ev.mechanism.description))
    assert run_kernel_work(cfg, workspace_of(cfg).n) < SPECIALIZE_WORK and engine.tier(spec) is None
    import yaml

    from optdesign.config import parse_config

    raw = yaml.safe_load((__import__("conftest").CONFIGS / "delta_opt.yaml").read_text())
    raw["optimizer"].update(population=2000, generations=1000)
    big = parse_config(yaml.safe_dump(raw))
    try:
        assert run_kernel_work(big, workspace_of(big).n) >= SPECIALIZE_WORK
        Evaluator.from_config(big)
        assert engine.tier(spec) == spec
    finally:
        engine._SPECIALIZED.discard(spec)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["delta.yaml", "sps_s_legs.yaml"])
def test_the_specialized_tier_gives_the_generic_tiers_bits(monkeypatch, name):
    """A shape through the specialized tier (its generated routines compiled)
    and through the generic one: every statistic and every local value the
    same.  The two shapes hold every choice of the generated code
    (KernelSpec): the Delta the translation columns (0, 1, 2) with the rods
    of revolute legs, the 3-SPS-S the rotation columns (3, 4, 5) of a
    rotation pose with struts.  (The Gough-Stewart's spatial pose has all six
    columns and no rods: its generated routines compile in about 25 CPU-s,
    these two in about 6 each.)"""
    from optdesign.config import load_config
    from optdesign.evaluate import index_requests, mechanism_class, workspace_of
    from optdesign.mechanisms.described.packing import kernel_spec, shape_codes

    cfg = load_config(__import__("conftest").CONFIGS / name)
    X = workspace_of(cfg).X[:1500]
    rng = np.random.default_rng(3)
    des = {k: dv.value * rng.uniform(0.97, 1.03, (7, 1)) for k, dv in cfg.design_variables.items()}
    req = index_requests(cfg, list(cfg.indices))
    out = {}
    for tier in ("generic", "specialized"):
        monkeypatch.setenv(engine.TIER_VAR, tier)
        mech = mechanism_class(cfg)(**{**cfg.parameters, **des})
        assert (engine.tier(kernel_spec(shape_codes(mech))) is None) == (tier == "generic")
        summary, reach = mech.global_statistics(req, X)
        vals, reach2 = mech.local_values_at(req, np.ascontiguousarray(np.broadcast_to(X[:200], (7, 200, X.shape[1]))))
        out[tier] = (summary, reach, vals, reach2)
    a, b = out["generic"], out["specialized"]
    assert np.array_equal(a[1], b[1]) and np.array_equal(a[3], b[3])
    for name in a[0]:
        for st in ("mean", "min", "max", "std", "count"):
            assert np.array_equal(a[0][name][st], b[0][name][st], equal_nan=True), (name, st)
        assert np.array_equal(a[2][name], b[2][name], equal_nan=True), name


def _zoom_both(mech, request, base, reg, u0, val0, spacing, stop, tol, iterations):
    """The zoom of optdesign.worstcase.search run in the engine (with the starts
    it hands back finished level by level) and level by level throughout."""
    from optdesign.worstcase import search as S

    def make(index):
        m = type(mech)(**{k: np.asarray(v)[index] if np.ndim(v) else v for k, v in mech.params.items()})

        def f(X):
            vals, reach = m.local_values_at([request], np.swapaxes(X, 0, 1))
            c = vals[request.name].T
            return np.where(reach.T & np.isfinite(c), c, np.inf)
        f.zoom = lambda *a: m.zoom_cond(request, *a)
        return f

    design = np.arange(len(u0))
    out = []
    for compiled in (True, False):
        q = S._Quantity(make, design, base, reg)
        if not compiled:
            q.compiled_zoom = lambda *a: None
        u, val = u0.copy(), val0.copy()
        S._zoom(q, u, val, spacing, stop, tol, iterations)
        out.append((u, val))
    return out


def test_the_zoom_in_the_engine_is_the_zoom_level_by_level():
    """The worst-case search's zoom in the engine (``Mechanism.zoom_cond``) and
    level by level in numpy around it give the same bits: 3-P(4S) designs from
    the worst samples of a box W (and the refinement's fine levels), and a
    start the engine hands back at an exactly singular pose (vertical rails,
    rods in the rails' plane: the numpy path's point) that goes on level by level."""
    from optdesign.mechanisms.base import IndexRequest
    from optdesign.mechanisms.p4s import P4S
    from optdesign.worstcase import search as S

    req = IndexRequest("cond", "isotropy", "frobenius")
    rng = np.random.default_rng(7)
    D = 6
    mech = P4S(r_a=rng.uniform(0.21, 0.29, D), r_b=rng.uniform(0.63, 0.71, D), L=np.full(D, 0.38),
               d=np.full(D, 0.12), phi=np.radians(rng.uniform(25, 35, D)))
    reg = {"axes": np.array([0, 1, 2]), "lo": np.array([-0.06, -0.06, 0.53]), "hi": np.array([0.06, 0.06, 0.61]),
           "disc": None}
    u0 = rng.random((D, 3))
    base = np.zeros((D, 3))
    base[:] = reg["lo"] + u0 * (reg["hi"] - reg["lo"])
    val0 = mech.local_values_at([req], base[:, None, :])[0]["cond"][:, 0]
    for spacing, tol, levels in ((0.2, S.TOL, S.ITERATIONS), (4e-4, S.FINE_TOL, S.FINE_LEVELS)):
        (ua, va), (ub, vb) = _zoom_both(mech, req, base, reg, u0, val0, spacing, 50.0, tol, levels)
        assert np.array_equal(ua, ub) and np.array_equal(va, vb)
        assert np.all(va >= val0) and np.any(va > val0)
    # a disc (the cylinder's W): the projection onto it in the engine too
    disc = {"axes": np.array([0, 1]), "lo": np.array([-0.05, -0.05]), "hi": np.array([0.05, 0.05]),
            "disc": (0.0, 0.0, 0.05)}
    base2 = np.c_[np.zeros((D, 2)), np.full(D, 0.57)]
    (ua, va), (ub, vb) = _zoom_both(mech, req, base2, disc, np.full((D, 2), 0.5), val0, 0.4, 50.0, S.TOL, 30)
    assert np.array_equal(ua, ub) and np.array_equal(va, vb)
    # vertical rails: at x = 0.5 the rods lie in the rails' plane (J singular): handed back at the first level
    sing = P4S(r_a=np.array([0.25]), r_b=np.array([0.25 * np.cos(np.arcsin(0.12 / 0.5))]), L=np.array([0.5]),
               d=np.array([0.12]), phi=np.array([np.pi / 2]))
    reg1 = {"axes": np.array([0]), "lo": np.array([0.0]), "hi": np.array([1.0]), "disc": None}
    base1 = np.array([[0.25, 0.0, 1.0]])
    v1 = sing.local_values_at([req], base1[:, None, :])[0]["cond"][:, 0]
    u, val, h = np.array([[0.25]]), v1.copy(), np.array([0.25])
    live, budget = np.array([True]), np.array([30])
    done, bail = sing.zoom_cond(req, base1, reg1, u, val, h, live, budget, np.array([[-1.0], [1.0]]), 1e30, 1e-6)
    assert bail[0] and done[0] == 0
    (ua, va), (ub, vb) = _zoom_both(sing, req, base1, reg1, np.array([[0.25]]), v1, 0.5, 1e30, 1e-6, 30)
    assert np.array_equal(ua, ub) and np.array_equal(va, vb, equal_nan=True)
