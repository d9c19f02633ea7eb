"""2-CPR/RRR (seed paper 002): kinematics of both input types against finite
differences, the paper's forward Jacobian and Hessian (eq. 15-18, 21-24),
automatic differentiation, and screw theory (eq. 1-3)."""

import numpy as np
import pytest
from numeric_helpers import central_jacobian
from hypothesis import given, settings
from hypothesis import strategies as st

from optdesign import screws as sc
from optdesign.mechanisms import get
from optdesign.mechanisms.cpr_rrr import LINEAR, ROTARY
from optdesign.studies.cpr_rrr_motion import motion_profile, paper_motion, plot_motion_example

from conftest import CONFIGS, edited_text

CONFIG = CONFIGS / "cpr_rrr.yaml"
DESIGN = dict(n=0.1, f=0.02, w=0.03, l1=0.2, l2=0.2)
RNG = np.random.default_rng(3)


def mech(input_type=ROTARY, **kw):
    return get("cpr_rrr")(**{**DESIGN, **kw}, input_type=input_type)


def poses(k=40):
    return RNG.uniform(-0.08, 0.08, size=(k, 2))


def test_names_and_actuators_follow_the_input_type():
    assert mech(ROTARY).actuator_names == ("theta2", "theta1")
    assert mech(LINEAR).actuator_names == ("m1", "m2")
    with pytest.raises(ValueError):
        mech(input_type=2)


@pytest.mark.parametrize("key, bad", [("input_type: 0 ", "input_type: 2 "), ("elbow: 1 ", "elbow: 0 ")])
def test_config_rejects_bad_mode_switches(key, bad):
    from optdesign.config import ConfigError, parse_config

    text = CONFIG.read_text()
    assert key in text
    with pytest.raises(ConfigError) as e:
        parse_config(text.replace(key, bad), "x.yaml")
    assert e.value.path == "parameters." + key.split(":")[0]


@settings(max_examples=60, deadline=None)
@given(st.floats(-0.08, 0.08), st.floats(-0.08, 0.08), st.sampled_from([ROTARY, LINEAR]))
def test_forward_inverts_inverse(x, y, kind):
    m = mech(kind)
    X = np.array([[x, y]])
    Q = m.inverse(X)
    assert np.all(np.isfinite(Q))
    np.testing.assert_allclose(m.forward(Q), X, atol=1e-12)


def test_rotary_inverse_is_the_geometry_of_eq1():
    """theta_i is the angle of the P_i direction u_i, whose line from the C_i axis
    meets the R_i axis: (0, d1 cos theta1, d1 sin theta1) = (., y - w, n)."""
    m = mech()
    X = poses()
    t2, t1 = m.inverse(X).T
    st_ = m.chain_state(X)
    np.testing.assert_allclose(st_["d1"] * np.cos(t1), X[:, 1] - DESIGN["w"], atol=1e-15)
    np.testing.assert_allclose(st_["d1"] * np.sin(t1), DESIGN["n"], atol=1e-15)
    np.testing.assert_allclose(st_["d2"] * np.cos(t2), X[:, 0] - DESIGN["f"], atol=1e-15)
    np.testing.assert_allclose(st_["d2"] * np.sin(t2), DESIGN["n"], atol=1e-15)
    assert np.all((t1 > 0) & (t1 < np.pi) & (t2 > 0) & (t2 < np.pi))


@pytest.mark.parametrize("kind", [ROTARY, LINEAR])
def test_jacobian_against_finite_differences(kind):
    m = mech(kind)
    X = poses(20)
    J = m.jacobian(X)
    np.testing.assert_allclose(J, central_jacobian(m.inverse, X, 1e-6), rtol=1e-7, atol=1e-9)
    # diagonal (uncoupled) for both input types, the identity for linear inputs
    np.testing.assert_array_equal(J[:, 0, 1], 0)
    np.testing.assert_array_equal(J[:, 1, 0], 0)
    if kind == LINEAR:
        np.testing.assert_array_equal(J, np.broadcast_to(np.eye(2), J.shape))


def test_paper_forward_jacobian_eq16_is_the_inverse_and_the_derivative_of_forward():
    m = mech()
    X = poses()
    Q = m.inverse(X)
    Jf = m.forward_jacobian(Q)
    np.testing.assert_allclose(Jf @ m.jacobian(X), np.broadcast_to(np.eye(2), Jf.shape), atol=1e-12)
    Jfd = central_jacobian(m.forward, Q, 1e-7)
    np.testing.assert_allclose(Jf, Jfd, rtol=1e-6)
    # the printed eq. 16/25 add -f and -w to the diagonal: no position equation
    # x = n cot(theta2) + const gives that (documented exception, docs/reproduction.md)
    printed = Jf[:, 0, 0] - DESIGN["f"]
    fd = Jfd[:, 0, 0]
    assert np.all(np.abs(printed - fd) > 0.5 * DESIGN["f"])


