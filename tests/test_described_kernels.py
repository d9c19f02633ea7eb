"""The small dense routines of the described mechanisms' compiled kernel,
against numpy.linalg and exact rational arithmetic: lambda_max of Gram
matrices (closed forms for n <= 3, tridiagonalization + Newton steps + Sturm
check + bisection for n >= 4) on random, nearly degenerate and exactly
degenerate spectra; the adjugate inverse with compensated minors (n <= 3) and
the Householder R^-1 (n >= 4); and the compiled path on the pose cases the
config tests do not reach (two angles with a fixed one that varies per design:
n = 2 and per-design frames)."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from described_helpers import description

from optdesign import fast
from optdesign.config import IndexSpec, parse_config
from optdesign.evaluate import evaluate

K = pytest.importorskip("optdesign.engine.kernels")

EPS = np.finfo(float).eps


def _orthogonal(rng, K_, n):
    Q, R = np.linalg.qr(rng.normal(size=(K_, n, n)))
    return Q * np.sign(np.diagonal(R, axis1=1, axis2=2))[:, None, :]


def _spectra(rng, K_, n):
    """Eigenvalue sets (name, (K, n)): random, nearly degenerate tops, exactly
    degenerate (double top, all equal, rank deficient, zero), graded."""
    out = {"random": rng.uniform(0.05, 1.0, (K_, n)), "all equal": np.full((K_, n), 0.7),
           "graded": 10.0 ** rng.uniform(-8, 0, (K_, n))}
    if n == 1:
        return out
    lam = rng.uniform(0.05, 0.9, (K_, n))
    lam[:, 0] = 1.0
    lam[:, 1] = 1.0 - 10.0 ** rng.uniform(-15, -2, K_)
    out["near double top"] = lam
    if n >= 3:
        lam = rng.uniform(0.05, 0.9, (K_, n))
        lam[:, :2] = 1.0
        lam[:, 2] = 1.0 - 10.0 ** rng.uniform(-15, -2, K_)
        out["near triple top"] = lam
    lam = rng.uniform(0.05, 0.9, (K_, n))
    lam[:, :2] = 1.0
    out["double top"] = lam
    lam = rng.uniform(0.05, 1.0, (K_, n))
    lam[:, n // 2:] = 0.0
    out["rank deficient"] = lam
    return out


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 6])
def test_lambda_max_of_gram_matrices(n):
    """lambda_max(X^T X) and lambda_max(X X^T) for X = diag(sqrt(lambda)) Q^T
    (so X^T X = Q diag(lambda) Q^T) against numpy.linalg.eigvalsh, relative to
    lambda_max; the zero matrix gives 0."""
    rng = np.random.default_rng(n)
    for name, lam in _spectra(rng, 300, n).items():
        Q = _orthogonal(rng, 300, n)
        X = np.sqrt(lam)[:, :, None] * np.swapaxes(Q, 1, 2)
        for rows in (False, True):
            # the rows mode reads an upper triangular factor for n >= 4 (R^-1 in the kernel)
            Y = np.linalg.qr(X)[1] if rows and n >= 4 else X
            G = Y @ np.swapaxes(Y, 1, 2) if rows else np.swapaxes(Y, 1, 2) @ Y
            ref = np.linalg.eigvalsh(G)[:, -1]
            got = K.gram_lambda_max_stack(np.ascontiguousarray(Y), rows, None)
            rel = np.abs(got - ref) / np.maximum(ref, np.finfo(float).tiny)
            tol = 1.5e-13 if n >= 4 else 5e-15 * n
            assert np.all(rel <= tol), (name, rows, float(rel.max()))
    assert np.all(K.gram_lambda_max_stack(np.zeros((5, n, n)), False, None) == 0.0)


def test_lambda_max_large_random_stack_and_partial_blocks():
    """A stack that is not a multiple of the block, n = 6, Gaussian factors
    (condition numbers up to ~1e4): within 1e-13 of LAPACK."""
    rng = np.random.default_rng(11)
    X = rng.normal(size=(1001, 6, 6))
    ref = np.linalg.eigvalsh(np.swapaxes(X, 1, 2) @ X)[:, -1]
    got = K.gram_lambda_max_stack(X, False, None)
    assert np.max(np.abs(got - ref) / ref) < 1e-13


def _exact_inverse(A):
    """det and inverse in exact rational arithmetic (Gauss-Jordan on Fractions)."""
    n = len(A)
    M = [[Fraction(float(A[i][j])) for j in range(n)] + [Fraction(int(i == j)) for j in range(n)] for i in range(n)]
    det = Fraction(1)
    for c in range(n):
        p = next(r for r in range(c, n) if M[r][c] != 0)
        if p != c:
            M[c], M[p] = M[p], M[c]
            det = -det
        det *= M[c][c]
        inv = 1 / M[c][c]
        M[c] = [x * inv for x in M[c]]
        for r in range(n):
            if r != c and M[r][c] != 0:
                f = M[r][c]
                M[r] = [x - f * y for x, y in zip(M[r], M[c])]
    return det, [[M[i][n + j] for j in range(n)] for i in range(n)]


@pytest.mark.parametrize("n", [1, 2, 3])
def test_adjugate_inverse_is_exact_to_a_few_ulps(n):
    """n <= 3: every entry of A^-1 and |det A| within a few ulps of the exact
    rational values, also for nearly singular A (cond up to 1e12), where a plain
    cofactor expansion loses about eps cond."""
    rng = np.random.default_rng(20 + n)
    A = rng.normal(size=(200, n, n))
    if n > 1:
        # nearly singular: the last row close to a combination of the others
        w = rng.normal(size=(100, n - 1))
        A[:100, -1] = np.einsum("ki,kij->kj", w, A[:100, :-1]) + 10.0 ** rng.uniform(-12, -3, (100, 1)) * rng.normal(size=(100, n))
    det, i2, U = K.inverse_stack(A, None)
    worst_entry = worst_det = 0.0
    for k in range(len(A)):
        d, inv = _exact_inverse(A[k])
        worst_det = max(worst_det, abs(det[k] - abs(float(d))) / abs(float(d)))
        for i in range(n):
            for j in range(n):
                e = float(inv[i][j])
                if e != 0.0:
                    worst_entry = max(worst_entry, abs(U[k, i, j] - e) / abs(e))
        fro = float(sum(x * x for row in inv for x in row))
        assert abs(i2[k] - fro) <= 16 * EPS * fro
    assert worst_det <= 8 * EPS and worst_entry <= 8 * EPS, (worst_det, worst_entry)


@pytest.mark.parametrize("n", [4, 5, 6])
def test_householder_inverse_against_lapack(n):
    """n >= 4: U = R^-1 of A = QR has the singular values of A^-1: |det A|,
    ||A^-1||_F^2 and sigma_max(U)^2 = 1 / sigma_min(A)^2 against LAPACK (SVD), to
    eps cond(A) (random matrices with cond < 1e3); U is upper triangular."""
    rng = np.random.default_rng(30 + n)
    A = rng.normal(size=(400, n, n))
    s = np.linalg.svd(A, compute_uv=False)
    A = A[s[:, 0] / s[:, -1] < 1e3]
    s = np.linalg.svd(A, compute_uv=False)
    cond = s[:, 0] / s[:, -1]
    det, i2, U = K.inverse_stack(np.ascontiguousarray(A), None)
    assert np.all(np.tril(U, -1) == 0.0)
    assert np.all(np.abs(det - np.prod(s, -1)) <= 50 * EPS * cond * np.prod(s, -1))
    ref = np.sum(1.0 / s ** 2, -1)
    assert np.all(np.abs(i2 - ref) <= 50 * EPS * cond * ref)
    lu = K.gram_lambda_max_stack(U, True, None)
    assert np.all(np.abs(lu * s[:, -1] ** 2 - 1.0) <= 50 * EPS * cond)


def _kinds():
    return {"dyn": ("dynamic", None, {}), "st": ("stiffness", "lambda_min_K", {"k": 2.0}),
            "iso": ("isotropy", "frobenius", {}), "iso2": ("isotropy", "two_norm", {}),
            "dex": ("dexterity", "normalized", {}), "man": ("manipulability", None, {}),
            "ax1": ("axis_stiffness", None, {"axis": 1})}


@pytest.mark.parametrize("kind", ["strut", "prismatic", "revolute"])
def test_two_angles_and_a_fixed_angle_per_design(kind):
    """A rotation pose with two angles (n = 2) and the third fixed by a design
    variable that differs between designs (the kernel's frames per design):
    the compiled path equals the numpy path to 1e-12, reachable mask bitwise."""
    import yaml

    desc = description(kind, "rotation", masses=True,
                       pose_extra={"angles": ["roll", "pitch"], "fixed": {"yaw": 0.0}, "coordinates": ["a", "b"]})
    desc["pose"]["fixed"] = {"yaw": "psi"}
    desc["parameters"] = {"psi": {"kind": "angle", "default": 0.0}}
    cfg_text = yaml.safe_dump({"mechanism": desc, "design_variables": {"psi": {"value": 0.0, "bounds": [-0.05, 0.05]}},
                               "workspace": {"type": "box", "axes": {"a": [-0.08, 0.08], "b": [-0.08, 0.08]},
                                             "sampling": "sobol", "points": 300},
                               "indices": {"iso": {"kind": "isotropy"}}})
    import dataclasses

    cfg = parse_config(cfg_text)
    cfg = dataclasses.replace(cfg, indices={n: IndexSpec(n, k, c, "min", dict(o)) for n, (k, c, o) in _kinds().items()})
    designs = {"psi": np.linspace(-0.05, 0.05, 7)}
    with fast.disabled():
        ref = evaluate(cfg, designs)
    got = evaluate(cfg, designs)
    assert np.array_equal(got.reachable, ref.reachable) and got.reachable.any()
    for name in cfg.indices:
        for s in ("mean", "min", "max", "std"):
            a, b = got.summary[name][s], ref.summary[name][s]
            scale = np.maximum(np.abs(b), np.abs(ref.summary[name]["mean"]))
            assert np.all(np.abs(a - b) <= 1e-12 * scale), (name, s)
