"""The generators of the described kernel's fixed-size routines
(optdesign.engine.codegen, the specialized tier), one by one, without numba: each
source parses and defines its function; run as plain Python on small numpy
arrays (a block of BLK points) it matches numpy (QR / inverse / det,
eigvalsh of the Gram matrices, the pose-space mass matrix and W = U^T M_p);
the two-point bodies are two independent copies of one body; the spec and
the numba arguments that carry it; ``optdesign kernel-source`` on every
shipped described config."""
from __future__ import annotations

import ast
import hashlib
import types
from pathlib import Path

import numpy as np
import pytest

from optdesign.engine import codegen as G
from optdesign.engine import eigen as Dn
from optdesign.engine import layout as Lay

ROOT = Path(__file__).resolve().parents[1]
BLK = Lay.BLK
K = pytest.importorskip("optdesign.engine.kernels")


def _pure(fn, **names):
    """A numba dispatcher's Python function with its globals (and the names given) in pure Python."""
    fn = getattr(fn, "py_func", fn)
    glb = dict(fn.__globals__)
    glb.update(_u=int, **names)
    return types.FunctionType(fn.__code__, glb)


#: what the generated code needs, in plain Python (no compilation)
NAMES = {**{k: getattr(Lay, k) for k in G.GLOBALS if hasattr(Lay, k)}, "math": __import__("math"), "np": np,
         "_u": int, "_lmax3_point": Dn._lmax3_point.py_func,
         "_bisect_flagged": lambda T, out, V, nt, m: _pure(Dn.bisect_flagged, _count_below=_pure(Dn._count_below))(
             T, out, V, len(nt), m)}


def _run(source, name="impl"):
    tree = ast.parse(source)
    defs = [s.name for s in tree.body if isinstance(s, ast.FunctionDef)]
    assert defs == [name], defs
    ns = dict(NAMES)
    exec(compile(source, "<generated>", "exec"), ns)  # noqa: S102 - the generated code, run as plain Python
    return ns[name]


def _block(M):
    """The rows of a block: entry (r, c) of point j at [(r n + c) BLK + j] (M: (BLK, n, n))."""
    return np.ascontiguousarray(M.reshape(BLK, -1).T).ravel()


def _unblock(a, n):
    return a[:n * n * BLK].reshape(n * n, BLK).T.reshape(BLK, n, n)


def _scratch(n):
    return np.zeros((Lay.NVS + 3 * n) * BLK), np.zeros(2 * n * BLK)


@pytest.mark.parametrize("n", [4, 5, 6])
def test_qr_inverse(n):
    """U = R^-1 of A = QR: upper triangular, A U orthogonal; |det A| and ||A^-1||_F^2 in V."""
    rng = np.random.default_rng(n)
    A = rng.normal(size=(BLK, n, n))
    U = np.zeros(n * n * BLK)
    V, _ = _scratch(n)
    _run(G.qr_inverse_source(n))(_block(A), U, V, (0,) * n, BLK)
    Ui = _unblock(U, n)
    assert np.all(np.tril(Ui, -1) == 0.0)
    Q = A @ Ui
    np.testing.assert_allclose(np.swapaxes(Q, 1, 2) @ Q, np.broadcast_to(np.eye(n), Q.shape), atol=1e-11)
    np.testing.assert_allclose(V[Lay.VDET * BLK:][:BLK], np.abs(np.linalg.det(A)), rtol=1e-12)
    np.testing.assert_allclose(V[Lay.VI2 * BLK:][:BLK], np.sum(np.linalg.inv(A) ** 2, axis=(1, 2)), rtol=1e-11)
    assert G.routine_source("_inverse", n) == G.qr_inverse_source(n)
    assert G.routine_source("_inverse", 3) is None      # n <= 3: the hand-written adjugate


@pytest.mark.parametrize("n, mode", [(n, m) for n in range(1, 7) for m in ("cols", "rows", "urows")
                                     if n >= 4 or m != "urows"])
