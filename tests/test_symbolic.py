"""The hand-derived, batched 3-P(4S) model (eq. 8-23) against the CasADi route
(closure equations and body energies written once, derivatives by automatic
differentiation, dynamics by Lagrange's equations)."""
from __future__ import annotations

import numpy as np
import pytest

from optdesign.mechanisms import get
from optdesign.mechanisms.p4s import symbolic_model

P4S = get("p4s")
N = 300


@pytest.fixture(scope="module")
def sym():
    return symbolic_model()


@pytest.fixture(scope="module")
def sample():
    """N random designs (one per point: per-point parameters) and poses, with
    random velocities and accelerations; only well-conditioned reachable poses."""
    rng = np.random.default_rng(11)
    r_a = rng.uniform(0.17, 0.3, N)
    params = dict(r_a=r_a, r_b=rng.uniform(0.6, 0.8, N), L=rng.uniform(0.33, 0.48, N),
                  d=rng.uniform(0.05, 0.14, N), phi=np.radians(rng.uniform(22, 42, N)),
                  m_platform=rng.uniform(2, 6, N), m_slider=rng.uniform(1, 4, N), m_rod=rng.uniform(0.5, 2.5, N),
                  rod_Ixx=rng.uniform(0.005, 0.04, N), g=np.full(N, 9.81), rods_per_branch=np.full(N, 2.0))
    m = P4S(**params)
    # a home height per design (rods 40 deg from vertical at equal strokes), then jitter
    R = params["L"] * np.sin(np.radians(40))
    q0 = (params["r_b"] - m.rho - R) / np.cos(params["phi"])
    z0 = q0 * np.sin(params["phi"]) + params["L"] * np.cos(np.radians(40))
    X = np.stack([np.zeros(N), np.zeros(N), z0], -1) + rng.uniform(-0.05, 0.05, (N, 3))
    bs = m.branch_state(X)
    ok = bs["reachable"] & (np.nan_to_num(bs["s"]).min(-1) > 0.15)
    assert ok.sum() > 200
    params = {k: v[ok] for k, v in params.items()}
    X = X[ok]
    V = rng.normal(size=X.shape)
    A = rng.normal(size=X.shape) * 5
    return P4S(**params), params, X, V, A


def test_jacobian_matches_casadi(sym, sample):
    m, p, X, V, A = sample
    Q = m.inverse(X)
    np.testing.assert_allclose(sym.closure(X, Q, p), 0.0, atol=1e-13)
    J = m.jacobian(X)
    np.testing.assert_allclose(sym.jacobian(X, Q, p), J, rtol=1e-10, atol=1e-12 * np.abs(J).max())


def test_accelerations_match_casadi(sym, sample):
    m, p, X, V, A = sample
    Q = m.inverse(X)
    qdd = m.accelerations(X, V, A)
    np.testing.assert_allclose(sym.accelerations(X, Q, V, A, p), qdd, rtol=1e-9, atol=1e-11 * np.abs(qdd).max())
    # the velocity-product term alone
    Z = np.zeros_like(A)
    np.testing.assert_allclose(sym.accelerations(X, Q, V, Z, p), m.velocity_product_terms(X, V)["qdd"],
                               rtol=1e-9, atol=1e-11 * np.abs(qdd).max())


def test_mass_matrices_match_casadi(sym, sample):
    m, p, X, V, A = sample
    Q = m.inverse(X)
    Mp = m.platform_mass_matrix(X)
    Mp_ad = sym.platform_mass_matrix(X, Q, p)
    np.testing.assert_allclose(Mp_ad, Mp, rtol=1e-11, atol=1e-12 * np.abs(Mp).max())
    # the M of eq. 23 is J^-T M_p
    J = sym.jacobian(X, Q, p)
    M_ad = np.linalg.solve(np.swapaxes(J, -1, -2), Mp_ad)
    M = m.mass_matrix(X)
    np.testing.assert_allclose(M_ad, M, rtol=1e-9, atol=1e-11 * np.abs(M).max())
    # kinetic energy of the symbolic bodies = v^T M_p v / 2
    T, _ = sym.energies(X, Q, V, p)
    np.testing.assert_allclose(T, 0.5 * np.einsum("ni,nij,nj->n", V, Mp, V), rtol=1e-11)


def test_actuator_forces_match_casadi(sym, sample):
    m, p, X, V, A = sample
    Q = m.inverse(X)
    Z = np.zeros_like(A)
    tau = m.actuator_forces(X, V, A)
    scale = np.abs(tau).max()
    np.testing.assert_allclose(sym.actuator_forces(X, Q, V, A, p), tau, rtol=1e-9, atol=1e-11 * scale)
    # term by term: gravity (at rest), velocity products (a = 0, g = 0)
    np.testing.assert_allclose(sym.actuator_forces(X, Q, Z, Z, p), m.gravity_term(X), rtol=1e-9, atol=1e-11 * scale)
    p0 = {**p, "g": np.zeros_like(p["g"])}
    np.testing.assert_allclose(sym.actuator_forces(X, Q, V, Z, p0), m.velocity_term(X, V), rtol=1e-9, atol=1e-11 * scale)


def test_forward_newton_matches_closed_form(sym, sample):
    m, p, X, V, A = sample
    Q = m.inverse(X)
    X0 = X + np.random.default_rng(2).uniform(-0.02, 0.02, X.shape)
    Xn, ok = sym.forward_newton(Q, X0, p)
    assert ok.all()
    Xf = m.forward(Q)
    assert np.abs(Xn - Xf).max() <= 1e-12
    assert np.abs(Xf - X).max() <= 1e-12


def test_inverse_newton_matches_closed_form(sym, sample):
    m, p, X, V, A = sample
    Q = m.inverse(X)
    Qn, ok = sym.inverse_newton(X, Q + 0.01, p)
    assert ok.all()
    assert np.abs(Qn - Q).max() <= 1e-12


def test_symbolic_model_single_design_scalar_params(sym):
    """Scalar parameters broadcast over the points (the route a config would use)."""
    design = dict(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=np.radians(30))
    m = P4S(**design)
    p = {k: float(v) for k, v in m.params.items()}
    X = np.array([[0.0, 0.0, 0.57], [0.01, -0.02, 0.56]])
    Q = m.inverse(X)
    np.testing.assert_allclose(sym.jacobian(X, Q, p), m.jacobian(X), rtol=1e-10, atol=1e-13)
    V = np.array([[0.1, 0.2, 0.0], [0.0, -0.1, 0.05]])
    A = np.array([[1.0, 0.0, 2.0], [-3.0, 1.0, 0.0]])
    np.testing.assert_allclose(sym.actuator_forces(X, Q, V, A, p), m.actuator_forces(X, V, A), rtol=1e-10)
