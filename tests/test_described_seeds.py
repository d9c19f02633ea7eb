"""The seeds written as descriptions (configs/p4s_legs.yaml, configs/sps_s_legs.yaml)
against the hand-written modules (optdesign/mechanisms/p4s.py, sps_s.py): two
independent implementations of one mechanism.

Agreement is asked to 1e-12 relative at poses where J is well conditioned
(cond_2(J) <= 1000, the region the 3-P(4S) compiled path also treats as
regular); everywhere else the two may differ by round-off amplified by the
condition number, and the test bounds that by 8 eps cond_2(J).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from optdesign.config import load_config
from optdesign.indices import cond_2
from optdesign.mechanisms import get

ROOT = Path(__file__).resolve().parents[1]
EPS = np.finfo(float).eps


def _pair(hand, described):
    return load_config(ROOT / "configs" / hand), load_config(ROOT / "configs" / described)


def _close(a, b, cond, what, scale=None):
    """Per-pose relative difference (norm over the trailing axes, relative to
    the norm of b or to ``scale``) <= 1e-12 where cond <= 1000, <= 8 eps cond
    elsewhere; NaN patterns equal."""
    a, b = np.asarray(a), np.asarray(b)
    assert np.array_equal(np.isnan(a), np.isnan(b)), what
    ax = tuple(range(cond.ndim, a.ndim))
    ok = np.all(np.isfinite(b), axis=ax) if ax else np.isfinite(b)
    num = np.sqrt(np.sum(np.where(np.isfinite(b), (a - b) ** 2, 0.0), axis=ax)) if ax else np.abs(np.where(ok, a - b, 0.0))
    den = np.sqrt(np.sum(np.where(np.isfinite(b), b * b, 0.0), axis=ax)) if ax else np.abs(np.where(ok, b, 1.0))
    if scale is not None:
        den = scale
    rel = np.where(ok & (den > 0), num / np.where(den > 0, den, 1.0), 0.0)
    good = ok & (cond <= 1000)
    assert good.sum() > 0.5 * ok.sum(), f"{what}: too few well-conditioned poses"
    assert np.max(rel[good]) <= 1e-12, f"{what}: {np.max(rel[good]):.3g}"
    assert np.all(rel[ok] <= np.maximum(1e-12, 8 * EPS * cond[ok])), what


def _designs(rng, D, ranges):
    return {k: rng.uniform(lo, hi, D)[:, None] for k, (lo, hi) in ranges.items()}


def test_p4s_legs_equals_p4s_at_random_designs_and_poses():
    c0, c1 = _pair("p4s_paper.yaml", "p4s_legs.yaml")
    rng = np.random.default_rng(7)
    D, N = 12, 200
    des = _designs(rng, D, {"r_a": (0.2, 0.3), "r_b": (0.6, 0.72), "L": (0.36, 0.42), "d": (0.08, 0.14),
                            "phi": (np.radians(22), np.radians(38))})
    masses = {"m_platform": rng.uniform(2, 6, (D, 1)), "m_slider": rng.uniform(1, 4, (D, 1)),
              "m_rod": rng.uniform(0.5, 2, (D, 1)), "rod_Ixx": rng.uniform(0.005, 0.04, (D, 1)), "g": 9.81}
    X = np.stack([rng.uniform(-0.06, 0.06, N), rng.uniform(-0.06, 0.06, N), rng.uniform(0.5, 0.62, N)], -1)
    V = rng.normal(0, 0.5, (N, 3))
    A = rng.normal(0, 20, (N, 3))
    hand = get(c0.mechanism)(**{**c0.parameters, **des, **masses})
    desc = get(c1.mechanism)(**{**c1.parameters, **des, **masses})
    with np.errstate(all="ignore"):
        J0 = hand.jacobian(X)
        cond = np.where(np.all(np.isfinite(J0), axis=(-1, -2)), cond_2(J0), np.inf)
        assert np.isfinite(cond).sum() > 0.8 * cond.size
        _close(desc.inverse(X), hand.inverse(X), cond, "inverse")
        assert np.array_equal(desc.reachable(X), hand.reachable(X))
        _close(desc.jacobian(X), J0, cond, "jacobian")
        _close(desc.platform_mass_matrix(X), hand.platform_mass_matrix(X), cond, "platform mass matrix")
        _close(desc.mass_matrix(X), hand.mass_matrix(X), cond, "mass matrix")
        # forces: relative to the size of their three parts (inertia, velocity, gravity),
        # not to their sum, which may cancel
        parts = [np.einsum("...ij,...j->...i", hand.mass_matrix(X), A), hand.velocity_term(X, V), hand.gravity_term(X)]
        scale = sum(np.linalg.norm(p, axis=-1) for p in parts)
        _close(desc.actuator_forces(X, V, A), hand.actuator_forces(X, V, A), cond, "actuator forces", scale)
        _close(desc.velocity_term(X, V), hand.velocity_term(X, V), cond, "velocity term")
        _close(desc.gravity_term(X), hand.gravity_term(X), cond, "gravity term")
        _close(desc.accelerations(X, V, A), hand.accelerations(X, V, A), cond, "accelerations")


def test_sps_s_legs_equals_sps_s_at_random_designs_and_poses():
    c0, c1 = _pair("sps_s.yaml", "sps_s_legs.yaml")
    rng = np.random.default_rng(8)
    D, N = 12, 200
    des = _designs(rng, D, {"r_b": (0.2, 0.6), "r_B": (0.5, 1.2), "h_B": (0.15, 0.5), "h_o": (-0.1, 0.4),
                            "delta": (-0.8, 0.8)})
    X = rng.uniform(-0.3, 0.3, (N, 3))
    hand = get(c0.mechanism)(**{**c0.parameters, **des})
    desc = get(c1.mechanism)(**{**c1.parameters, **des})
    with np.errstate(all="ignore"):
        J0 = hand.jacobian(X)
        cond = cond_2(J0)
        _close(desc.inverse(X), hand.inverse(X), cond, "inverse")
        _close(desc.jacobian(X), J0, cond, "jacobian (angular velocity, eq. 10)")
        _close(desc.jacobian_twist(X), J0, cond, "jacobian_twist")
        _close(desc.jacobian_rates(X), hand.jacobian_euler(X), cond, "jacobian_rates = jacobian_euler")


def _global_equal(hand_cfg, desc_cfg, designs, tol=1e-12):
    from optdesign.evaluate import evaluate

    e0 = evaluate(hand_cfg, designs)
    e1 = evaluate(desc_cfg, designs)
    assert np.array_equal(e0.reachable, e1.reachable)
    for name in hand_cfg.indices:
        for stat in ("mean", "min", "max", "std"):
            a, b = e1.summary[name][stat], e0.summary[name][stat]
            scale = np.maximum(np.abs(b), np.abs(e0.summary[name]["mean"]))
            assert np.all(np.abs(a - b) <= tol * scale + 1e-300), (name, stat, np.max(np.abs(a - b) / scale))


def test_global_indices_equal_at_random_designs():
    rng = np.random.default_rng(3)
    c0, c1 = _pair("p4s_paper.yaml", "p4s_legs.yaml")
    D = 12
    des = {"r_a": rng.uniform(0.21, 0.29, D), "r_b": rng.uniform(0.63, 0.71, D), "L": np.full(D, 0.38),
           "d": np.full(D, 0.12), "phi": np.radians(rng.uniform(25, 35, D))}
    _global_equal(c0, c1, des)
    c0, c1 = _pair("sps_s_opt.yaml", "sps_s_legs.yaml")
    c1 = load_config(ROOT / "configs" / "sps_s_legs.yaml")
    # the optimization config's indices and delta on the description: compare over its workspace
    import dataclasses

    c1 = dataclasses.replace(c1, indices=c0.indices, workspace=c0.workspace, parameters={**c1.parameters, **c0.parameters})
    des = {"r_b": rng.uniform(0.2, 0.6, D), "r_B": rng.uniform(0.5, 1.2, D), "h_B": rng.uniform(0.15, 0.5, D),
           "h_o": rng.uniform(-0.1, 0.4, D)}
    _global_equal(c0, c1, des)


@pytest.mark.parametrize("hand,described", [("p4s_paper.yaml", "p4s_legs.yaml"), ("sps_s.yaml", "sps_s_legs.yaml")])
def test_optdesign_evaluate_prints_the_same_indices(hand, described):
    from cli_helpers import run_cli_in

    outs = []
    for f in (hand, described):
        rc, out, err = run_cli_in(ROOT, ["evaluate", f"configs/{f}"])
        assert rc == 0, err
        outs.append(out.splitlines()[1:])            # the first line names the config and mechanism
        rc, js, err = run_cli_in(ROOT, ["evaluate", "--json", f"configs/{f}"])
        outs.append(json.loads(js)["designs"])
    assert outs[0] == outs[2]
    for dname, rec in outs[1].items():
        for k, v in rec.items():
            if isinstance(v, dict) and "mean" in v:
                for s in ("mean", "min", "max", "std"):
                    assert abs(outs[3][dname][k][s] - v[s]) <= 1e-12 * max(abs(v[s]), abs(v["mean"])), (dname, k, s)