def test_lambda_max(n, mode):
    """lambda_max of X^T X (cols), X X^T (rows; urows: X upper triangular, as
    the kernel reads it for n >= 4) against eigvalsh; also with no Newton step,
    where every point goes to the bisection."""
    rng = np.random.default_rng(10 * n + len(mode))
    X = rng.normal(size=(BLK, n, n))
    X[:4] *= 1e-3                              # scaled points
    X[4, :, 0] = X[4, :, -1]                   # a repeated column
    if mode == "urows":
        X = np.triu(X)
    G_ = np.swapaxes(X, 1, 2) @ X if mode == "cols" else X @ np.swapaxes(X, 1, 2)
    ref = np.linalg.eigvalsh(G_)[:, -1]
    for iters in ((G.NEWTON, 0) if n >= 4 else (G.NEWTON,)):
        out = np.zeros(BLK)
        V, T = _scratch(n)
        V[Lay.VMASK * BLK:(Lay.VMASK + 1) * BLK] = 1.0
        _run(G.lmax_source(n, mode, iters))(_block(X), out, T, V, (0,) * n, BLK)
        np.testing.assert_allclose(out, ref, rtol=2e-13 if n >= 4 else 1e-14 * n)
        if n >= 4 and iters == 0:
            assert V[Lay.VV0 * BLK:][:BLK].all()    # none certified without a step: all bisected


