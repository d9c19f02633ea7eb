"""The generic screw-theory tools on textbook cases (results known from the
literature, not from our code): a spherical wrist, a planar RRR chain, the
3-P(4S) parallelogram chains; and basic algebraic properties."""
import numpy as np
import pytest

from optdesign import screws as sc

RNG = np.random.default_rng(7)


def test_joint_twists_follow_the_plucker_convention():
    # revolute about z through (1, 0, 0): the origin moves with v = r x s = (0, -1, 0)
    np.testing.assert_allclose(sc.revolute([0, 0, 2.0], [1, 0, 0]), [0, 0, 1, 0, -1, 0])
    np.testing.assert_allclose(sc.prismatic([0, 3.0, 0]), [0, 0, 0, 0, 1, 0])
    C = sc.cylindrical([1, 0, 0], [0, 0, 0])
    np.testing.assert_allclose(C, [[0, 0, 0, 1, 0, 0], [1, 0, 0, 0, 0, 0]])   # eq. 1: S11, S12
    # a revolute twist moves the points of its own axis with zero velocity
    s, r = _unit(RNG.normal(size=3)), RNG.normal(size=3)
    T = sc.revolute(s, r)
    v_at_r = T[3:] + np.cross(T[:3], r)      # v(p) = v_O + omega x p
    np.testing.assert_allclose(v_at_r, 0, atol=1e-14)


def _unit(v):
    return v / np.linalg.norm(v)


def test_reciprocal_is_the_null_space_of_the_reciprocal_product():
    for k in range(0, 7):
        A = RNG.normal(size=(k, 6))
        R = sc.reciprocal(A)
        assert R.shape == (6 - k, 6)
        if k and len(R):
            np.testing.assert_allclose(sc.reciprocal_product(A[:, None, :], R[None, :, :]), 0, atol=1e-12)
        # the reciprocal of the reciprocal gives the system back
        if 0 < k < 6:
            assert sc.same_span(sc.reciprocal(R), A)


def test_length_scale_does_not_change_the_systems():
    A = RNG.normal(size=(4, 6))
    for L in (1e-3, 0.1, 10.0):
        assert sc.same_span(sc.reciprocal(A, length_scale=L), sc.reciprocal(A))


def test_spherical_wrist_leaves_three_rotations_and_three_forces_through_the_centre():
    p = np.array([0.1, -0.2, 0.3])
    # three revolute axes meeting at p, not coplanar
    axes = [_unit(RNG.normal(size=3)) for _ in range(3)]
    chain = np.stack([sc.revolute(a, p) for a in axes])
    W = sc.constraint_wrenches(chain)
    assert W.shape == (3, 6)
    # every constraint wrench is a pure force whose line passes through p: m = p x f
    np.testing.assert_allclose(W[:, 3:], np.cross(p, W[:, :3]), atol=1e-12)
    T = sc.platform_twist_space([chain])
    assert sc.motion_type(T) == (3, 0)
    assert sc.same_span(T, sc.spherical(p))


def test_planar_rrr_chain_has_three_planar_dof():
    pts = [np.array([0.0, 0.0, 0.0]), np.array([0.3, 0.1, 0.05]), np.array([0.5, 0.4, 0.2])]
    chain = np.stack([sc.revolute([0, 0, 1], r) for r in pts])
    T = sc.platform_twist_space([chain])
    assert T.shape == (3, 6)
    assert sc.motion_type(T) == (1, 2)
    for t in ([0, 0, 1, 0, 0, 0], [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0]):
        assert sc.contains(T, np.array(t, float))
    # constraints: couples about x and y, and a force along z
    W = sc.constraint_wrenches(chain)
    assert sc.same_span(W, np.array([[0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 1, 0, 0, 0.0]]))
    # stretched chain (axes coplanar): the platform loses the radial translation
    line = [np.array([0.0, 0, 0]), np.array([0.2, 0.1, 0]), np.array([0.4, 0.2, 0])]
    stretched = np.stack([sc.revolute([0, 0, 1], r) for r in line])
    assert sc.platform_twist_space([stretched]).shape == (2, 6)


