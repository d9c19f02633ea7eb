"""The walk along the singularity wall (optdesign.optimize.wall).

* its direction is the projection of -g onto the cone of directions that
  keep the active rows and bounds: inside the cone, Moreau-orthogonal, and
  no random direction of the cone is closer to -g;
* on configs/delta_opt.yaml (a Delta whose stiffness maximum lies on the
  singularity wall, a reach boundary 1e-6 of the box away): from a design
  SLSQP leaves stalled, the walk ends on the bounds R = 0.3 m, r = 0.03 m,
  at a stiffness no lower than the best feasible design of a dense grid
  over (L_a, L_b) on those bounds, feasible for the Evaluator and on a dense
  grid of W's bottom rim (where the maximum of cond lies).
"""
from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS

from optdesign.config import load_config
from optdesign.evaluate import _COND, Evaluator
from optdesign.optimize.problem import DesignProblem, index_term
from optdesign.optimize.wall import ACTIVE_ROW, _direction, walk_design
from optdesign import worstcase


def test_the_direction_is_the_projection_onto_the_cone_of_the_active_rows_and_bounds():
    rng = np.random.default_rng(3)
    for _ in range(50):
        n = 4
        g = rng.normal(size=n)
        J = rng.normal(size=(3, n)) * 10.0 ** rng.uniform(-2, 6, size=(3, 1))
        c = rng.choice([0.0, 1.0, 3 * ACTIVE_ROW], size=3)
        u = rng.choice([0.0, 0.5, 1.0], size=n, p=[0.2, 0.6, 0.2])
        d, _, _ = _direction(g, c, J, u)
        act = [J[j] / np.linalg.norm(J[j]) for j in range(3) if c[j] <= ACTIVE_ROW]
        B = np.array(act + [np.eye(n)[i] for i in range(n) if u[i] <= 0] + [-np.eye(n)[i] for i in range(n) if u[i] >= 1])
        if len(B):
            assert np.all(B @ d >= -1e-9)                                # in the cone
        assert abs(d @ (d + g)) <= 1e-9 * max(1.0, np.linalg.norm(g) ** 2)   # Moreau: d is orthogonal to d + g
        K = rng.normal(size=(4000, n))
        if len(B):
            K = K[np.all(K @ B.T >= 0, axis=1)]
        for k in K[:200]:
            t = max(0.0, -(k @ g) / (k @ k))                            # the best multiple of k
            assert np.linalg.norm(d + g) <= np.linalg.norm(t * k + g) + 1e-9


@pytest.mark.slow
def test_the_walk_reaches_the_corner_of_the_delta_and_beats_a_dense_grid():
    ev = Evaluator.from_config(load_config(CONFIGS / "delta_opt.yaml"))
    problem = DesignProblem(ev, [index_term("stiffness", "max")])
    x0 = np.array([0.297917, 0.036717, 0.199996, 0.615165])          # where SLSQP stalls (19.086 N/m)
    got = walk_design(problem, x0, 300)
    x = np.array(got["end"])
    r = ev(x[None])
    assert all(v[0] <= 0 for v in r["constraints"].values())
    assert x[0] == ev.xu[0] and x[1] == ev.xl[1]                      # R and r on their bounds
    stiffness = float(r["values"]["stiffness"][0])
    assert stiffness == pytest.approx(-got["end_value"], rel=1e-12)
    # a dense grid over (L_a, L_b) on those bounds
    A, B = np.meshgrid(np.linspace(0.190, 0.206, 81), np.linspace(0.600, 0.630, 121), indexing="ij")
    G = np.stack([np.full(A.size, ev.xu[0]), np.full(A.size, ev.xl[1]), A.ravel(), B.ravel()], axis=1)
    rg = ev(G)
    ok = np.all([np.asarray(v) <= 0 for v in rg["constraints"].values()], axis=0)
    assert ok.any() and stiffness >= np.max(rg["values"]["stiffness"][ok]) * (1 - 1e-9)
    # and the walk's design holds on a dense grid of W's bottom rim
    th = np.linspace(0.0, 2.0 * np.pi, 100001)
    rim = np.stack([0.15 * np.cos(th), 0.15 * np.sin(th), np.full_like(th, -0.7)], axis=1)
    req = next(q for q in ev.requests_all if q.name == (ev._cond or _COND))
    f = worstcase.local_functions(ev.mechanism, ev.fixed, ev.designs(x[None]), req.kind, req.convention)["cond"]
    cond = np.asarray(f(np.zeros(1, int))(rim[:, None, :]), float)
    assert np.all(np.isfinite(cond)) and np.max(cond) <= ev.limit * (1 + 1e-9)
