"""Certificates of described mechanisms and of a run's reported designs
(optdesign.mechanisms.described.enclosure, optdesign.intervals, optdesign.certify).

The enclosures are checked against the float models at random poses of
random boxes of random designs (every entry of J and every actuator value
inside its enclosure), the interval derivatives against central differences,
and the certificates against exhaustive samples: a design certified at a
limit has no sampled pose above it, and a limit just below the sampled
maximum is never certified."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import CONFIGS, DATA
from optdesign.certify.designs import certify_design, region_of
from optdesign.mechanisms.described.enclosure import DescribedEnclosure
from optdesign.intervals.dual import Dual, cos, mean_value, seed, sin
from optdesign.intervals.interval import Interval
from optdesign.intervals.matrix import cond_2_upper_adjugate, cond_fro_upper_adjugate
from optdesign.config import load_config
from optdesign.evaluate import build, workspace_of
from optdesign.linalg import cond_2, cond_fro

SHAPES = ["p4s_legs", "delta", "sps_s_legs_opt", "gough_stewart"]


def _random_design(cfg, rng):
    d = dict(cfg.design(next(iter(cfg.designs))))
    for v in cfg.free_variables:
        lo, hi = v.bounds
        d[v.name] = lo + (hi - lo) * rng.uniform(0.2, 0.8)
    return d


@pytest.mark.parametrize("name", SHAPES)
def test_enclosures_contain_the_float_model(name):
    cfg = load_config(CONFIGS / f"{name}.yaml")
    ws = workspace_of(cfg)
    reg = region_of(ws)
    rng = np.random.default_rng(11)
    checked = bounded = 0
    for trial in range(3):
        mech = build(cfg, _random_design(cfg, rng) if cfg.free_variables else next(iter(cfg.designs)))
        enc = DescribedEnclosure(mech)
        span = reg["hi"] - reg["lo"]
        c = reg["lo"] + span * rng.uniform(0.1, 0.9, (60, len(span)))
        w = span * rng.choice([0.002, 0.02, 0.1], (60, 1))
        lo, hi = c - w / 2, c + w / 2
        e = enc.evaluate(lo, hi)
        args = (e["J"], e["J_dual"], e["J_mid"], lo, hi)
        with np.errstate(all="ignore"):
            u_adj = {"fro": cond_fro_upper_adjugate(*args), "two": cond_2_upper_adjugate(*args)}
        X = lo[None] + rng.uniform(0, 1, (25, 1, len(span))) * (hi - lo)[None]
        for s in range(X.shape[0]):
            J = mech.index_matrices(X[s], {"J"})["J"]
            Q = mech.inverse(X[s])
            reach = mech.reachable(X[s])
            proved = e["reach_lo"] > 0
            assert np.all(reach[proved]), "a box proved reachable holds an unreachable pose"
            for i in range(J.shape[-2]):
                for k in range(J.shape[-1]):
                    inside = e["J"][i][k].contains(J[:, i, k])
                    assert np.all(inside[proved]), (name, i, k)
                if e["q"][i] is not None:
                    assert np.all(e["q"][i].contains(Q[:, i])[proved]), (name, "q", i)
            with np.errstate(all="ignore"):
                assert np.all((cond_fro(J) <= u_adj["fro"])[proved]), (name, "adjugate cond_F")
                assert np.all((cond_2(J) <= u_adj["two"])[proved]), (name, "adjugate cond_2")
            checked += int(proved.sum())
            bounded += int(np.sum(proved & np.isfinite(u_adj["two"])))
    assert checked > 100
    assert bounded > 100 or J.shape[-1] > 4      # the adjugate form is of orders up to 4


def test_interval_derivatives_contain_central_differences():
    rng = np.random.default_rng(5)
    c = rng.uniform(0.2, 2.0, 400)
    w = rng.uniform(1e-4, 0.3, 400)
    lo, hi = c - w, c + w

    def f(x, lib_cos, lib_sin):
        return (x.sqr() + 1.0).sqrt() * lib_cos(x) / (x * 2.0 + 3.0) - lib_sin(x * 0.5) * x

    def f_float(x):
        return np.sqrt(x * x + 1) * np.cos(x) / (2 * x + 3) - np.sin(0.5 * x) * x

    dual = f(seed(lo, hi, 0, 1), cos, sin)
    assert isinstance(dual, Dual)
    at_mid = f(Interval(c), cos, sin)
    mv = mean_value(dual, at_mid, lo[:, None], hi[:, None])
    t = rng.uniform(0, 1, (50, 1))
    x = lo + t * (hi - lo)
    h = 1e-6
    fd = (f_float(x + h) - f_float(x - h)) / (2 * h)
    d = dual.d[0]
    assert np.all((d.lo - 1e-6 <= fd) & (fd <= d.hi + 1e-6))
    v = f_float(x)
    assert np.all((mv.lo <= v) & (v <= mv.hi))
    assert np.all(dual.v.contains(v))
    # on small boxes the mean-value form's excess over the sampled range is far below the natural one's
    small = w < 0.01
    rng_ = v.max(axis=0) - v.min(axis=0)
    ex_mv = (mv.hi - mv.lo) - rng_
    ex_nat = (dual.v.hi - dual.v.lo) - rng_
    assert np.median(ex_mv[small] / ex_nat[small]) < 0.2


def _sampled_max(cfg, mech, n=16384):
    from scipy.stats import qmc

    ws = workspace_of(cfg)
    reg = region_of(ws)
    free = reg["hi"] > reg["lo"]
    u = qmc.Sobol(int(free.sum()), scramble=True, seed=3).random(n)
    X = np.tile(reg["lo"], (n, 1))
    X[:, free] = reg["lo"][free] + u * (reg["hi"] - reg["lo"])[free]
    if reg["disc"] is not None:
        cx, cy, r = reg["disc"]
        X = X[(X[:, 0] - cx) ** 2 + (X[:, 1] - cy) ** 2 <= r * r]
    J = mech.index_matrices(X, {"J"})["J"]
    return float(np.max(cond_2(J))), reg


@pytest.mark.parametrize("name, factor", [("delta", 1.5), pytest.param("gough_stewart", 10.0, marks=pytest.mark.slow)])
def test_certificates_agree_with_dense_samples(name, factor):
    """Certified a little above the sampled maximum (the 6-D W needs far more
    boxes near it, so there the margin is wider), never just below it."""
    cfg = load_config(CONFIGS / f"{name}.yaml")
    mech = build(cfg, next(iter(cfg.designs)))
    cmax, reg = _sampled_max(cfg, mech)
    above = certify_design(mech, reg, factor * cmax, "two_norm", budget=60_000)
    assert above["status"] == "certified", above
    below = certify_design(mech, reg, 0.98 * cmax, "two_norm", budget=20_000)
    assert below["status"] in ("refuted", "unknown"), below
    if below["status"] == "refuted":
        X = np.array([below["witness"]])
        assert cond_2(mech.index_matrices(X, {"J"})["J"])[0] > 0.98 * cmax


def test_the_old_maximum_design_is_refuted_in_the_described_3p4s_too():
    """p4s_legs (the 3-P(4S) as data) at (0.2846, 0.6462, 27.91 deg): the
    witness is checked by the hand-written model, an independent implementation."""
    from optdesign.mechanisms import get

    cfg = load_config(CONFIGS / "p4s_legs.yaml")
    d = {**cfg.design(next(iter(cfg.designs))), "r_a": 0.2845941646130193, "r_b": 0.6462157517431623,
         "phi": 0.4871681655184717}
    mech = build(cfg, d)
    c = certify_design(mech, region_of(workspace_of(cfg)), 1000.0, "frobenius")
    assert c["status"] == "refuted" and c["reason"] == "singularity"
    hand = get("p4s")(r_a=d["r_a"], r_b=d["r_b"], L=d["L"], d=d["d"], phi=d["phi"])
    X = np.array([c["witness"]])
    assert cond_fro(hand.jacobian(X))[0] > 1000.0


@pytest.mark.slow
def test_a_run_certifies_every_reported_design(tmp_path):
    """results.json["certificates"]: the optimum, both extremes of each index,
    the named designs and every Pareto point; certified designs hold on a
    401 x 401 grid of W by the hand-written model, refuted ones break the
    limit at their witness; results.md and report.html show the statuses."""
    from optdesign.mechanisms import get
    from optdesign.runner import start_run

    cfg = load_config(DATA / "p4s_tiny.yaml")
    res = start_run(cfg, seed=2, out=tmp_path)
    certs = res.results["certificates"]
    keys = {"optimum", "dynamic.min", "dynamic.max", "stiffness.min", "stiffness.max", *cfg.designs}
    assert keys <= set(certs)
    for st in ("pareto_nsga2", "pareto_nsga3"):
        n = len(res.stages[st]["front"])
        assert {f"{st}[{i}]" for i in range(n)} <= set(certs)
    g = np.linspace(-0.05, 0.05, 401)
    gx, gy = np.meshgrid(g, g)
    X = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, 0.57)], -1)
    seen = set()
    for key, c in certs.items():
        assert c["status"] in ("certified", "refuted", "unknown")
        d = {**{"L": 0.38, "d": 0.12}, **c["design"]}
        mech = get("p4s")(r_a=d["r_a"], r_b=d["r_b"], L=d["L"], d=d["d"], phi=d["phi"])
        sig = tuple(sorted(d.items()))
        if c["status"] == "certified" and sig not in seen:
            seen.add(sig)
            assert np.all(mech.reachable(X))
            # p4s_tiny has no isotropy index: its singularity limit is on cond_2 (docs/config.md)
            assert np.max(np.linalg.cond(mech.jacobian(X), 2)) <= c["limit"], key
        if c["status"] == "refuted":
            W = np.array([c["witness"]])
            assert not mech.reachable(W)[0] or np.linalg.cond(mech.jacobian(W), 2)[0] > c["limit"], key
    md = (res.folder.path / "results.md").read_text()
    assert "## Certificates over the continuous workspace" in md
    assert f"| optimum | {certs['optimum']['status']}" in md.replace("REFUTED", "refuted")
    saved = json.loads((res.folder.path / "results.json").read_text())
    assert saved["certificates"]["optimum"]["status"] == certs["optimum"]["status"]
    html = (res.folder.path / "report.html").read_text()
    assert 'id="certificates"' in html


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "optdesign", *args], capture_output=True, text=True, timeout=600)


def test_certify_command(tmp_path):
    p = _cli("certify", str(CONFIGS / "delta.yaml"), "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert {c["status"] for c in out["certificates"].values()} == {"certified"}
    p = _cli("certify", str(CONFIGS / "sps_s_legs.yaml"), "--design", "paper")
    assert p.returncode == 1
    assert p.stdout.startswith("paper: refuted") and "psi = 0 deg" in p.stdout
    p = _cli("certify", str(CONFIGS / "delta.yaml"), "--design", "nope")
    assert p.returncode == 2 and "nope" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    p = _cli("certify", str(CONFIGS / "delta.yaml"), "--budget", "0")
    assert p.returncode == 2 and "--budget" in p.stderr


def test_condition_bounds_hold_over_interval_matrices():
    from optdesign.intervals.matrix import cond_2_upper, cond_fro_upper

    rng = np.random.default_rng(2)
    K, n = 300, 4
    Q = np.linalg.qr(rng.normal(size=(K, n, n)))[0]
    M = Q * rng.uniform(1, 3, (K, 1, n))          # orthogonal columns: the bound is tight there
    M[::2] = rng.normal(size=(K // 2, n, n)) + 3 * np.eye(n)
    R = np.abs(rng.normal(size=(K, n, n))) * rng.choice([1e-4, 1e-2, 0.1], (K, 1, 1))
    J = [[Interval(M[:, i, k] - R[:, i, k], M[:, i, k] + R[:, i, k]) for k in range(n)] for i in range(n)]
    u2, uf = cond_2_upper(J), cond_fro_upper(J)
    a2, af = cond_2_upper_adjugate(J), cond_fro_upper_adjugate(J)     # order 4: cofactors of order 3
    assert np.all(u2 <= uf)
    assert np.sum(np.isfinite(af)) > K // 3
    for _ in range(30):
        S = M + R * rng.uniform(-1, 1, M.shape)
        assert np.all(cond_2(S) <= u2)
        assert np.all(cond_fro(S) <= uf)
        assert np.all(cond_2(S) <= a2)
        assert np.all(cond_fro(S) <= af)
    tight = (R.max(axis=(1, 2)) < 1e-3) & (np.arange(K) % 2 == 1)
    assert tight.sum() > 30
    assert np.all(u2[tight] < 1.01 * cond_2(M[tight]))
    assert np.all(np.isfinite(u2[R.max(axis=(1, 2)) < 1e-3]))
