"""Interval certificates (optdesign.certify): enclosures contain sampled values,
the 3-P(4S) reproduction optimum is certified, the old maximum design refuted."""
import numpy as np
import pytest

from optdesign.certify.bnb import branch_and_bound
from optdesign.intervals.interval import Interval, _down, _up
from optdesign.intervals.matrix import cond_fro_upper
from optdesign.mechanisms.p4s.enclosure import P4SEnclosure
from optdesign.linalg import cond_fro
from optdesign.mechanisms import get


def test_the_outward_rounding_is_numpys_nextafter_bit_for_bit():
    """_up/_down step on the bits of a double (compiled, for large arrays);
    numpy's nextafter (libm) is the reference: every special value,
    subnormals, the largest doubles, and random bit patterns (NaN payloads
    included), as arrays of several shapes and layouts and as 0-d arrays."""
    import contextlib

    from optdesign import fast
    from optdesign.intervals.interval import _STEPS, COMPILED_FROM

    f = np.finfo(float)
    special = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, -np.nan, f.max, -f.max, f.tiny, -f.tiny,
                        f.smallest_subnormal, -f.smallest_subnormal, 2 * f.smallest_subnormal, 1.0, -1.0,
                        f.eps, -f.eps, 0.5, -0.5, 2.0 ** -1022 - 2.0 ** -1074])
    bits = np.random.default_rng(7).integers(-2 ** 63, 2 ** 63 - 1, size=20000, dtype=np.int64, endpoint=True)
    values = np.concatenate([special, bits.view(float), np.random.default_rng(8).normal(size=1000)])
    for compiled in (True, False):      # compiled paths on (large arrays stepped on the bits) and off
        with fast.disabled() if not compiled else contextlib.nullcontext():
            for a in (values, values.reshape(-1, 4)[:, ::3], values[:1].reshape(()), values[:COMPILED_FROM],
                      values[:COMPILED_FROM - 1]):      # either side of the threshold
                for ours, toward in ((_up, np.inf), (_down, -np.inf)):
                    with np.errstate(all="ignore"):
                        ref, got = np.nextafter(a, toward), ours(a)
                    assert np.shape(got) == np.shape(ref)
                    assert np.array_equal(np.asarray(got).view(np.int64), np.asarray(ref).view(np.int64))
    assert _STEPS.module is not None, "the compiled steps were not used"


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


def _random_boxes(rng, n, z_free=False):
    """n random boxes in W (random centres and widths from 1e-5 to 2e-2 m); z free or fixed."""
    c = np.c_[rng.uniform(-0.05, 0.05, (n, 2)), np.full(n, 0.57)]
    w = 10.0 ** rng.uniform(-5, np.log10(0.02), (n, 1)) * np.array([1.0, 1.0, 1.0 if z_free else 0.0])
    w = w * rng.uniform(0.3, 1.0, (n, 3))
    return c - w / 2, c + w / 2


@pytest.mark.parametrize("z_free", [False, True])
def test_adjugate_bounds_contain_sampled_cond(z_free):
    """At random poses of random boxes of random designs (some near the
    singularity constraint), neither adjugate bound is ever below the sampled
    cond, nor are det and adj J outside their enclosures."""
    from optdesign.intervals.matrix import (cond_2_upper, cond_2_upper_adjugate, cond_fro_upper_adjugate,
                                            det_adjugate)
    from optdesign.linalg import cond_2

    rng = np.random.default_rng(7 + z_free)
    proved = 0
    for trial in range(6):
        ra, rb = rng.uniform(0.21, 0.29), rng.uniform(0.63, 0.71)
        phi = np.radians(28.70055 if trial == 0 else rng.uniform(25, 35))
        ra, rb = (0.29, 0.63) if trial == 0 else (ra, rb)
        enc = P4SEnclosure(ra, rb, 0.38, 0.12, phi)
        mech = get("p4s")(r_a=ra, r_b=rb, L=0.38, d=0.12, phi=phi)
        lo, hi = _random_boxes(rng, 300, z_free)
        with np.errstate(all="ignore"):          # unreachable boxes: inf and NaN bounds, never proved
            e = enc.evaluate(lo, hi)
            args = (e["J"], e["J_dual"], e["J_mid"], lo, hi)
            uf, u2 = cond_fro_upper_adjugate(*args), cond_2_upper_adjugate(*args)
            u2_pre = cond_2_upper(e["J"])
            det, adj = det_adjugate(*args)
        ok = e["reach_lo"] > 0
        for _ in range(20):
            X = lo + rng.uniform(0, 1, lo.shape) * (hi - lo)
            assert np.all(mech.reachable(X)[ok])
            J = mech.jacobian(X)[ok]
            assert np.all(cond_fro(J) <= uf[ok])
            assert np.all(cond_2(J) <= u2[ok])
            assert np.all(cond_2(J) <= u2_pre[ok])
            tol = 1e-13 * np.abs(J).max(axis=(1, 2)) ** 3     # the float det's and cofactors' rounding
            d = np.linalg.det(J)
            assert np.all((det[ok].lo - tol <= d) & (d <= det[ok].hi + tol))
            r = [J[:, 0], J[:, 1], J[:, 2]]
            A = np.stack([np.cross(r[1], r[2]), np.cross(r[2], r[0]), np.cross(r[0], r[1])], -1)  # adj J
            for i in range(3):
                for k in range(3):
                    m = adj[i][k][ok]
                    assert np.all((m.lo - tol <= A[:, i, k]) & (A[:, i, k] <= m.hi + tol)), (i, k)
        proved += int(np.sum(ok & np.isfinite(uf)))
    assert proved > 1000                          # the bounds were finite where sampled


