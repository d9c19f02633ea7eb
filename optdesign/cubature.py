"""Adaptive cubature of the integral mean over W (``workspace.sampling: adaptive``).

A global index is ``int_W sigma m dW / int_W m dW`` (eq. 29, ``m`` the
reachable indicator).  This module estimates it to a requested relative
``tolerance`` with an embedded rule on a partition of W that is refined where
the error is:

* the Genz-Malik rule (degree 7 with an embedded degree-5 rule, 2^d + 2d^2 +
  2d + 1 nodes) on boxes of d >= 2 free coordinates, the Gauss-Kronrod 7-15
  pair on d = 1; the error of a box is ``SAFETY |Q_hi - Q_lo|`` (below);
* a cylinder is integrated in (radius, angle, height) with the Jacobian r;
* each pass splits, in two along the coordinate of the largest fourth
  difference (Genz-Malik), the boxes that carry the largest half of the
  remaining error, and evaluates every new node of every box for all designs
  in one call of the vectorized index path (``local(X) -> (values, reach)``,
  values ``{index: (D, N)}``);
* the region is a workspace spec (:class:`optdesign.workspace.WorkspaceSpec`,
  read by its fields: this module imports no other part of the package, the
  workspace module builds its starting rule from it);
* the error of a mean is propagated from its numerator and denominator;
* a design and index ends ``converged`` (error <= tolerance * |mean|),
  ``unbounded`` or ``not_converged`` (the point budget ``max_points`` is spent).

``unbounded`` (the integrand is not bounded on W, a singular design: cond ->
inf inside W) is said when a local value at a reachable node is not finite,
or when the cubature did not converge and the largest local value it found
grew under refinement without bound in sight: to at least ``GROWTH`` times
the largest value of the starting partition's nodes and at least ``SPIKE``
times the mean (a bounded integrand that the budget does not resolve, such as
the jump at the edge of the reachable region, keeps its largest value; near a
singularity cond ~ 1/distance grows as the boxes shrink).  From the pass where
an index grew so, it no longer drives the refinement (the budget goes to the
other indices).  An unbounded index gets the mean +-inf (the sign of its
values), never a finite mean.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["genz_malik", "gauss_kronrod", "CubatureResult", "integrate", "initial_rule", "GROWTH", "SPIKE", "SAFETY", "CALL_PAIRS"]

#: the error of a box is SAFETY |Q_hi - Q_lo|: on an integrand with a cone (sigma_max of M and sigma_min of J
#: where two singular values are equal, at the centre of the 3-P(4S)'s W by its three-fold symmetry) Q_hi
#: converges no faster than Q_lo, and its error is about |Q_hi - Q_lo| (measured 1.15-1.17 times it, docs/config.md)
SAFETY = 3.0
#: the most (node, design) pairs of one call of the index path (its memory: 250-500 bytes a pair on numpy)
CALL_PAIRS = 1_000_000
#: an index is unbounded when the largest local value grew by this factor from the starting partition ...
GROWTH = 100.0
#: ... to at least this many times the mean (and the cubature did not converge)
SPIKE = 1e4


def genz_malik(d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Genz-Malik rule on [-1, 1]^d (d >= 2): nodes (P, d), degree-7 and
    degree-5 weights (P,), each summing to 1 (rules of the mean over the cube)."""
    if d < 2:
        raise ValueError("the Genz-Malik rule needs at least two dimensions")
    l2, l3, l4, l5 = math.sqrt(9 / 70), math.sqrt(9 / 10), math.sqrt(9 / 10), math.sqrt(9 / 19)
    eye = np.eye(d)
    pts = [np.zeros((1, d)), l2 * eye, -l2 * eye, l3 * eye, -l3 * eye]
    pairs = []
    for i in range(d):
        for j in range(i + 1, d):
            for si in (1, -1):
                for sj in (1, -1):
                    p = np.zeros(d)
                    p[i], p[j] = si * l4, sj * l4
                    pairs.append(p)
    pts.append(np.array(pairs))
    corners = np.array(np.meshgrid(*([[-l5, l5]] * d), indexing="ij")).reshape(d, -1).T
    pts.append(corners)
    X = np.concatenate(pts)
    n1, n2, n4, n5 = 1, 2 * d, 2 * d * (d - 1), 2 ** d
    w7 = np.concatenate([[(12824 - 9120 * d + 400 * d * d) / 19683], np.full(n2, 980 / 6561),
                         np.full(n2, (1820 - 400 * d) / 19683), np.full(n4, 200 / 19683),
                         np.full(n5, 6859 / 19683 / 2 ** d)])
    w5 = np.concatenate([[(729 - 950 * d + 50 * d * d) / 729], np.full(n2, 245 / 486),
                         np.full(n2, (265 - 100 * d) / 1458), np.full(n4, 25 / 729), np.zeros(n5)])
    assert X.shape[0] == n1 + 2 * n2 + n4 + n5
    return X, w7, w5


