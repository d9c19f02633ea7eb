"""The worst case of a local quantity over the continuous workspace W.

A local constraint (the singularity bound cond(J) <= limit, reachability,
the stroke limits) must hold at every pose of W, not only at the samples.
:func:`maximize` finds, for each of D designs, the largest value of a local
quantity over W by a continuous search:

1. the ``starts`` worst samples of the evaluated points, each at least two
   sample spacings from the ones picked before (so that the starts lie on
   different hills), are the starting poses;
2. from each, a local search over the free pose axes inside W's bounds (a
   box: clipped to it; a cylinder: projected onto its disc), vectorized over
   every (design, start) pair at once, in W's unit coordinates: where the
   quantity has a compiled path a zoom (pattern) search (:func:`_zoom`:
   per level the 3^f - 1 neighbours at offsets -h, 0, h, in one call; h
   halves where none gains), else a projected gradient ascent
   (:func:`_ascent`: forward differences, a step along the normalized
   gradient that doubles when it gains and halves when it does not), until
   h or the step falls below ``tol`` or ``iterations`` are spent;
3. a pair stops early once its value passes ``stop`` (the design is
   infeasible by a clear margin: its value is then a lower bound of the
   maximum, enough to reject it) or is not finite (an unreachable pose or an
   exact singularity: a violation).

The quantity is a factory ``make(index)`` of a callable ``f(X) -> (K, M)``:
the value at poses X[:, m] (SI, (K, M, dof)) of design ``index[m]``, larger is
worse, ``inf`` where the pose is not reachable (one mechanism instance of the
M starts' designs serves the whole search).  :func:`local_functions` builds
the conditioning and stroke quantities of a mechanism class for a population (cond
from the compiled ``Mechanism.local_values_at`` where the class has it, else
the Jacobian from ``Mechanism.index_matrices`` through
:func:`optdesign.indices.local_index`; the same convention as the sampled
index).  The answer of :func:`maximize`
is never below the samples' maximum.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..indices import local_index
from ..mechanisms.base import IndexRequest, Mechanism
from ..workspace import Workspace
from .search import ITERATIONS, STARTS, TOL, _project, maximize, region  # noqa: F401  (re-exported)

#: a design whose cond maximum comes within this share of the limit has its maximum refined (:func:`maximize`)
REFINE = 0.9

__all__ = ["ITERATIONS", "STARTS", "TOL", "local_functions", "maximize", "q_range", "region", "worst_over_w", "worst_poses"]


def local_functions(mechanism: type, fixed: Mapping[str, float], designs: Mapping[str, np.ndarray],
                    kind: str = "isotropy", convention: str | None = None, stroke: bool = False,
                    compiled: bool = True) -> dict:
    """The local quantities of a population for :func:`maximize`, each a
    factory ``make(index) -> f(X)`` (one mechanism of the designs ``index``
    (M,), poses X (K, M, dof) -> (K, M)): ``"cond"`` (the condition number of
    the Jacobian by ``convention``, inf where the pose is not reachable) and,
    with ``stroke``, ``"q_max"`` and ``"q_min_neg"`` (the largest actuator
    value and minus the smallest, inf where not reachable).  ``designs`` maps
    parameters to arrays (D,).  The condition number comes from the
    mechanism's compiled path (``Mechanism.local_values_at``) where it has
    one (and ``compiled``), else from the numpy path."""
    designs = {k: np.asarray(v, float) for k, v in designs.items()}
    population = []

    def mech_of(index):
        m = mechanism(**{**fixed, **{k: v[index] for k, v in designs.items()}})
        if designs:
            if not population:
                population.append(mechanism(**{**fixed, **designs}))
            D = len(next(iter(designs.values())))
            m.rows_of(population[0], np.arange(D)[index])
        return m

    request = IndexRequest("cond", kind, convention)

    def cond(index):
        m = mech_of(index)

        if compiled:
            def zoom(base, reg, u, val, h, live, budget, grid, stop, tol):
                return m.zoom_cond(request, base, reg, u, val, h, live, budget, grid, stop, tol)

        def f(X):
            fast = m.local_values_at([request], np.swapaxes(X, 0, 1)) if compiled else None
            if fast is not None:       # the compiled path: each start's design at its own poses
                vals, reach = fast
                c, reach = vals["cond"].T, reach.T
                return np.where(reach & np.isfinite(c), c, np.inf)
            with np.errstate(all="ignore"):
                st = m.state(X)
                reach = np.asarray(st.reachable, bool)
                c = np.asarray(local_index(kind, J=st.J, M=None, convention=convention, options={}), float)
            return np.where(reach & np.isfinite(c), c, np.inf)
        if compiled:
            f.zoom = zoom
        return f

    # the compiled path where the class has one (it may still decline: then the numpy path, correct but slower)
    cond.compiled = compiled and getattr(mechanism, "local_values_at", None) is not Mechanism.local_values_at
    out = {"cond": cond}
    if stroke:
        def q(index, sign):
            m = mech_of(index)

            def f(X):
                with np.errstate(all="ignore"):
                    st = m.state(X)
                    reach = np.asarray(st.reachable, bool)
                    v = np.max(np.asarray(st.q, float) * sign, axis=-1)
                return np.where(reach & np.isfinite(v), v, np.inf)
            return f
        out["q_max"] = lambda index: q(index, 1.0)
        out["q_min_neg"] = lambda index: q(index, -1.0)
    return out


def q_range(Q) -> tuple[np.ndarray, np.ndarray]:
    """(min, max) (D,) of the finite actuator values Q (D, N, n_act); NaN where none."""
    with np.errstate(all="ignore"):
        F = np.where(np.isfinite(Q), Q, np.nan)
        return np.nanmin(F, axis=(-1, -2)), np.nanmax(F, axis=(-1, -2))


def _sampled_cond(mech, X: np.ndarray, request, D: int, serial: bool = True) -> np.ndarray:
    """The local condition numbers (D, N) at the samples, inf where not
    reachable: the compiled path's local values when it has them (with
    ``serial`` its serial kernel of each design at its own points, cheaper for
    a population than the parallel one's start-up)."""
    fast = mech.local_values_at([request], np.broadcast_to(X, (D,) + X.shape)) if serial else None
    if fast is None:
        fast = mech.local_values([request], X)
    with np.errstate(all="ignore"):
        if fast is not None:
            vals, reach = fast
            v = np.broadcast_to(vals[request.name], (D, X.shape[0]))
        else:
            st = mech.state(X)
            reach = st.reachable
            v = local_index(request.kind, J=st.J, M=None, convention=request.convention, options={})
        reach = np.broadcast_to(reach, (D, X.shape[0]))
        v = np.broadcast_to(v, (D, X.shape[0]))
    return np.where(reach & np.isfinite(v), v, np.inf)


