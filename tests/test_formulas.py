"""The table of local values (optdesign.formulas): each formula against an
independent computation, the table against the index kinds, the compiled
kernels' columns against the table's numpy formulas, and each derivative
entry against finite differences of its value."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from optdesign import formulas as F
from optdesign.indices import INDEX_KINDS, local_index
from optdesign.local_derivatives import local_derivative
from optdesign.mechanisms.base import IndexRequest

ROOT = Path(__file__).resolve().parents[1]
EPS = np.finfo(float).eps

#: (kind, convention, options) reaching every row of the table
KINDS = [("dynamic", None, {}), ("stiffness", "lambda_min_K", {"k": 2.5}), ("stiffness", "sqrt_lambda_min_K", {"k": 3.0}),
         ("isotropy", "frobenius", {}), ("isotropy", "two_norm", {}), ("dexterity", "plain", {}),
         ("dexterity", "normalized", {}), ("manipulability", None, {}), ("driving", None, {}),
         ("axis_stiffness", None, {"axis": 1, "k": 3.0})]


def _stack(rng, n, K, log_cond):
    """K random n x n matrices with cond_2 = 10^log_cond (singular vectors random)."""
    U = np.linalg.qr(rng.normal(size=(K, n, n)))[0]
    V = np.linalg.qr(rng.normal(size=(K, n, n)))[0]
    s = np.logspace(0, -log_cond, n) * rng.uniform(0.5, 2.0, (K, 1))
    return U @ (s[..., None] * np.swapaxes(V, -1, -2))


def _direct_one(name, Jk, Mk, c, a):
    """The value of one matrix straight from numpy.linalg (no SVD where another route exists)."""
    if name == "dynamic":
        return np.linalg.norm(Mk, 2)
    if name == "col_sq":
        return c * np.linalg.norm(Jk[:, a]) ** 2
    if name in ("det_JJt", "det_JtJ"):
        return abs(np.linalg.det(Jk))
    if name == "cond_fro":
        return np.linalg.cond(Jk, "fro")
    if name == "cond_2":
        return np.linalg.cond(Jk)
    Ji = np.linalg.inv(Jk)
    if name == "inv_cond_fro":
        return c / (np.linalg.norm(Jk, "fro") * np.linalg.norm(Ji, "fro"))
    return {"sigma_min_sq": c / np.linalg.norm(Ji, 2) ** 2, "sigma_min": c / np.linalg.norm(Ji, 2)}[name]


def _direct(name, J, M, c, a):
    return np.array([_direct_one(name, Jk, Mk, c, a) for Jk, Mk in zip(J, M)])


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
@pytest.mark.parametrize("log_cond", [0.5, 2.0, 7.0])
def test_each_formula_matches_a_direct_computation(n, log_cond):
    rng = np.random.default_rng(10 * n + int(2 * log_cond))
    J, M = _stack(rng, n, 40, log_cond), _stack(rng, n, 40, 1.0)
    cond = np.linalg.cond(J)
    tol = np.maximum(1e-12, 100 * EPS * cond)     # ill-conditioned: the accuracy of either route
    for kind, conv, opts in KINDS:
        row, c, a = F.select(kind, conv, opts, n)
        got = row.value(F.Operands(J=J, M=M), c, a)
        ref = _direct(row.name, J, M, c, a)
        rel = np.abs(got - ref) / np.abs(ref)
        # sigma_max(M) and the column sums do not lose digits with cond(J); the
        # Gram determinants det(J J^T), det(J^T J) lose eps cond(J)^2
        gram = np.maximum(1e-12, 100 * EPS * cond ** 2)
        ok = rel <= {"dynamic": 1e-12, "col_sq": 1e-12, "det_JJt": gram, "det_JtJ": gram}.get(row.name, tol)
        assert ok.all(), (row.name, float(np.max(rel)))
        # the numpy path of the index is this row
        assert np.array_equal(local_index(kind, J=J, M=M, convention=conv, options=opts), got, equal_nan=True)


def test_values_that_cannot_be_computed_score_worst():
    """Non-finite and exactly singular matrices: inf for values to be
    minimized, 0 for values to be maximized (the row's sense)."""
    n = 3
    J = np.stack([np.full((n, n), np.nan), np.zeros((n, n)), np.outer([1.0, 2, 3], [1.0, 0, 1])])
    J[0, 1, 1] = 1.0
    for kind, conv, opts in KINDS:
        row, c, a = F.select(kind, conv, opts, n)
        with np.errstate(all="ignore"):
            v = row.value(F.Operands(J=J, M=J), c, a)
        if row.name in ("col_sq", "dynamic"):          # defined for singular matrices: only the non-finite one
            v = v[:1]
        assert np.all(v == (np.inf if row.sense == "min" else 0.0)), (row.name, v)


def test_the_table_and_the_index_kinds_agree():
    ids = [r.id for r in F.VALUES.values()]
    assert sorted(set(ids)) == list(range(F.COL0 + 1))
    assert [i for i in ids if ids.count(i) > 1] == [F.DET, F.DET]    # sqrt det(J J^T), sqrt det(J^T J): |det J|
    assert F.NVAL == F.COL0 + F.NCOL
    seen = set()
    for kind, spec in INDEX_KINDS.items():
        if spec.needs == "C":     # a value the mechanism gives (chain mechanisms' constraint singularity): no row
            assert F.kernel_value(kind, None, (), 3) is None
            continue
        for conv in (None,) + spec.conventions:
            row, _, _ = F.select(kind, conv, {}, 3)
            assert row.sense == spec.sense and row.needs == spec.needs, (kind, conv)
            seen.add(row.name)
            # the kernels' column and factor give the same value as the row
            rid, c = F.kernel_value(kind, conv, (("k", 2.0),) if "k" in spec.options else (), 3)
            rr, c2, _ = F.select(kind, conv, {"k": 2.0}, 3)
            assert rid == rr.id and np.isclose(c, c2, rtol=1e-15, atol=0), (kind, conv)
    assert seen == set(F.VALUES)
    # what the kernels do not compute
    assert F.kernel_value("isotropy", None, (("k", -1.0),), 3) is None
    assert F.kernel_value("dynamic", None, (("x", 1.0),), 3) is None
    assert F.kernel_value("axis_stiffness", None, (("axis", 3),), 3) is None
    assert F.kernel_value("axis_stiffness", None, (("axis", 2),), 3) == (F.COL0 + 2, 1.0)
    assert F.kernel_value("nonsense", None, (), 3) is None
    assert F.kernel_value("axis_stiffness", "frobenius", (), 3) is None
    for kind, conv in (("nonsense", None), ("isotropy", "nonsense"), ("axis_stiffness", "frobenius")):
        with pytest.raises(ValueError, match="no local value"):
            F.select(kind, conv, {}, 3)


def test_the_table_imports_numpy_only():
    tree = ast.parse((ROOT / "optdesign" / "formulas.py").read_text())
    mods = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    mods |= {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert mods <= {"numpy", "math", "dataclasses", "collections.abc", "__future__"}, mods


@pytest.mark.parametrize("n", [2, 3, 6])
def test_derivatives_agree_with_finite_differences(n):
    """Each row's derivative entry against central differences of its value
    entry along random directions, and the entry's value against the value."""
    rng = np.random.default_rng(n)
    J, M = _stack(rng, n, 30, 1.0), _stack(rng, n, 30, 0.5)
    dJ, dM = rng.normal(size=J.shape + (2,)), rng.normal(size=M.shape + (2,))
    h = 1e-6
    for kind, conv, opts in KINDS:
        row, c, a = F.select(kind, conv, opts, n)
        v, g = local_derivative(kind, conv, opts, J, dJ, M, dM)
        ref = row.value(F.Operands(J=J, M=M), c, a)
        assert np.allclose(v, ref, rtol=1e-12, atol=0), row.name
        for p in range(2):
            fd = (row.value(F.Operands(J=J + h * dJ[..., p], M=M + h * dM[..., p]), c, a)
                  - row.value(F.Operands(J=J - h * dJ[..., p], M=M - h * dM[..., p]), c, a)) / (2 * h)
            scale = np.maximum(np.abs(fd), np.abs(ref))
            assert np.all(np.abs(g[..., p] - fd) <= 1e-6 * scale), (row.name, p)


def _p4s_legs(D, seed):
    from optdesign.config import load_config
    from optdesign.mechanisms import get

    cfg = load_config(ROOT / "configs" / "p4s_legs.yaml")
    rng = np.random.default_rng(seed)
    kw = dict(cfg.parameters)
    kw.update({k: (dv.value * rng.uniform(0.95, 1.05, D))[:, None] for k, dv in cfg.design_variables.items()})
    return get(cfg.mechanism)(**kw), cfg


def test_the_described_kernel_computes_each_id_as_the_table():
    """The compiled kernel's column of every id (via global_statistics at one
    point at a time: the mean over one point is the point's value) against the
    table's numpy formula on the numpy path's own J and M, at points the kernel
    keeps (reach code 1), on the shipped description configs/p4s_legs.yaml."""
    from optdesign.mechanisms.described import compiled

    if compiled.kernels() is None:
        pytest.skip("numba not available")
    mech, _ = _p4s_legs(12, 4)
    dof = mech.dof
    kinds = KINDS + [("axis_stiffness", None, {"axis": 0}), ("axis_stiffness", None, {"axis": 2, "k": 2.0})]
    reqs = [IndexRequest(f"r{i}", k, c, tuple(sorted(o.items()))) for i, (k, c, o) in enumerate(kinds)]
    ids = {v for _, v, _ in compiled.plan(reqs, dof, True)}
    assert ids == set(range(F.COL0 + dof))                       # every id of a 3-column J
    home = np.array([[0.0, 0.0, 0.57]])
    for X in (home, home + [[0.03, -0.02, 0.01]], home + [[-0.05, 0.04, -0.03]]):
        assert np.all(compiled.reach_codes(mech, X) == 1)
        got, _ = compiled.global_statistics(mech, reqs, X)
        mats = mech.index_matrices(X, {"J", "M"})
        for r, (kind, conv, opts) in zip(reqs, kinds):
            ref = local_index(kind, J=mats["J"], M=mats["M"], convention=conv, options=opts)[:, 0]
            rel = np.abs(got[r.name]["mean"] - ref) / np.abs(ref)
            assert np.all(rel < 1e-12), (kind, conv, opts, float(np.max(rel)))


def test_the_p4s_kernel_computes_each_id_as_the_table():
    """The 3-P(4S) through the engine (its description): the values of the
    table's ids 0..4 against the table's numpy formulas on the numpy model's J and M."""
    from optdesign import engine
    from optdesign.mechanisms.base import IndexRequest
    from optdesign.mechanisms.p4s import P4S

    if engine.kernel_module() is None:
        pytest.skip("numba not available")
    names = {F.DYN: ("dynamic", None), F.SMIN2: ("stiffness", "lambda_min_K"), F.SMIN: ("stiffness", "sqrt_lambda_min_K"),
             F.FRO: ("isotropy", "frobenius"), F.TWO: ("isotropy", "two_norm")}
    reqs = [IndexRequest(f"v{i}", *kc) for i, kc in names.items()]
    assert [F.kernel_value(r.kind, r.convention, (), 3) for r in reqs] == [(i, 1.0) for i in names]
    mech = P4S(r_a=np.array([0.21, 0.25])[:, None], r_b=np.array([0.71, 0.67])[:, None], L=0.38, d=0.12,
               phi=np.radians([35.0, 30.0])[:, None])
    X = np.array([[0.0, 0.0, 0.57], [0.03, -0.02, 0.56], [-0.04, 0.03, 0.59]])
    vals, reach = mech.local_values(reqs, X)
    assert reach.all()
    ops = F.Operands(J=mech.jacobian(X), M=mech.mass_matrix(X))
    for i in names:
        row = next(v for v in F.VALUES.values() if v.id == i)
        ref = row.value(ops, 1.0, 0)
        assert np.max(np.abs(vals[f"v{i}"] - ref) / ref) < 1e-12, row.name