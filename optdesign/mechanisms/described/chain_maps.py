"""A declared coordinate map of a chain mechanism's pose (``pose.map``,
docs/lower-mobility.md): the independent pose coordinates as expressions of
new coordinates (e.g. the UPS+UPR+S's ``pitch = asin(s_theta)``), with exact
first and second derivatives (:mod:`.expr_diff`), so that the Jacobian, the
mass matrix and the velocity products are those of the new coordinates:
``J = J_pose Df``, ``M = Df^T M_pose Df`` and the mapped coordinates'
accelerations ``Df a + v^T H v`` (:func:`.chain_dynamics.unknowns_bias`).
The forward kinematics inverts the map by Newton from 0.
"""
from __future__ import annotations

import numpy as np

from .chain_poe import lsq

__all__ = ["coordinate_map", "unmap", "home_coordinates"]


def _map_trees(mech):
    cls = type(mech)
    t = cls.__dict__.get("_map_derivatives")
    if t is None:
        from .expr_diff import diff

        spec = mech.pose_spec
        d1 = [[diff(f, c) for c in spec.coords] for f in spec.cmap]
        d2 = [[[diff(g, c) for c in spec.coords] for g in row] for row in d1]
        t = (d1, d2)
        cls._map_derivatives = t
    return t


def coordinate_map(mech, X):
    """(the mapped pose coordinates (..., n), Df (..., n, n) = d(pose coordinate)/
    d(coordinate), H (..., n, n, n) its second derivatives) at coordinates X."""
    from .expr import evaluate

    spec = mech.pose_spec
    env = dict(mech.params)
    env.update({c: X[..., i] for i, c in enumerate(spec.coords)})
    shape = np.broadcast_shapes(X.shape[:-1], mech.chain_constants.base.shape)
    ev = lambda t: np.broadcast_to(np.asarray(evaluate(t, env), dtype=float), shape)  # noqa: E731
    d1, d2 = _map_trees(mech)
    with np.errstate(all="ignore"):
        Xr = np.stack([ev(t) for t in spec.cmap], -1)
        Df = np.stack([np.stack([ev(t) for t in row], -1) for row in d1], -2)
        H = np.stack([np.stack([np.stack([ev(t) for t in r2], -1) for r2 in row], -2) for row in d2], -3)
    return Xr, Df, H


def unmap(mech, Xr, iters: int = 40):
    """The coordinates whose map gives the pose coordinates Xr: Newton from 0
    (NaN where it does not converge)."""
    X = np.zeros(Xr.shape)
    with np.errstate(all="ignore"):
        for _ in range(iters):
            f, Df, _ = coordinate_map(mech, X)
            X = X - lsq(Df, f - Xr)
        f, _, _ = coordinate_map(mech, X)
        ok = np.all(np.abs(f - Xr) <= 1e-12 * (1.0 + np.abs(Xr)), axis=-1)
    return np.where(ok[..., None], X, np.nan)


def home_coordinates(mech) -> np.ndarray:
    """The independent coordinates of the home pose, S + (n,) (the map
    inverted where there is one: per design when it has parameters)."""
    spec = mech.pose_spec
    home = np.asarray(spec.home, dtype=float)[list(spec.independent_index)]
    S = tuple(mech.chain_constants.base.shape)
    home = np.broadcast_to(home, S + home.shape)
    return home if spec.cmap is None else unmap(mech, home)