_XGK = [0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
        0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
        0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
        0.207784955007898467600689403773245, 0.0]
_WGK = [0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
        0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
        0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
        0.204432940075298892414161999234649, 0.209482141084727828012999174891714]
_WG = [0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
       0.381830050505118944950369775488975, 0.417959183673469387755102040816327]


def gauss_kronrod() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Gauss-Kronrod 7-15 pair on [-1, 1]: nodes (15, 1), Kronrod and
    Gauss weights (15,) summing to 1 (the Gauss weights zero on Kronrod-only nodes)."""
    x = np.array([-v for v in _XGK[:-1]] + [0.0] + _XGK[:-1][::-1])
    wk = np.array(_WGK[:-1] + [_WGK[-1]] + _WGK[:-1][::-1]) / 2
    wg_half = [0.0, _WG[0], 0.0, _WG[1], 0.0, _WG[2], 0.0]
    wg = np.array(wg_half + [_WG[3]] + wg_half[::-1]) / 2
    return x[:, None], wk, wg


def _rule(d: int):
    return genz_malik(d) if d >= 2 else gauss_kronrod()


@dataclass
class CubatureResult:
    """Per index ``{name: (D,)}``: ``mean`` (+-inf where unbounded), ``error``
    (inf where unbounded), ``status`` (``converged``, ``not_converged``,
    ``unbounded``), ``min``/``max``/``std`` over the reachable nodes (std from
    the integral of sigma^2); ``reachable_fraction`` (D,), ``count`` (D,) the
    reachable nodes, ``points`` the nodes evaluated, ``regions`` the boxes of
    the final partition, ``passes`` the refinement passes."""

    mean: dict
    error: dict
    status: dict
    min: dict
    max: dict
    std: dict
    reachable_fraction: np.ndarray
    count: np.ndarray
    points: int
    regions: int
    passes: int


class _Geometry:
    """The integration box of a region (its free coordinates) and the map to poses with its Jacobian."""

    def __init__(self, spec, names: tuple[str, ...]):
        self.spec, self.names = spec, names
        if spec.type == "cylinder":
            lo3, hi3 = spec.axes[names[2]]
            self.lo = np.array([0.0, 0.0] + ([lo3] if hi3 > lo3 else []))
            self.hi = np.array([spec.radius, 2 * np.pi] + ([hi3] if hi3 > lo3 else []))
            self.jac_mean = 0.5 * spec.radius          # the mean of r over [0, R]
        else:
            self.free = [i for i, a in enumerate(names) if spec.axes[a][1] > spec.axes[a][0]]
            self.lo = np.array([spec.axes[names[i]][0] for i in self.free])
            self.hi = np.array([spec.axes[names[i]][1] for i in self.free])
            self.jac_mean = 1.0
        self.d = len(self.lo)

    def poses(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates U (N, d) -> poses (N, dof) and the Jacobian (N,)."""
        s = self.spec
        if s.type == "cylinder":
            cx, cy = s.center
            z = U[:, 2] if self.d == 3 else np.full(U.shape[0], s.axes[self.names[2]][0])
            X = np.stack([cx + U[:, 0] * np.cos(U[:, 1]), cy + U[:, 0] * np.sin(U[:, 1]), z], axis=-1)
            return X, U[:, 0].copy()
        X = np.empty((U.shape[0], len(self.names)))
        for i, a in enumerate(self.names):
            X[:, i] = s.axes[a][0]
        for j, i in enumerate(self.free):
            X[:, i] = U[:, j]
        return X, np.ones(U.shape[0])