def worst_over_w(mechanism: type, fixed: Mapping[str, float], designs: Mapping[str, np.ndarray], ws: Workspace,
                 request, limit: float, cmax: np.ndarray, reach_fraction: np.ndarray, Q=None,
                 stroke_limits: tuple[float, float] | None = None, margin: float = 0.0, method: str = "auto",
                 poses: bool = False):
    """The maxima over W of the local constraints of a population (what the
    Evaluator's constraints need): ``(max cond (D,), (min q, max q) (D,) or
    None)``.  ``cmax`` and ``Q`` (D, N, n_act) are the samples' values; the
    search runs for the designs the samples find feasible (every point
    reachable, cond <= ``limit``, the strokes within the limits narrowed by
    ``margin`` times their span); the others are infeasible already and keep
    their sampled values.  ``request`` is the conditioning index request (its
    kind and convention are those of the sampled index); ``method`` that of
    :func:`maximize` (``"ascent"``: the earlier search as it was, on the numpy
    path's quantities, for benchmarks/bench_worstcase.py).  With ``poses`` a
    third item: ``{"cond", "q_max", "q_min"}`` -> the pose (D, dof) SI of each
    maximum (of the largest actuator value, of the smallest), and
    ``"cond_hills"`` (D, starts, dof) the local maximum of cond on each hill
    the search climbed (:func:`maximize`'s ``hills``), NaN rows for the
    designs not searched (and no stroke keys without strokes): where the
    derivative of the maximum is the partial derivative (the envelope theorem)."""
    cmax = np.array(cmax, float)
    D = cmax.shape[0]
    dof = ws.X.shape[1]
    where = {"cond": np.full((D, dof), np.nan), "cond_hills": np.full((D, max(1, min(STARTS, len(ws.X))), dof), np.nan)}
    ok = (reach_fraction >= 1.0) & np.isfinite(cmax) & (cmax <= limit)
    qr = q_range(Q) if Q is not None else None
    if qr is not None:
        lo, hi = stroke_limits
        pad = margin * (hi - lo)
        ok &= (qr[0] >= lo + pad) & (qr[1] <= hi - pad)
        where["q_max"], where["q_min"] = np.full((D, dof), np.nan), np.full((D, dof), np.nan)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return (cmax, qr, where) if poses else (cmax, qr)
    sub = {k: np.asarray(v, float)[idx] for k, v in designs.items()}
    mech = mechanism(**{**fixed, **{k: v[:, None] for k, v in sub.items()}})
    new = method != "ascent"                # "ascent": the earlier search as it was, numpy quantities
    sampled = _sampled_cond(mech, ws.X, request, idx.size, serial=new)
    fs = local_functions(mechanism, fixed, sub, request.kind, request.convention, stroke=qr is not None,
                         compiled=new)
    found, where["cond"][idx], hill = maximize(fs["cond"], ws, sampled, stop=2.0 * limit, method=method, hills=True,
                                                   refine=REFINE * limit)
    where["cond_hills"][idx] = hill
    cmax[idx] = np.maximum(cmax[idx], found)
    if qr is not None:
        qn, qx = qr[0].copy(), qr[1].copy()
        Qs = np.asarray(Q)[idx]
        with np.errstate(all="ignore"):
            fin = np.all(np.isfinite(Qs), axis=-1)
            top = np.where(fin, np.max(Qs, axis=-1), np.inf)
            neg = np.where(fin, np.max(-Qs, axis=-1), np.inf)
        vx, where["q_max"][idx] = maximize(fs["q_max"], ws, top, method=method)
        vn, where["q_min"][idx] = maximize(fs["q_min_neg"], ws, neg, method=method)
        qx[idx] = np.maximum(qx[idx], vx)
        qn[idx] = np.minimum(qn[idx], -vn)
        qr = (qn, qx)
    return (cmax, qr, where) if poses else (cmax, qr)


def worst_poses(mechanism: type, fixed: Mapping[str, float], designs: Mapping[str, np.ndarray], ws: Workspace,
                request, sampled: np.ndarray, limit: float | None = None, hills: bool = False) -> np.ndarray:
    """The pose (D, dof) SI of each design's largest condition number over W
    (``sampled`` (D, N) its values at ``ws.X``, inf where not reachable):
    where the gradient polish adds the constraint at the worst pose (by the
    envelope theorem the derivative of the maximum over W is the partial
    derivative there).  With ``limit``: refined as :func:`worst_over_w`
    refines it (the same pose the Evaluator's constraint comes from, up to
    twice the limit: that search ends a start there, this one climbs on to
    the hill's maximum; ending it there too changed the runs' results and
    saved no time, docs/performance.md).  With
    ``hills``: (D, k, dof) the local maximum of every hill the search
    climbed (:func:`maximize`), NaN for a design it skipped."""
    fs = local_functions(mechanism, fixed, designs, request.kind, request.convention)
    refine = np.inf if limit is None else REFINE * limit
    got = maximize(fs["cond"], ws, np.asarray(sampled, float), refine=refine, hills=hills)
    return got[2] if hills else got[1]
