"""Interval certificates (optdesign.certify): enclosures contain sampled values,
the 3-P(4S) reproduction optimum is certified, the old maximum design refuted."""
import numpy as np
import pytest

from optdesign.certify.bnb import branch_and_bound
from optdesign.intervals.interval import Interval
from optdesign.intervals.matrix import cond_fro_upper
from optdesign.mechanisms.p4s.enclosure import P4SEnclosure
from optdesign.linalg import cond_fro
from optdesign.mechanisms import get


def test_interval_operations_enclose_samples():
    rng = np.random.default_rng(3)
    a = np.sort(rng.uniform(-2, 2, (2, 500)), axis=0)
    b = np.sort(rng.uniform(0.1, 3, (2, 500)), axis=0)
    A, B = Interval(a[0], a[1]), Interval(b[0], b[1])
    t = rng.uniform(0, 1, (50, 1))
    xa = a[0] + t * (a[1] - a[0])
    xb = b[0] + t * (b[1] - b[0])
    for f, g in [(A + B, xa + xb), (A - B, xa - xb), (A * B, xa * xb), (A / B, xa / xb), (A.sqr(), xa * xa),
                 (B.sqrt(), np.sqrt(xb))]:
        assert np.all((f.lo <= g) & (g <= f.hi))
        assert np.all(f.hi - f.lo < 50)          # finite, not the whole line


def _p4s(ra, rb, phi):
    enc = P4SEnclosure(ra, rb, 0.38, 0.12, phi)
    mech = get("p4s")(r_a=ra, r_b=rb, L=0.38, d=0.12, phi=phi)

    def bound(lo, hi):
        r = enc.evaluate(lo, hi)
        return np.where(r["reach_lo"] > 0, cond_fro_upper(r["J"]), np.inf)

    def value(X):
        return np.where(mech.reachable(X), cond_fro(mech.jacobian(X)), np.inf)

    return enc, mech, bound, value


def test_p4s_jacobian_enclosure_contains_the_model():
    enc, mech, bound, value = _p4s(0.25, 0.67, np.radians(30))
    rng = np.random.default_rng(1)
    c = rng.uniform(-0.05, 0.05, (200, 3)) + [0, 0, 0.57]
    lo, hi = c - 0.004, c + 0.004
    r = enc.evaluate(lo, hi)
    X = lo + rng.uniform(0, 1, (200, 3)) * (hi - lo)
    J = mech.jacobian(X)
    for i in range(3):
        for k in range(3):
            assert np.all(r["J"][i][k].contains(J[:, i, k]))
    assert np.all(bound(lo, hi) >= value(X))
    lo, hi = c - 1e-5, c + 1e-5                  # narrow enough on small boxes
    assert np.all(bound(lo, hi) < 1.1 * value(c))


W = (np.array([-0.05, -0.05, 0.57]), np.array([0.05, 0.05, 0.57]))


def test_reproduction_optimum_is_certified():
    _, _, bound, value = _p4s(0.21, 0.71, np.radians(35))
    res = branch_and_bound(bound, value, *W, 1000.0, budget=400_000)
    assert res["status"] == "certified" and res["share_proved"] == 1.0


def test_old_maximum_design_is_refuted_with_a_witness():
    _, mech, bound, value = _p4s(0.2846, 0.6462, np.radians(27.91))
    res = branch_and_bound(bound, value, *W, 1000.0, budget=400_000)
    assert res["status"] == "refuted"
    x = np.array(res["witness"])
    assert np.all((x >= W[0]) & (x <= W[1]))
    assert cond_fro(mech.jacobian(x[None]))[0] > 1000.0


def test_tight_limit_gives_unknown_or_refuted():
    _, _, bound, value = _p4s(0.21, 0.71, np.radians(35))
    res = branch_and_bound(bound, value, *W, 1.0, budget=1000)
    assert res["status"] == "refuted"            # cond_F >= 3 everywhere