def _initial_boxes(geo: _Geometry) -> tuple[np.ndarray, np.ndarray]:
    """The starting partition: 4 boxes per free coordinate (2 beyond three coordinates)."""
    k = 4 if geo.d <= 3 else 2
    edges = [np.linspace(lo, hi, k + 1) for lo, hi in zip(geo.lo, geo.hi)]
    mids = [0.5 * (e[1:] + e[:-1]) for e in edges]
    halves = [0.5 * (e[1:] - e[:-1]) for e in edges]
    C = np.stack([g.ravel() for g in np.meshgrid(*mids, indexing="ij")], axis=-1)
    H = np.stack([g.ravel() for g in np.meshgrid(*halves, indexing="ij")], axis=-1)
    return C, H


def initial_rule(spec, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The nodes (N, dof) and degree-7 weights (N,) (summing to 1) of the
    adaptive rule's starting partition: a fixed quadrature of the mean over W
    (for the paths that need points, e.g. stroke limits; the Genz-Malik
    weights include negative ones)."""
    geo = _Geometry(spec, names)
    if geo.d == 0:
        X, _ = geo.poses(np.zeros((1, 0)))
        return X, np.ones(1)
    C, H = _initial_boxes(geo)
    nodes, w7, _ = _rule(geo.d)
    U = (C[:, None, :] + H[:, None, :] * nodes[None]).reshape(-1, geo.d)
    X, jac = geo.poses(U)
    vol = np.prod(H, axis=1)
    w = (vol[:, None] * w7[None]).ravel() * jac
    return X, w / w.sum()


def _components(vals: dict, reach: np.ndarray, keys, jac: np.ndarray) -> np.ndarray:
    """(D, N, C) integrand components per node: m J, then sigma m J and sigma^2 m J per index."""
    m = np.where(reach, jac[None, :], 0.0)
    comps = [m]
    for k in keys:
        v = np.where(reach, vals[k], 0.0)
        comps += [v * m, v * v * m]
    return np.stack(comps, axis=-1)


def integrate(local: Callable, spec, names: tuple[str, ...], D: int, keys, tolerance: float,
              max_points: int) -> CubatureResult:
    """The integral mean over W of each index of ``keys`` for D designs, to the
    relative ``tolerance``, evaluating at most about ``max_points`` nodes
    (see the module's docstring)."""
    keys = list(keys)
    K = len(keys)
    geo = _Geometry(spec, names)
    if geo.d == 0:
        X, jac = geo.poses(np.zeros((1, 0)))
        vals, reach = local(X)
        return _point_result(vals, np.asarray(reach), keys)
    nodes, wh, wl = _rule(geo.d)
    P = nodes.shape[0]
    C, H = _initial_boxes(geo)
    vmax = np.zeros((D, K))
    vmin = np.full((D, K), np.inf)
    vmaxabs = np.zeros((D, K))
    nonfinite = np.zeros((D, K), bool)
    count = np.zeros(D, dtype=np.int64)

    def estimate(C, H):
        """Region estimates (R, D, Cc) of the high and low rules, fourth differences (R, d, D, Cc)."""
        nonlocal count
        R = C.shape[0]
        U = (C[:, None, :] + H[:, None, :] * nodes[None]).reshape(-1, geo.d)
        X, jac = geo.poses(U)
        vals, reach = local(X)
        reach = np.broadcast_to(np.asarray(reach, bool), (D, X.shape[0]))
        vals = {k: np.broadcast_to(np.asarray(vals[k], float), (D, X.shape[0])) for k in keys}
        for j, k in enumerate(keys):
            v = vals[k]
            bad = reach & ~np.isfinite(v)
            nonfinite[:, j] |= bad.any(axis=1)
            good = reach & np.isfinite(v)
            vmax[:, j] = np.maximum(vmax[:, j], np.max(np.where(good, v, -np.inf), axis=1))
            vmin[:, j] = np.minimum(vmin[:, j], np.min(np.where(good, v, np.inf), axis=1))
            vmaxabs[:, j] = np.maximum(vmaxabs[:, j], np.max(np.where(good, np.abs(v), 0.0), axis=1))
        count += reach.sum(axis=1)
        with np.errstate(all="ignore"):
            F = _components({k: np.where(np.isfinite(v), v, 0.0) for k, v in vals.items()}, reach, keys, jac)
        F = F.reshape(D, R, P, -1)
        vol = (2.0 ** geo.d * np.prod(H, axis=1)).reshape(-1, 1, 1)     # the boxes' volumes
        hi = np.einsum("drpc,p->rdc", F, wh) * vol
        lo = np.einsum("drpc,p->rdc", F, wl) * vol
        if geo.d >= 2:       # fourth differences along each axis (Genz-Malik's split rule)
            f0 = F[:, :, 0]
            a = F[:, :, 1:1 + geo.d] + F[:, :, 1 + geo.d:1 + 2 * geo.d] - 2 * f0[:, :, None]
            b = F[:, :, 1 + 2 * geo.d:1 + 3 * geo.d] + F[:, :, 1 + 3 * geo.d:1 + 4 * geo.d] - 2 * f0[:, :, None]
            diff = np.abs(a - (9 / 70) / (9 / 10) * b)          # (D, R, d, Cc)
            diff = np.moveaxis(diff, 2, 1).transpose(2, 1, 0, 3)  # (R, d, D, Cc)
        else:
            diff = np.ones((R, 1, D, F.shape[-1]))
        return hi, SAFETY * np.abs(hi - lo), diff

    est, err, diff = estimate(C, H)
    used = C.shape[0] * P
    first_max = vmaxabs.copy()
    passes = 0
    tol = float(tolerance)
    while True:
        I = est.sum(axis=0)            # (D, Cc)
        E = err.sum(axis=0)
        den = I[:, 0]
        with np.errstate(all="ignore"):
            mean = I[:, 1::2] / den[:, None]                            # (D, K)
            emean = (E[:, 1::2] + np.abs(mean) * E[:, :1]) / np.abs(den[:, None])
            done = (emean <= tol * np.abs(mean)) | ~np.isfinite(emean) & (den[:, None] == 0)
        with np.errstate(all="ignore"):   # grown without bound in sight: unbounded, it no longer drives refinement
            flagged = (vmaxabs >= GROWTH * first_max) & (vmaxabs >= SPIKE * np.abs(mean))
        done |= nonfinite | flagged
        if done.all() or used + P * 2 > max_points:
            break
        # each region's share of the remaining error of the undone means, in tolerances
        with np.errstate(all="ignore"):
            allowed = tol * np.abs(mean) * np.abs(den[:, None])          # (D, K)
            allowed = np.where(allowed > 0, allowed, np.finfo(float).tiny)
            share = (err[:, :, 1::2] + np.abs(mean)[None] * err[:, :, :1]) / allowed[None]   # (R, D, K)
        share = np.where(done[None], 0.0, np.nan_to_num(share, nan=0.0, posinf=1e300))
        score = share.max(axis=(1, 2))
        order = np.argsort(-score)
        cum = np.cumsum(score[order])
        n_split = int(np.searchsorted(cum, 0.5 * cum[-1])) + 1
        n_split = max(1, min(n_split, (max_points - used) // (2 * P), CALL_PAIRS // (2 * P * D)))
        pick = order[:n_split]
        # the axis to split: the largest fourth difference, weighted like the score
        with np.errstate(all="ignore"):
            wgt = np.where(done, 0.0, 1.0 / allowed)                    # (D, K)
            dsel = diff[pick][..., 1::2]                                # (n, d, D, K)
            axis_score = np.einsum("nadk,dk->na", np.nan_to_num(dsel, nan=0.0, posinf=1e300), wgt)
        # ties (an integrand flat along the axes) go to the widest side
        top = np.max(axis_score, axis=1, keepdims=True)
        tie = 1e-6 * H[pick] / np.max(H[pick], axis=1, keepdims=True)
        axis = np.argmax(np.where(top > 0, axis_score / np.where(top > 0, top, 1.0), 0.0) + tie, axis=1)
        Cp, Hp = C[pick].copy(), H[pick].copy()
        Hp[np.arange(len(pick)), axis] *= 0.5
        C1, C2 = Cp.copy(), Cp.copy()
        C1[np.arange(len(pick)), axis] -= Hp[np.arange(len(pick)), axis]
        C2[np.arange(len(pick)), axis] += Hp[np.arange(len(pick)), axis]
        Cn, Hn = np.concatenate([C1, C2]), np.concatenate([Hp, Hp])
        e2, r2, d2 = estimate(Cn, Hn)
        keep = np.ones(C.shape[0], bool)
        keep[pick] = False
        C, H = np.concatenate([C[keep], Cn]), np.concatenate([H[keep], Hn])
        est, err, diff = np.concatenate([est[keep], e2]), np.concatenate([err[keep], r2]), np.concatenate([diff[keep], d2])
        used += Cn.shape[0] * P
        passes += 1
    with np.errstate(all="ignore"):
        var = I[:, 2::2] / den[:, None] - mean ** 2
        converged = emean <= tol * np.abs(mean)
        growing = (vmaxabs >= GROWTH * first_max) & (vmaxabs >= SPIKE * np.abs(mean))
    unbounded = nonfinite | (~converged & growing)
    empty = den <= 0
    out_mean, out_err, status = {}, {}, {}
    for j, k in enumerate(keys):
        sign = np.where(vmax[:, j] > 0, 1.0, -1.0)
        m = np.where(unbounded[:, j], sign * np.inf, mean[:, j])
        out_mean[k] = np.where(empty, np.nan, m)
        out_err[k] = np.where(empty, np.nan, np.where(unbounded[:, j], np.inf, emean[:, j]))
        st = np.where(unbounded[:, j], "unbounded", np.where(converged[:, j], "converged", "not_converged"))
        status[k] = np.where(empty, "unreachable", st)
    return CubatureResult(
        out_mean, out_err, status,
        {k: np.where(empty, np.nan, vmin[:, j]) for j, k in enumerate(keys)},
        {k: np.where(empty, np.nan, vmax[:, j]) for j, k in enumerate(keys)},
        {k: np.where(empty, np.nan, np.sqrt(np.maximum(var[:, j], 0.0))) for j, k in enumerate(keys)},
        np.where(count == used, 1.0, np.clip(den / geo.jac_mean / np.prod(geo.hi - geo.lo), 0.0, 1.0)),
        count, int(used), int(C.shape[0]), passes)


def _point_result(vals: dict, reach: np.ndarray, keys) -> CubatureResult:
    """W is one pose: the index's value there (exact)."""
    reach = reach.reshape(reach.shape[0] if reach.ndim > 1 else 1, -1)[:, 0]
    D = reach.shape[0]
    mean, err, status, mn = {}, {}, {}, {}
    for k in keys:
        v = np.broadcast_to(np.asarray(vals[k], float), (D, 1))[:, 0]
        ok = reach & np.isfinite(v)
        mean[k] = np.where(reach, np.where(np.isfinite(v), v, np.inf), np.nan)
        err[k] = np.where(ok, 0.0, np.where(reach, np.inf, np.nan))
        status[k] = np.where(ok, "converged", np.where(reach, "unbounded", "unreachable"))
        mn[k] = np.where(reach, v, np.nan)
    return CubatureResult(mean, err, status, mn, dict(mn), {k: np.where(reach, 0.0, np.nan) for k in keys},
                          reach.astype(float), reach.astype(np.int64), 1, 1, 0)
