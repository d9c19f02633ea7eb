"""One state per (design population, poses): the numpy path's evaluation runs
the inverse kinematics once for the reachable mask, J and M, and gives the
values the separate public methods give, bitwise."""
import numpy as np
import pytest
from described_helpers import mechanism as described_mechanism
from described_helpers import random_poses

from optdesign import fast
from optdesign.indices import local_index
from optdesign.mechanisms.base import IndexRequest
from optdesign.mechanisms.p4s import P4S
from optdesign.statistics import local_values, statistics

REQUESTS = [IndexRequest("dynamic", "dynamic"), IndexRequest("stiffness", "stiffness"),
            IndexRequest("isotropy", "isotropy")]


@pytest.fixture
def numpy_path():
    fast.set_enabled(False)
    yield
    fast.set_enabled(None)


def _count(monkeypatch, cls, name):
    calls = []
    orig = getattr(cls, name)

    def counted(self, X, *a, **kw):
        calls.append(np.shape(X))
        return orig(self, X, *a, **kw)
    monkeypatch.setattr(cls, name, counted)
    return calls


def _p4s_population(D=5, seed=7):
    rng = np.random.default_rng(seed)
    pop = {"r_a": rng.uniform(0.2, 0.27, D), "r_b": rng.uniform(0.64, 0.72, D), "L": rng.uniform(0.36, 0.42, D),
           "d": rng.uniform(0.08, 0.13, D), "phi": np.radians(rng.uniform(27, 36, D))}
    mech = P4S(**{k: v[:, None] for k, v in pop.items()})
    X = np.column_stack([rng.uniform(-0.05, 0.05, 40), rng.uniform(-0.05, 0.05, 40), np.full(40, 0.57)])
    X[0] = [0.0, 0.0, 5.0]                                  # one pose out of reach
    return mech, X, D


def _separate(mech, X, D):
    """The values by the public methods, each with its own inverse kinematics."""
    with np.errstate(all="ignore"):
        reach = np.broadcast_to(mech.reachable(X), (D, X.shape[0]))
        J, M = mech.jacobian(X), mech.mass_matrix(X)
        vals = {r.name: np.broadcast_to(local_index(r.kind, J=J, M=M, convention=r.convention, options={}),
                                        reach.shape) for r in REQUESTS}
    return vals, reach


@pytest.mark.parametrize("keep_local", [False, True])
def test_p4s_numpy_path_runs_the_branch_state_once(numpy_path, monkeypatch, keep_local):
    mech, X, D = _p4s_population()
    ref_vals, ref_reach = _separate(mech, X, D)
    calls = _count(monkeypatch, P4S, "branch_state")
    _, reach, local = statistics(mech, X, REQUESTS, D, keep_local)
    assert len(calls) == 1
    assert np.array_equal(reach, ref_reach) and not reach[:, 0].any() and reach[:, 1:].all()
    if keep_local:
        for k, v in ref_vals.items():
            assert np.array_equal(local[k], np.where(ref_reach, v, np.nan), equal_nan=True), k
    calls.clear()
    vals, _ = local_values(mech, X, REQUESTS, D)
    assert len(calls) == 1
    for k, v in ref_vals.items():
        assert np.array_equal(vals[k], v, equal_nan=True), k


@pytest.mark.parametrize("kind,ptype", [("prismatic", "translation"), ("strut", "spatial"), ("revolute", "planar")])
def test_described_numpy_path_runs_the_legs_inverse_kinematics_once(numpy_path, monkeypatch, kind, ptype):
    mech = described_mechanism(kind, ptype, masses=True)
    X = random_poses(mech, np.random.default_rng(3), 30)
    cls = type(mech)
    ref_vals, ref_reach = _separate(mech, X, 1)
    calls = _count(monkeypatch, cls, "leg_state")
    _, reach, local = statistics(mech, X, REQUESTS, 1, True)
    assert len(calls) == 1
    assert np.array_equal(reach, ref_reach) and reach.any()
    for k, v in ref_vals.items():
        assert np.array_equal(local[k], np.where(ref_reach, v, np.nan), equal_nan=True), k


def test_a_state_computes_each_quantity_once(numpy_path, monkeypatch):
    mech, X, _ = _p4s_population()
    calls = _count(monkeypatch, P4S, "branch_state")
    st = mech.state(X)
    q, r, J = st.q, st.reachable, st.J
    M = st.matrices({"M", "J"})
    assert st.q is q and st.reachable is r and st.J is J and M["J"] is J
    assert st.matrices({"M"})["M"] is M["M"]
    assert len(calls) == 1
    # a new state at other poses computes again
    assert mech.state(X[:5]).q.shape == (5, 5, 3)
    assert len(calls) == 2
