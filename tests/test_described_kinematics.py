"""Kinematics of described mechanisms, every leg kind on every pose type,
against computations the package does not make: the closure equations written
here with scipy's rotations, central differences of the inverse kinematics,
second differences for the accelerations, and forward kinematics round trips."""
from __future__ import annotations

import numpy as np
import pytest
from described_helpers import CASES, mechanism, random_poses, rotation_of


def _closure_residual(mech, X, Q):
    """|b - a(q)| - l (rod legs) or |b - A| - q (struts), from the description's
    numbers and scipy's rotation matrices."""
    C, spec = mech.constants, mech.pose_spec
    fixed = {a: float(C.fixed[i]) for i, a in enumerate(("roll", "pitch", "yaw")) if a not in spec.roles}
    out = np.empty(Q.shape)
    for k, (x, q) in enumerate(zip(X, Q)):
        R = rotation_of(spec.roles, x, fixed)
        o = np.zeros(3) if spec.type != "rotation" else C.centre.copy()
        for r, v in zip(spec.roles, x):
            if r in ("x", "y", "z"):
                o["xyz".index(r)] = v
        for i, kind in enumerate(C.kind):
            b = o + R @ C.P[i]
            if kind == 0:
                out[k, i] = np.linalg.norm(b - C.A[i] - q[i] * C.U[i]) - C.Lr[i]
            elif kind == 1:
                a = C.A[i] + C.La[i] * (np.cos(q[i]) * C.R0[i] + np.sin(q[i]) * np.cross(C.U[i], C.R0[i]))
                out[k, i] = np.linalg.norm(b - a) - C.Lr[i]
            else:
                out[k, i] = np.linalg.norm(b - C.A[i]) - q[i]
    return out


@pytest.mark.parametrize("kind,ptype", CASES)
def test_inverse_kinematics_closes_every_leg(kind, ptype):
    mech = mechanism(kind, ptype)
    X = random_poses(mech, np.random.default_rng(1), 40)
    Q = mech.inverse(X)
    assert np.all(np.isfinite(Q))
    assert np.max(np.abs(_closure_residual(mech, X, Q))) < 1e-13


@pytest.mark.parametrize("kind,ptype", CASES)
def test_jacobian_against_central_differences(kind, ptype):
    mech = mechanism(kind, ptype)
    X = random_poses(mech, np.random.default_rng(2), 30)
    J = mech.jacobian_rates(X)
    h = 1e-6
    num = np.stack([(mech.inverse(X + h * e) - mech.inverse(X - h * e)) / (2 * h) for e in np.eye(mech.dof)], -1)
    assert np.max(np.abs(J - num)) <= 1e-7 * np.max(np.abs(num))
    if ptype in ("translation", "planar"):
        assert np.array_equal(mech.jacobian_twist(X), J)


@pytest.mark.parametrize("kind,ptype", CASES)
def test_forward_of_inverse_round_trip(kind, ptype):
    mech = mechanism(kind, ptype)
    X = random_poses(mech, np.random.default_rng(3), 30)
    Xf = mech.forward(mech.inverse(X))
    assert np.max(np.abs(Xf - X)) < 1e-12


@pytest.mark.parametrize("kind,ptype", CASES)
def test_accelerations_against_second_differences(kind, ptype):
    mech = mechanism(kind, ptype)
    rng = np.random.default_rng(4)
    X = random_poses(mech, rng, 20)
    V = rng.normal(0, 0.3, X.shape)
    A = rng.normal(0, 2.0, X.shape)
    h = 1e-4
    path = [mech.inverse(X + s * V + 0.5 * s * s * A) for s in (-h, 0.0, h)]
    num = (path[0] - 2 * path[1] + path[2]) / (h * h)
    qdd = mech.accelerations(X, V, A)
    assert np.max(np.abs(qdd - num)) <= 2e-5 * max(1.0, np.max(np.abs(num)))


def test_rotation_with_two_angles_and_a_fixed_one():
    mech = mechanism("strut", "rotation", pose_extra={"angles": ["roll", "pitch"], "fixed": {"yaw": 0.2},
                                                      "coordinates": ["a", "b"]})
    assert mech.pose_names == ("a", "b") and mech.dof == 2
    X = random_poses(mech, np.random.default_rng(5), 20)
    Q = mech.inverse(X)
    assert np.max(np.abs(_closure_residual(mech, X, Q))) < 1e-13
    h = 1e-6
    num = np.stack([(mech.inverse(X + h * e) - mech.inverse(X - h * e)) / (2 * h) for e in np.eye(2)], -1)
    assert np.max(np.abs(mech.jacobian(X) - num)) <= 1e-7 * np.max(np.abs(num))
    assert np.max(np.abs(mech.forward(Q) - X)) < 1e-12


def test_batched_designs_broadcast_like_single_designs():
    from optdesign.mechanisms.described import build_class

    raw = {"parameters": {"R": "length", "r": "length", "L": "length"},
           "pose": {"type": "translation", "home": {"z": -0.5}},
           "legs": [{"kind": "revolute", "actuator": "t", "pattern": {"angles": [0, 120, 240], "unit": "deg"},
                     "base": ["R", 0, 0], "axis": [0, 1, 0], "reference": [1, 0, 0], "crank": 0.25, "rod": "L",
                     "platform": ["r", 0, 0]}]}
    cls = build_class(raw)
    rng = np.random.default_rng(6)
    R, r, L = rng.uniform(0.18, 0.22, 5), rng.uniform(0.04, 0.06, 5), rng.uniform(0.55, 0.65, 5)
    many = cls(R=R[:, None], r=r[:, None], L=L[:, None])
    X = np.array([[0.0, 0.0, -0.5], [0.05, -0.02, -0.55], [0.1, 0.1, -0.45]])
    Qm, Jm = many.inverse(X), many.jacobian(X)
    assert Qm.shape == (5, 3, 3) and Jm.shape == (5, 3, 3, 3)
    for d in range(5):
        one = cls(R=R[d], r=r[d], L=L[d])
        assert np.array_equal(one.inverse(X), Qm[d])
        assert np.array_equal(one.jacobian(X), Jm[d])


def test_unreachable_pose_gives_nan_and_mask():
    mech = mechanism("revolute", "translation")
    X = np.array([[0.0, 0.0, -0.5], [0.0, 0.0, -5.0]])
    Q = mech.inverse(X)
    assert np.all(np.isfinite(Q[0])) and np.all(np.isnan(Q[1]))
    assert mech.reachable(X).tolist() == [True, False]
    assert np.all(np.isnan(mech.jacobian(X)[1]))


@pytest.mark.parametrize("shapes", [((5, 3, 3), (5, 3, 3)), ((4, 1, 3, 3), (3, 3)), ((2, 3), (7, 1, 3))])
def test_the_constants_cross_product_is_numpys_to_the_bit(shapes):
    """constants._cross (the cross product of the legs' axes, without np.cross's
    axis moves) gives np.cross's bits, broadcasting as it does."""
    from optdesign.mechanisms.described.constants import _cross

    rng = np.random.default_rng(len(shapes[0]))
    a = rng.normal(size=shapes[0]) * 10.0 ** rng.integers(-8, 8, size=shapes[0])
    b = rng.normal(size=shapes[1])
    got, want = _cross(a, b), np.cross(a, b)
    assert got.shape == want.shape and got.tobytes() == want.tobytes()