def test_p4s_parallelogram_chains_leave_three_translations_and_match_eq8():
    """Each 3-P(4S) branch as P + parallelogram: the slider along m_i, two
    translations of the far edge normal to the rods (the parallelogram swing),
    and a rotation about the far edge (the line of its two S joints)."""
    from optdesign.mechanisms import get

    mech = get("p4s")(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=np.radians(30))
    X = np.array([[0.0, 0.0, 0.57], [0.03, -0.04, 0.56], [-0.05, 0.02, 0.59]])
    bodies = mech.body_positions(X)
    st = mech.branch_state(X)
    J = mech.jacobian(X)
    from optdesign.mechanisms.p4s import T as TDIR

    for k in range(len(X)):
        chains = []
        for i in range(3):
            n = st["n"][k, i]
            a = _unit(np.cross(n, TDIR[i]))
            b = np.cross(n, a)
            chains.append(np.stack([sc.prismatic(st["m"][k, i]), sc.prismatic(a), sc.prismatic(b),
                                    sc.revolute(TDIR[i], bodies["d"][k, i])]))
        for c in chains:
            W = sc.constraint_wrenches(c)
            assert W.shape == (2, 6)
            np.testing.assert_allclose(W[:, :3], 0, atol=1e-12)          # couples only
        T = sc.platform_twist_space(chains)
        assert sc.motion_type(T) == (0, 3)
        # Joshi-Tsai inverse Jacobian from the actuation wrenches (slider locked):
        # its translational columns are eq. 8
        A = sc.actuation_jacobian(chains, [0, 0, 0])
        np.testing.assert_allclose(A[:, 3:], J[k], rtol=1e-10, atol=1e-12)
        # the actuation wrench of a branch is a force along its rod n_i
        for i, c in enumerate(chains):
            W = sc.actuation_wrench(c, 0)
            assert abs(abs(W[:3] @ st["n"][k, i]) - np.linalg.norm(W[:3])) < 1e-9
        # the slider rate that produces a platform translation v is row i of eq. 8's J
        for v in np.eye(3):
            tw = np.concatenate([np.zeros(3), v])
            for i, c in enumerate(chains):
                rates, res = sc.joint_rates(c, tw)
                assert res < 1e-12
                assert rates[0] == pytest.approx(J[k, i] @ v, abs=1e-12)


def test_twist_space_dimension_is_vectorized_and_agrees_with_the_single_version():
    # planar RRR chains at random elbow positions plus stretched ones
    n = 50
    b = np.zeros((n, 3))
    e = np.concatenate([RNG.normal(size=(n, 2)), np.zeros((n, 1))], axis=1)
    p = e + np.concatenate([RNG.normal(size=(n, 2)), np.zeros((n, 1))], axis=1)
    p[:5] = 2 * e[:5]                                     # collinear: stretched
    z = np.broadcast_to([0.0, 0, 1], (n, 3))
    chain = np.stack([sc.revolute(z, b), sc.revolute(z, e), sc.revolute(z, p)], axis=-2)
    dims = sc.twist_space_dimension([chain])
    expect = np.array([sc.platform_twist_space([chain[i]]).shape[0] for i in range(n)])
    np.testing.assert_array_equal(dims, expect)
    assert set(dims[:5]) == {2} and set(dims[5:]) == {3}


def test_actuation_wrench_rejects_a_redundant_actuator():
    # a spherical joint's three rotations with the twist of the first repeated:
    # locking that copy removes no motion, so there is no actuation wrench
    c = np.concatenate([sc.spherical([0.0, 0, 0]), sc.revolute([1.0, 0, 0], [0, 0, 0])[None]])
    with pytest.raises(ValueError):
        sc.actuation_wrench(c, 3)