def test_sigma_and_lambda_bounds_hold():
    """Weyl's sigma_max bound and the eigenvalue bound are never below sampled
    values over random interval matrices, and exact to 1e-9 on point matrices."""
    from optdesign.intervals.matrix import _weyl_bound, lambda_max_upper, sigma_max_upper

    rng = np.random.default_rng(5)
    K, n = 400, 3
    M = rng.normal(size=(K, n, n)) * rng.choice([1e-3, 1.0, 1e3], (K, 1, 1))
    R = np.abs(rng.normal(size=(K, n, n))) * np.abs(M).max(axis=(1, 2))[:, None, None] \
        * rng.choice([0.0, 1e-6, 1e-2, 0.3], (K, 1, 1))
    A = [[Interval(M[:, i, k] - R[:, i, k], M[:, i, k] + R[:, i, k]) for k in range(n)] for i in range(n)]
    s_up, w_up = sigma_max_upper(A), _weyl_bound(A)
    for _ in range(30):
        S = M + R * rng.uniform(-1, 1, M.shape)
        s = np.linalg.norm(S, 2, axis=(1, 2))
        assert np.all(s <= s_up) and np.all(s <= w_up)
    point = R.max(axis=(1, 2)) == 0
    assert point.sum() > 50
    s = np.linalg.norm(M[point], 2, axis=(1, 2))
    assert np.all(w_up[point] <= s * (1 + 1e-9))
    G = M @ np.swapaxes(M, 1, 2)
    lam = np.linalg.eigvalsh(G)[:, -1]
    lu = lambda_max_upper(G)
    assert np.all(lu >= lam) and np.all(lu <= lam + 1e-9 * np.abs(G).max(axis=(1, 2)))


@pytest.mark.slow
def test_extreme_on_the_constraint_is_certified_within_the_default_budget():
    """The reproduction's normalization extreme (r_a 0.29, r_b 0.63, phi
    28.70055 deg: max cond_F over W 999.0, limit 1000) is certified within
    DEFAULT_BUDGET; with the preconditioned bound alone it is not."""
    from optdesign.certify.designs import DEFAULT_BUDGET, certify_design

    mech = get("p4s")(r_a=0.29, r_b=0.63, L=0.38, d=0.12, phi=np.radians(28.70055))
    region = {"lo": W[0], "hi": W[1], "disc": None}
    c = certify_design(mech, region, 1000.0, "frobenius", budget=DEFAULT_BUDGET)
    assert c["status"] == "certified" and c["share_proved"] == 1.0 and c["boxes"] <= DEFAULT_BUDGET
    c = certify_design(mech, region, 1000.0, "frobenius", budget=20_000, adjugate=False)
    assert c["status"] == "unknown"
    assert cond_fro(mech.jacobian(np.array([[0.0, 0.0, 0.57]])))[0] < 999.0


def test_budgets_per_dimension_and_pareto_point():
    from optdesign.certify.designs import DEFAULT_BUDGET
    from optdesign.certify.reported import budget_for

    assert budget_for(2, False) == DEFAULT_BUDGET == 300_000
    assert budget_for(6, False) == DEFAULT_BUDGET // 3
    assert budget_for(3, True) == DEFAULT_BUDGET // 20
    assert budget_for(6, True, base=60_000) == 20_000 // 20