def test_paper_hessian_eq17_18_against_finite_differences():
    m = mech()
    X = poses(10)
    Q = m.inverse(X)
    Qd = RNG.normal(size=Q.shape)
    Qdd = RNG.normal(size=Q.shape)
    a = m.forward_acceleration(Q, Qd, Qdd)
    h = 1e-5
    # second derivative of forward(Q + t Qd + t^2/2 Qdd) at t = 0
    fp, f0, fm = (m.forward(Q + s * Qd + 0.5 * s * s * Qdd) for s in (h, 0.0, -h))
    np.testing.assert_allclose(a, (fp - 2 * f0 + fm) / h ** 2, rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize("kind", [ROTARY, LINEAR])
def test_actuator_accelerations_against_finite_differences(kind):
    m = mech(kind)
    X = poses(10)
    V = RNG.normal(size=X.shape) * 0.1
    A = RNG.normal(size=X.shape) * 0.1
    h = 1e-5
    qp, q0, qm = (m.inverse(X + s * V + 0.5 * s * s * A) for s in (h, 0.0, -h))
    np.testing.assert_allclose(m.accelerations(X, V, A), (qp - 2 * q0 + qm) / h ** 2, rtol=1e-4, atol=1e-6)


@pytest.mark.parametrize("kind", [ROTARY, LINEAR])
def test_casadi_route_matches(kind):
    from optdesign.mechanisms.cpr_rrr import symbolic_model

    m = mech(kind)
    sm = symbolic_model(kind)
    X = poses(15)
    Q = m.inverse(X)
    p = {k: DESIGN[k] for k in ("n", "f", "w")}
    np.testing.assert_allclose(sm.closure(X, Q, p), 0, atol=1e-14)
    np.testing.assert_allclose(sm.jacobian(X, Q, p), m.jacobian(X), rtol=1e-12, atol=1e-14)
    V, A = RNG.normal(size=X.shape), RNG.normal(size=X.shape)
    np.testing.assert_allclose(sm.accelerations(X, Q, V, A, p), m.accelerations(X, V, A), rtol=1e-10, atol=1e-12)
    Xn, ok = sm.forward_newton(Q, X + 0.005, p)
    assert ok.all()
    np.testing.assert_allclose(Xn, X, atol=1e-12)


def test_broadcast_over_designs():
    n = np.array([[0.08], [0.1], [0.15]])
    for kind in (ROTARY, LINEAR):
        m = mech(kind, n=n)
        X = poses(7)
        assert m.inverse(X).shape == (3, 7, 2)
        assert m.jacobian(X).shape == (3, 7, 2, 2)
        assert m.reachable(X).shape == (3, 7)
        for d in range(3):
            np.testing.assert_allclose(m.jacobian(X)[d], mech(kind, n=float(n[d, 0])).jacobian(X))


def test_rrr_reach_limits_the_workspace():
    m = mech(l1=0.1, l2=0.1, rrr_base_x=-0.2, rrr_base_y=0.0)
    X = np.array([[0.0, 0.0], [-0.005, 0.0], [0.001, 0.0], [-0.2, 0.0]])
    # |C - B| = 0.2 (stretched, on the boundary), 0.195 inside, 0.201 outside, 0 (folded, l1 = l2)
    np.testing.assert_array_equal(m.reachable(X), [True, True, False, True])
    Q = m.inverse(X)
    assert np.isnan(Q[2]).all() and np.isfinite(Q[[0, 1, 3]]).all()
    st_ = m.chain_state(X)
    # the elbow point is at l1 from the base and l2 from the platform attachment
    np.testing.assert_allclose(np.linalg.norm(st_["E"] - st_["B"], axis=-1)[[0, 1, 3]], 0.1)
    np.testing.assert_allclose(np.linalg.norm(st_["C"] - st_["E"], axis=-1)[[0, 1, 3]], 0.1)


# ---------------------------------------------------------------------- screw theory
def test_chain_constraint_wrenches_are_eq2_and_eq3():
    m = mech()
    X = poses(8)
    L1, L2, L3 = m.joint_twists(X)
    # eq. 1 as printed, chain L1: S11, S12, S13, S14
    t1 = m.inverse(X)[:, 1]
    d1 = m.chain_state(X)["d1"]
    for k in range(len(X)):
        c, s = np.cos(t1[k]), np.sin(t1[k])
        eq1 = np.array([[0, 0, 0, 1, 0, 0], [1, 0, 0, 0, 0, 0], [0, 0, 0, 0, c, s],
                        [1, 0, 0, 0, d1[k] * s, -d1[k] * c]], float)
        np.testing.assert_allclose(L1[k], eq1, atol=1e-15)
        couples = lambda *axes: np.array([[0, 0, 0, *np.eye(3)[a]] for a in axes])  # noqa: E731
        assert sc.same_span(sc.constraint_wrenches(L1[k]), couples(1, 2))          # eq. 2
        assert sc.same_span(sc.constraint_wrenches(L2[k]), couples(0, 2))          # eq. 3
        # RRR: couples about X and Y and a force along Z
        W3 = np.concatenate([couples(0, 1), [[0, 0, 1, 0, 0, 0]]])
        assert sc.same_span(sc.constraint_wrenches(L3[k], length_scale=0.1), W3, length_scale=0.1)
        # the platform: translations along X and Y only
        T = sc.platform_twist_space([L1[k], L2[k], L3[k]], length_scale=0.1)
        assert T.shape == (2, 6)
        assert sc.motion_type(T, length_scale=0.1) == (0, 2)
        assert sc.same_span(T, np.array([[0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0.0]]))


@pytest.mark.parametrize("kind", [ROTARY, LINEAR])
def test_screw_joint_rates_reproduce_the_jacobian(kind):
    """Each chain's actuated joint rate, solved from the chain's twists for a
    platform translation, equals the row of J (eq. 16 / eq. 23)."""
    m = mech(kind)
    X = poses(10)
    chains = m.joint_twists(X)
    J = m.jacobian(X)
    ia, ib = m.actuated_joints()
    # actuator order: (theta2, theta1) = (L2, L1) rotary; (m1, m2) = (L1, L2) linear
    order = [(1, ib), (0, ia)] if kind == ROTARY else [(0, ia), (1, ib)]
    for v in np.eye(2):
        tw = np.concatenate([np.zeros(3), v, [0.0]])
        for row, (chain, joint) in enumerate(order):
            rates, res = sc.joint_rates(chains[chain], tw)
            assert np.all(res < 1e-12)
            np.testing.assert_allclose(rates[:, joint], J[:, row] @ v, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("kind", [ROTARY, LINEAR])
def test_actuation_wrenches_eq19_and_the_screw_jacobian(kind):
    """Linear inputs: the actuation wrench of L1 is the force along X through O
    (eq. 19); rotary inputs: a force normal to P1 in the YZ plane through the R1
    axis.  The Joshi-Tsai Jacobian from these wrenches equals J."""
    m = mech(kind)
    X = poses(6)
    L1, L2, L3 = m.joint_twists(X)
    a = m.actuated_joints()[0]
    t1 = m.chain_state(X)["theta1"]
    for k in range(len(X)):
        W = sc.actuation_wrench(L1[k], a)
        W = W * np.sign(W[np.argmax(np.abs(W))])
        if kind == LINEAR:
            assert sc.same_span(np.concatenate([[W], sc.constraint_wrenches(L1[k])]),
                                np.array([[1, 0, 0, 0, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1.0]]))
        else:
            f = W[:3] / np.linalg.norm(W[:3])
            assert abs(abs(f @ [0, -np.sin(t1[k]), np.cos(t1[k])]) - 1) < 1e-12
        chains = [L2[k], L1[k]] if kind == ROTARY else [L1[k], L2[k]]
        A = sc.actuation_jacobian(chains, [a, a])
        np.testing.assert_allclose(A[:, 3:5], m.jacobian(X)[k], rtol=1e-10, atol=1e-12)
        # (the other columns act on twists the platform cannot have: the wrench is
        # defined up to the constraint wrenches, which do no work on allowed twists)


def test_twist_space_over_the_workspace_and_the_rrr_singularity():
    m = mech(l1=0.2, l2=0.2, rrr_base_x=-0.2, rrr_base_y=-0.2)
    g = np.linspace(-0.05, 0.05, 11)
    X = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    dims = sc.twist_space_dimension(m.joint_twists(X), length_scale=0.1)
    assert np.all(dims == 2)
    # an unreachable pose has no twists: dimension -1, not an exception
    assert sc.twist_space_dimension(m.joint_twists(np.array([[0.5, 0.5]])))[0] == -1
    # with the RRR chain stretched the three Z axes are coplanar and the platform
    # loses the translation along the chain: one DOF left
    r = 0.4 / np.sqrt(2)
    Xs = np.array([[-0.2 + r, -0.2 + r]])
    assert m.reachable(Xs).all()
    assert sc.twist_space_dimension(m.joint_twists(Xs), length_scale=0.1)[0] == 1


# ---------------------------------------------------------------------- motion example and config
def test_motion_example_both_routes_agree(tmp_path):
    P = 200
    t = np.linspace(0, 25, P + 1)
    mp = plot_motion_example(tmp_path / "m.png", t, **{k: DESIGN[k] for k in ("n", "f", "w")})
    assert (tmp_path / "m.png").stat().st_size > 10_000
    m0 = paper_motion(t)
    np.testing.assert_allclose(mp["X"], m0["X"], atol=1e-15)                 # eq. 21-22
    np.testing.assert_allclose(mp["V_from_rotary"], mp["V"], atol=1e-15)     # eq. 15-16 vs eq. 23
    np.testing.assert_allclose(mp["A_from_rotary"], mp["A"], atol=1e-15)     # eq. 17-18 vs eq. 24
    # the velocities are the time derivatives of the positions (fine time grid)
    t = np.linspace(0, 25, 25001)
    dt = t[1] - t[0]
    mp = motion_profile(t, **{k: DESIGN[k] for k in ("n", "f", "w")})
    np.testing.assert_allclose(np.gradient(mp["X"], dt, axis=0)[1:-1], mp["V"][1:-1], atol=1e-9)
    np.testing.assert_allclose(np.gradient(mp["theta"], dt, axis=0)[1:-1], mp["thetad"][1:-1], atol=1e-9)
    np.testing.assert_allclose(np.gradient(mp["thetad"], dt, axis=0)[1:-1], mp["thetadd"][1:-1], atol=1e-9)
    assert np.abs(mp["X"][:, 0]).max() == pytest.approx(0.010)
    assert np.abs(mp["X"][:, 1]).max() == pytest.approx(0.0075, rel=1e-3)


def test_config_evaluates_and_linear_inputs_are_isotropic():
    from optdesign.config import load_config, parse_config
    from optdesign.evaluate import evaluate_named

    cfg = load_config(CONFIG)
    res = evaluate_named(cfg)
    for name, rec in res.items():
        assert rec["reachable_fraction"] == 1.0
        assert rec["isotropy"]["min"] >= 1.0 and rec["isotropy"]["max"] > 1.0
        assert 0 < rec["dexterity"]["mean"] < 1.0
    # a taller design (larger n) is more isotropic and has less manipulability
    assert res["tall"]["isotropy"]["mean"] < res["default"]["isotropy"]["mean"]
    assert res["tall"]["manipulability"]["mean"] < res["default"]["manipulability"]["mean"]
    text = edited_text(CONFIG.read_text(), {"input_type: 0": "input_type: 1"})
    lin = evaluate_named(parse_config(text, "lin.yaml"))
    for rec in lin.values():
        for k in ("isotropy", "dexterity", "manipulability"):
            assert rec[k]["min"] == pytest.approx(1.0) and rec[k]["max"] == pytest.approx(1.0)


def test_optimization_config_loads_and_centring_the_offsets_helps():
    """configs/cpr_rrr_opt.yaml: placing theta = 90 deg at the bed centre
    (f = w = 0.1 m) raises both indices over the start design, as the symmetry
    of sin^2 theta about 90 deg says it must."""
    from optdesign.config import load_config
    from optdesign.evaluate import evaluate_named

    cfg = load_config(CONFIG.parent / "cpr_rrr_opt.yaml")
    assert [v.name for v in cfg.free_variables] == ["n", "f", "w"]
    res = evaluate_named(cfg)
    assert res["centred"]["reachable_fraction"] == res["start"]["reachable_fraction"] == 1.0
    for k in ("dexterity", "stiffness"):
        assert res["centred"][k]["mean"] > res["start"][k]["mean"]


# ---------------------------------------------------------------------- MuJoCo cross-check
def _mjcf(m):
    """The three chains as open kinematic trees in MuJoCo, each ending in a site
    at the platform point; joint order as in the paper's eq. 1."""
    P = {k: float(np.asarray(v)) for k, v in m.params.items()}
    return f"""
<mujoco>
  <worldbody>
    <body name="c1"><joint name="m1" type="slide" axis="1 0 0"/><joint name="th1" type="hinge" axis="1 0 0"/>
      <geom type="sphere" size="0.01" mass="1"/>
      <body name="p1"><joint name="d1" type="slide" axis="0 1 0"/><geom type="sphere" size="0.01" mass="1"/>
        <body name="r1"><joint name="r1" type="hinge" axis="1 0 0"/><geom type="sphere" size="0.01" mass="1"/>
          <site name="s1" pos="0 {P['w']} 0"/></body></body></body>
    <body name="c2"><joint name="m2" type="slide" axis="0 1 0"/><joint name="th2" type="hinge" axis="0 -1 0"/>
      <geom type="sphere" size="0.01" mass="1"/>
      <body name="p2"><joint name="d2" type="slide" axis="1 0 0"/><geom type="sphere" size="0.01" mass="1"/>
        <body name="r2"><joint name="r2" type="hinge" axis="0 1 0"/><geom type="sphere" size="0.01" mass="1"/>
          <site name="s2" pos="{P['f']} 0 0"/></body></body></body>
    <body name="b3" pos="{P['rrr_base_x']} {P['rrr_base_y']} 0"><joint name="a1" type="hinge" axis="0 0 1"/>
      <geom type="sphere" size="0.01" mass="1"/>
      <body name="e3" pos="{P['l1']} 0 0"><joint name="a2" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.01" mass="1"/>
        <body name="c3" pos="{P['l2']} 0 0"><joint name="a3" type="hinge" axis="0 0 1"/><geom type="sphere" size="0.01" mass="1"/>
          <site name="s3" pos="{-P['rrr_attach_x']} {-P['rrr_attach_y']} {P['n']}"/></body></body></body>
  </worldbody>
</mujoco>"""


@pytest.mark.parametrize("kind", [ROTARY, LINEAR])
def test_mujoco_closes_the_loops_and_reproduces_the_jacobian(kind):
    """MuJoCo composes each chain's joints with its own kinematics: with our
    joint values all three chains end at the platform point (x, y, n) with the
    platform level, and the chain's joint rates that give a platform
    translation (solved from MuJoCo's site Jacobians) have actuated rates equal
    to the rows of J."""
    mujoco = pytest.importorskip("mujoco")
    m = mech(kind, rrr_attach_x=0.01, rrr_attach_y=-0.02)
    model = mujoco.MjModel.from_xml_string(_mjcf(m))
    data = mujoco.MjData(model)
    X = poses(12)
    s = m.chain_state(X)
    J = m.jacobian(X)
    jid = {model.joint(i).name: model.jnt_qposadr[i] for i in range(model.njnt)}
    chains = {"s1": ["m1", "th1", "d1", "r1"], "s2": ["m2", "th2", "d2", "r2"], "s3": ["a1", "a2", "a3"]}
    actuated = {ROTARY: [("s2", "th2"), ("s1", "th1")], LINEAR: [("s1", "m1"), ("s2", "m2")]}[kind]
    for k in range(len(X)):
        q = {"m1": s["m1"][k], "th1": s["theta1"][k], "d1": s["d1"][k], "r1": -s["theta1"][k],
             "m2": s["m2"][k], "th2": s["theta2"][k], "d2": s["d2"][k], "r2": s["theta2"][k],
             "a1": s["phi1"][k], "a2": s["phi2"][k] - s["phi1"][k], "a3": s["phi3"][k] - s["phi2"][k]}
        for name, v in q.items():
            data.qpos[jid[name]] = v
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        target = np.array([X[k, 0], X[k, 1], DESIGN["n"]])
        for site, body in (("s1", "r1"), ("s2", "r2"), ("s3", "c3")):
            np.testing.assert_allclose(data.site(site).xpos, target, atol=1e-14)
            np.testing.assert_allclose(data.body(body).xmat.reshape(3, 3), np.eye(3), atol=1e-14)
        for v in np.eye(2):
            twist = np.concatenate([np.zeros(3), v, [0.0]])      # (omega; v) of the platform point
            rates = {}
            for site, names in chains.items():
                jp, jr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
                mujoco.mj_jacSite(model, data, jp, jr, model.site(site).id)
                cols = [jid[nm] for nm in names]                  # hinge/slide: qpos index = dof index
                A = np.vstack([jr[:, cols], jp[:, cols]])
                r, *_ = np.linalg.lstsq(A, twist, rcond=None)
                assert np.linalg.norm(A @ r - twist) < 1e-12
                rates.update(dict(zip(names, r)))
            got = [rates[j] for _, j in actuated]
            np.testing.assert_allclose(got, J[k] @ v, rtol=1e-10, atol=1e-12)
