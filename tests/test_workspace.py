"""Workspace regions and samples: grids and quasi-random points (seeded,
reproducible, inside the region, the right counts) and the reachable fraction."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from optdesign.config import WorkspaceSpec
from optdesign.evaluate import evaluate
from optdesign.workspace import sample

NAMES = ("x", "y", "z")


def box(axes, **kw):
    return WorkspaceSpec(type="box", axes=axes, **kw)


def cyl(radius, z, center=(0.0, 0.0), **kw):
    return WorkspaceSpec(type="cylinder", axes={"z": z}, radius=radius, center=center, **kw)


# ----------------------------------------------------------------------------- grids
def test_plane_grid_by_step():
    ws = sample(box({"x": (-0.05, 0.05), "y": (-0.05, 0.05), "z": (0.57, 0.57)}, step=0.01), NAMES)
    assert ws.X.shape == (121, 3) and ws.grid_shape == (11, 11)
    assert np.all(ws.X[:, 2] == 0.57)
    xs = np.unique(ws.X[:, 0])
    assert len(xs) == 11 and xs[0] == -0.05 and xs[-1] == 0.05      # the grid ends on the bound
    np.testing.assert_allclose(np.diff(xs), 0.01, rtol=1e-9)
    assert ws.free_axes() == ["x", "y"]
    # 'ij' order: the first free axis varies slowest (reshape to grid_shape works)
    np.testing.assert_allclose(ws.X[:, 0].reshape(ws.grid_shape)[:, 0], xs)


def test_box_grid_by_points_per_axis_and_step_not_dividing():
    ws = sample(box({"x": (-0.1, 0.1), "y": (0.0, 0.2), "z": (0.5, 0.6)}, points_per_axis=4), NAMES)
    assert ws.X.shape == (64, 3) and ws.grid_shape == (4, 4, 4)
    np.testing.assert_allclose(np.unique(ws.X[:, 2]), np.linspace(0.5, 0.6, 4))
    ws = sample(box({"x": (0.0, 0.1), "y": (0.0, 0.0), "z": (0.5, 0.5)}, step=0.03), NAMES)
    np.testing.assert_allclose(ws.X[:, 0], [0.0, 0.03, 0.06, 0.09])   # never beyond the upper bound


def test_cylinder_grid_inside_and_count():
    r, step = 0.05, 0.01
    ws = sample(cyl(r, (0.55, 0.59), center=(0.01, -0.02), step=step), NAMES)
    dx, dy = ws.X[:, 0] - 0.01, ws.X[:, 1] + 0.02
    assert np.all(dx ** 2 + dy ** 2 <= r * r * (1 + 1e-9))
    assert np.all((ws.X[:, 2] >= 0.55) & (ws.X[:, 2] <= 0.59))
    # lattice points of the disc counted independently (integers i^2 + j^2 <= 25), times 5 heights
    n_disc = sum(1 for i in range(-5, 6) for j in range(-5, 6) if i * i + j * j <= 25)
    assert ws.n == n_disc * 5 == 81 * 5


# ----------------------------------------------------------------------------- random samples
@pytest.mark.parametrize("kind", ["sobol", "halton", "lhs", "random"])
def test_qmc_box_seeded_inside_counts(kind):
    spec = box({"x": (-0.05, 0.05), "y": (-0.02, 0.04), "z": (0.57, 0.57)}, sampling=kind, points=300, seed=5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = sample(spec, NAMES).X
    b = sample(spec, NAMES).X
    c = sample(dataclasses.replace(spec, seed=6), NAMES).X
    assert a.shape == (300, 3)
    np.testing.assert_array_equal(a, b)                 # reproducible
    assert not np.allclose(a, c)                        # the seed matters
    assert np.all((a[:, 0] >= -0.05) & (a[:, 0] <= 0.05) & (a[:, 1] >= -0.02) & (a[:, 1] <= 0.04))
    assert np.all(a[:, 2] == 0.57)
    assert len(np.unique(a[:, :2], axis=0)) == 300
    # the sample fills the region: every quarter of the x range holds 15-35 % of the points
    counts = np.histogram(a[:, 0], bins=4, range=(-0.05, 0.05))[0]
    assert counts.min() >= 45 and counts.max() <= 105


def test_lhs_is_stratified():
    a = sample(box({"x": (0.0, 1.0), "y": (0.0, 1.0), "z": (0.0, 2.0)}, sampling="lhs", points=50, seed=1), NAMES).X
    for k, hi in enumerate((1.0, 1.0, 2.0)):
        strata = np.floor(a[:, k] / hi * 50).astype(int)
        assert sorted(strata) == list(range(50))


@pytest.mark.parametrize("kind", ["sobol", "halton", "random"])
def test_qmc_cylinder_uniform_over_the_disc(kind):
    spec = cyl(0.05, (0.55, 0.59), sampling=kind, points=4096, seed=2)
    X = sample(spec, NAMES).X
    assert X.shape == (4096, 3)
    rr = np.hypot(X[:, 0], X[:, 1])
    assert rr.max() <= 0.05 * (1 + 1e-12)
    assert np.all((X[:, 2] >= 0.55) & (X[:, 2] <= 0.59))
    # uniform over the area: half of the points within r / sqrt(2), a quarter in each quadrant
    assert np.mean(rr <= 0.05 / np.sqrt(2)) == pytest.approx(0.5, abs=0.03)
    quad = np.mean((X[:, 0] > 0) & (X[:, 1] > 0))
    assert quad == pytest.approx(0.25, abs=0.03)
    np.testing.assert_array_equal(X, sample(spec, NAMES).X)


def test_qmc_cylinder_plane():
    X = sample(cyl(0.03, (0.57, 0.57), sampling="sobol", points=100, seed=0), NAMES).X
    assert X.shape == (100, 3) and np.all(X[:, 2] == 0.57)


# ----------------------------------------------------------------------------- reachable fraction
def _reachable_by_distance(design, X):
    """Independent test of reachability: every top joint d_i must be within L of
    its rail line (the slider's line of motion)."""
    r_a, r_b, L, d, phi = (design[k] for k in ("r_a", "r_b", "L", "d", "phi"))
    rho = np.sqrt(r_a ** 2 - d ** 2 / 4)
    ok = np.ones(len(X), bool)
    for g in (0.0, 2 * np.pi / 3, 4 * np.pi / 3):
        e = np.array([np.cos(g), np.sin(g), 0.0])
        m = -np.cos(phi) * e + np.array([0, 0, np.sin(phi)])
        w = X + rho * e - r_b * e
        perp = w - np.outer(w @ m, m)
        ok &= np.linalg.norm(perp, axis=1) <= L
    return ok


def test_reachable_fraction_of_a_large_region(paper_config):
    """A box reaching beyond the workspace of the before design: the reported
    reachable fraction equals an independent count, and the global mean is
    taken over the reachable points only."""
    spec = box({"x": (-0.3, 0.3), "y": (-0.3, 0.3), "z": (0.3, 0.8)}, sampling="sobol", points=2048, seed=0)
    ws = sample(spec, NAMES)
    design = paper_config.design("before")
    ev = evaluate(paper_config, [design], ws, keep_local=True)
    ind = _reachable_by_distance(design, ws.X)
    assert 0.2 < ind.mean() < 0.9
    np.testing.assert_array_equal(ev.reachable[0], ind)
    assert ev.reachable_fraction[0] == pytest.approx(ind.mean())
    loc = ev.local["isotropy"][0]
    assert np.all(np.isnan(loc[~ind]))
    assert ev.summary["isotropy"]["mean"][0] == pytest.approx(np.mean(loc[ind]))


def test_reachable_fraction_zero_gives_nan_summary(paper_config):
    ws = sample(box({"x": (-0.01, 0.01), "y": (-0.01, 0.01), "z": (2.0, 2.0)}, step=0.01), NAMES)
    ev = evaluate(paper_config, [paper_config.design("after")], ws)
    assert ev.reachable_fraction[0] == 0.0
    assert np.isnan(ev.summary["dynamic"]["mean"][0])