def _rigid_matrix(B):
    """The 6 x 6 rigid-body matrices from the ten rows of B ((NB, BLK))."""
    a, s, w = B[Lay.BA], B[Lay.BS:Lay.BS + 3], B[Lay.BW:Lay.BW + 6]
    out = np.zeros((BLK, 6, 6))
    out[:, [0, 1, 2], [0, 1, 2]] = a[:, None]
    C = np.zeros((BLK, 3, 3))
    C[:, 0, 1], C[:, 0, 2], C[:, 1, 2] = s[2], -s[1], s[0]
    C[:, 1, 0], C[:, 2, 0], C[:, 2, 1] = -s[2], s[1], -s[0]
    out[:, :3, 3:] = C
    out[:, 3:, :3] = np.swapaxes(C, 1, 2)
    for k, (r, c) in enumerate([(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]):
        out[:, 3 + r, 3 + c] = out[:, 3 + c, 3 + r] = w[k]
    return out


def _columns(kinds, e):
    """The pose columns S (BLK, 6, n) of the kinds (e: the five Euler-column entries (5, BLK))."""
    S = np.zeros((BLK, 6, len(kinds)))
    for c, k in enumerate(kinds):
        if k < 6:
            S[:, k, c] = 1.0
        elif k == Lay.CT_ROLL:
            S[:, 3:6, c] = e[0:3].T
        else:
            S[:, 3:5, c] = e[3:5].T
    return S


@pytest.mark.parametrize("kinds, rods", [((0, 1, 2), True), ((3, 4, 5), False), ((0, 1, 2, 6, 7, 5), False),
                                         ((0, 2, 6, 7), True), ((1, 6), True), ((5,), False), ((0, 1, 2, 3, 4), True)])
def test_dynamic_product_and_mass_matrix(kinds, rods):
    """M_p = S^T B S + sum_i [gamma_i J_i^T J_i + delta_i (J_i^T K_i + K_i^T J_i)]
    (full, mass_only) and W = U^T M_p (U upper triangular for n >= 4; U = J^-1
    for n <= 3, which the legs' terms use)."""
    spec = G.KernelSpec(kinds, rods, True)
    n = spec.n
    rng = np.random.default_rng(sum(kinds) + 7 * n + rods)
    B = rng.normal(size=(Lay.NB, BLK))
    FRb = np.zeros(Lay.NFR * BLK)
    e = rng.normal(size=(5, BLK))
    FRb[Lay.FRE * BLK:(Lay.FRE + 5) * BLK] = e.ravel()
    J, Kp, U = (rng.normal(size=(BLK, n, n)) for _ in range(3))
    if n >= 4:
        U = np.triu(U)
    else:
        U = np.linalg.inv(J)
    Lg = np.zeros((n, Lay.NLG * BLK))
    ga, de = rng.normal(size=(n, BLK)), rng.normal(size=(n, BLK)) if rods else np.zeros((n, BLK))
    Lg[:, Lay.GGA * BLK:(Lay.GGA + 1) * BLK] = ga
    Lg[:, Lay.GDE * BLK:(Lay.GDE + 1) * BLK] = de
    S = _columns(kinds, e)
    M = np.swapaxes(S, 1, 2) @ _rigid_matrix(B) @ S
    Kr = Kp if rods else np.zeros_like(Kp)
    for i in range(n):
        Ji, Ki = J[:, i, :, None], Kr[:, i, :, None]
        M += ga[i][:, None, None] * (Ji @ np.swapaxes(Ji, 1, 2))
        M += de[i][:, None, None] * (Ji @ np.swapaxes(Ki, 1, 2) + Ki @ np.swapaxes(Ji, 1, 2))
    for mass_only, ref in ((True, M), (False, np.swapaxes(U, 1, 2) @ M)):
        W = np.zeros(n * n * BLK)
        src = G.dyn_source(spec, mass_only)
        assert src == G.routine_source("_mass_p" if mass_only else "_dyn_w", n, spec)
        _run(src)(B.ravel(), Lg, _block(J), _block(Kp), FRb, _block(U), W, (0,) * n, None, BLK)
        scale = np.max(np.abs(ref), axis=(1, 2))[:, None, None]
        assert np.all(np.abs(_unblock(W, n) - ref) <= 1e-13 * scale)


def _renamed_copy(stmt: ast.stmt, local: set) -> str:
    class R(ast.NodeTransformer):
        def visit_Name(self, node):
            if node.id == "j":
                return ast.copy_location(ast.Name("j2", node.ctx), node)
            if node.id in local:
                return ast.copy_location(ast.Name(node.id + "_b", node.ctx), node)
            return node

    return ast.unparse(R().visit(ast.parse(ast.unparse(stmt)).body[0]))


@pytest.mark.parametrize("source", [G.qr_inverse_source(4), G.qr_inverse_source(6), G.lmax_source(4, "cols"),
                                    G.lmax_source(5, "urows"), G.lmax_source(6, "rows", 2)])
def test_two_point_bodies_are_two_independent_copies(source):
    """The loop over two points (j, j2 = j + BLK/2): statements alternate, the
    second of each pair is the first with every local of the body suffixed
    _b and j -> j2, so the copies share no local."""
    loop = next(s for s in ast.parse(source).body[0].body if isinstance(s, ast.For))
    assert ast.unparse(loop.iter) == f"range({BLK // 2})" and ast.unparse(loop.body[0]) == f"j2 = j + {BLK // 2}"
    body = loop.body[1:]
    assert len(body) % 2 == 0
    first, second = body[0::2], body[1::2]
    local = {t.id for s in first for t in ast.walk(s) if isinstance(t, ast.Name) and isinstance(t.ctx, ast.Store)}
    for a, b in zip(first, second):
        assert ast.unparse(b) == _renamed_copy(a, local)
    used = {t.id for s in second for t in ast.walk(s) if isinstance(t, ast.Name)}
    assert not (used & local)


#: sha256 (16 hex) of the routines (ROUTINES order, functions named impl) as the
#: generator of a07461a (regex renaming of the second copy) wrote them, but
#: for n <= 3, whose dynamic product W = U^T M_p takes the legs' terms through
#: J U = I since the 3-P(4S) moved onto the engine (the hand kernel's form,
#: no cancellation near singular poses): the compiled kernels of the shipped
#: shapes are unchanged as long as these hold (a deliberate change of the
#: generated code updates them, after a bitwise check of the results)
GOLDEN = {((0, 1, 2), True, False): "2facb773471d0b98",       # delta, p4s_legs
          ((3, 4, 5), False, True): "a56d84754777d7a2",       # sps_s_legs
          ((0, 1, 2, 6, 7, 5), False, True): "0e85482194ef8d7e",   # gough_stewart
          ((6, 7), True, True): "20deb3623034c365", ((0, 1, 2, 5), True, True): "784b08f6d0c63332",
          ((0, 1, 2, 6, 7), True, True): "0cbb9de5dc0b8adf"}


def _digest(spec):
    src = [G.routine_source(s, spec.n, spec) for s in G.ROUTINES]
    return hashlib.sha256("".join(s for s in src if s is not None).encode()).hexdigest()[:16]


@pytest.mark.parametrize("key", list(GOLDEN))
def test_generated_text_is_unchanged(key):
    assert _digest(G.KernelSpec(*key)) == GOLDEN[key]


def test_the_spec_and_its_numba_arguments():
    """Hashable, printable, normalized; the numba arguments carry it (through
    numba's type of cspec) and read back to the same spec."""
    numba = pytest.importorskip("numba")
    spec = G.KernelSpec(np.array([0, 1, 2, 6, 7, 5]), np.bool_(False), 1)
    assert spec == G.KernelSpec((0, 1, 2, 6, 7, 5), False, True) and spec.n == 6
    assert repr(spec) == "KernelSpec(kinds=(0, 1, 2, 6, 7, 5), rods=False, rot=True)"
    assert len({spec, G.KernelSpec((0, 1, 2, 6, 7, 5), False, True), G.KernelSpec((0, 1, 2), True, False)}) == 2
    for s in (spec, G.KernelSpec((3, 4, 5), False, True), G.KernelSpec((0,), True, False)):
        nt, cspec = s.numba_args()
        assert nt == (0,) * s.n
        assert G.size_of_type(numba.typeof(nt)) == s.n and G.KernelSpec.of_type(numba.typeof(cspec)) == s


def _described_configs(chains: bool = False):
    """The configs with a description (with chain legs or parasitic coordinates:
    ``chains``; those run on the engine's chain kernel, the same code for every shape)."""
    out = []
    for p in sorted((ROOT / "configs").glob("*.yaml")):
        text = p.read_text()
        if "\nmechanism:\n" in text or text.startswith("mechanism:\n"):
            if (("kind: chain" in text) or ("independent:" in text)) == chains:
                out.append(p)
    return out


@pytest.mark.parametrize("path", _described_configs(chains=True), ids=lambda p: p.stem)
def test_kernel_source_refuses_chain_descriptions(path, capsys):
    from cli_helpers import run_main

    rc, out, err = run_main(capsys, ["kernel-source", str(path)])
    assert rc == 2 and out == "" and "chain legs runs on the engine's chain kernel" in err


@pytest.mark.parametrize("path", _described_configs(), ids=lambda p: p.stem)
def test_kernel_source_of_every_described_config(path, capsys):
    from cli_helpers import run_main

    rc, out, err = run_main(capsys, ["kernel-source", str(path)])
    assert rc == 0 and err == ""
    tree = ast.parse(out)
    names = [s.name for s in tree.body if isinstance(s, ast.FunctionDef)]
    n = int(out.split("(n = ", 1)[1].split(";", 1)[0])
    assert names == [s for s in G.ROUTINES if n >= 4 or s != "_inverse"]
    assert out.startswith("# The generated routines of") and path.name in out.splitlines()[0]


def test_kernel_source_out_file_and_refusals(tmp_path, capsys):
    from cli_helpers import run_main

    assert len(_described_configs()) >= 4
    target = tmp_path / "gs.py"
    rc, out, _ = run_main(capsys, ["kernel-source", str(ROOT / "configs" / "gough_stewart.yaml"), "--out", str(target)])
    assert rc == 0 and "wrote" in out
    ast.parse(target.read_text())
    rc, _, _ = run_main(capsys, ["kernel-source", str(ROOT / "configs" / "delta.yaml"), "--out", str(target)])
    assert rc == 0 and "delta" in target.read_text().splitlines()[0]       # its own output is overwritten
    mine = tmp_path / "mine.py"
    mine.write_text("print('mine')\n")
    for argv, what in ((["configs/p4s_paper.yaml"], "p4s has no generated kernel"),
                       (["configs/delta.yaml", "--out", str(mine)], "not written by kernel-source"),
                       (["configs/delta.yaml", "--out", str(tmp_path / "x.txt")], "ending in .py"),
                       (["configs/missing.yaml"], "missing.yaml")):
        rc, out, err = run_main(capsys, ["kernel-source", str(ROOT / argv[0]), *argv[1:]])
        assert rc == 2 and what in err and len(err.strip().splitlines()) == 1, (argv, err)
    assert mine.read_text() == "print('mine')\n"
