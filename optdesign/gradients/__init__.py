"""Derivatives of the global indices and of the smooth constraints with
respect to the free design variables, for the gradient polish of
:mod:`optdesign.optimize.polish`.

Two routes, one answer (:class:`Derivatives`):

* ``ad`` -- the mechanism's CasADi model (:mod:`optdesign.symbolic`, the
  registry's ``symbolic_model``) differentiated by CasADi: with the closure
  ``f(x, q, p) = 0`` the actuators follow the design implicitly,
  ``dq/dp = -f_q^-1 f_p``; ``J = -f_q^-1 f_x`` and the platform mass matrix
  ``M_p = d^2 T / d xdot^2`` are differentiated totally
  (``dA/dp = dA/dp|_q + dA/dq dq/dp``).  The matrices themselves are the
  mechanism's own (numpy or compiled path); the CasADi ones must equal them
  (to 1e-8 relative) or the route is refused.  The derivative of
  ``M = J^-T M_p`` follows from ``J^T M = M_p``:
  ``dM = J^-T (dM_p - dJ^T M)``.  Each local index's derivative is then taken
  from its matrix in closed form (:func:`local_derivative`).  Values alone
  (``values_only``: SLSQP's line searches, about four calls per iteration)
  come from the mechanism's compiled path where it answers every request
  (:func:`_compiled_values`, about half the time of the numpy matrices): the
  same quantities, equal to round-off;
* ``fd`` -- central differences on the vectorized evaluation, the checked
  fallback where a mechanism has no AD route (described mechanisms, a free
  parameter the CasADi model does not read, a Jacobian convention it does not
  share): one evaluation of ``4 n + 1`` designs (steps h and 2h), the
  difference of the two estimates kept as an error estimate (``fd_error``);
  the worst-case constraints from the local quantity at the poses of their
  maxima, held (the envelope theorem), one singularity row per hill of W
  (:mod:`.fd`).

Global indices are the means over the reachable points (eq. 29, with the
workspace's quadrature weights where it has them), so their derivative is the
mean of the local derivatives at a design whose points are all reachable.
"""
from __future__ import annotations

import weakref
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from .. import fast, worstcase
from ..evaluate import _COND, Evaluator
from ..local_derivatives import local_derivative, solve as _solve
from ..mechanisms import symbolic_model
from .casadi_fn import ad_function as _ad_function, arguments as _arguments, columns as _columns
from .casadi_fn import mapped as _mapped, vec_columns as _vec_columns
from .fd import ENVELOPE_STEP, FD_STEP, fd_derivatives, smooth_singularity  # noqa: F401  (re-exported)

__all__ = ["Derivatives", "derivatives", "local_derivative", "ad_available", "smooth_singularity"]

#: relative agreement the CasADi matrices must have with the mechanism's own
CHECK_RTOL = 1e-8
#: answers of :func:`derivatives` kept per Evaluator (the last ones asked for):
#: SLSQP, its restarts, the optimality measure and the walk ask again for
#: designs they had (14 % of the calls of two runs each of the Python API page's
#: config and a small Delta, measured);
#: the answer is a function of (X, route, values_only), the compiled paths'
#: switch and the Evaluator's constraint settings, all in the key, so a repeat
#: gets the same object
MEMO = 64
#: the Evaluator's settings a derivative depends on, besides the design (part of the memo's key)
_SETTINGS = ("stroke_limits", "worst_case", "worst_case_method", "limit", "threshold", "margin")
_MEMOS: "weakref.WeakKeyDictionary[Evaluator, OrderedDict]" = weakref.WeakKeyDictionary()


@dataclass
class Derivatives:
    """Values and derivatives at D designs (n free variables).

    ``values[name]`` (D,) global index means and extra objectives,
    ``grads[name]`` (D, n); ``constraints[name]`` (D, m) the smooth
    constraints (``<= 0`` feasible) and ``constraint_grads[name]`` (D, m, n);
    ``reach`` (D,) the reachable fraction of W (a hard check, not
    differentiated).  ``route``: ``ad`` or ``fd`` (``reason``: why not AD);
    ``fd_error[name]`` (D, n): |g(h) - g(2h)| / 3 on the fd route.

    The smooth constraints: on the AD route ``singularity`` is
    ``log(cond(x_j) / limit)`` at every workspace point j (the same
    feasible set as the Evaluator's sampled ``max_W cond / limit - 1``, without
    the kink of the maximum, and no steeper than cond itself where it grows
    without bound near a singularity) and ``stroke_low`` / ``stroke_high`` are
    ``(lo + pad - q) / (hi - lo)`` and ``(q - hi + pad) / (hi - lo)`` (pad: the margin times hi - lo) at every point and
    actuator; an unreachable point counts as violated by 1.  On the fd route
    the strokes are one value each (the Evaluator's, of the maximum over W)
    and the singularity :func:`smooth_singularity` of cond (the same
    feasible set; next to a reach boundary, where the optimum of an index
    often lies, it is linear in the distance to it where ``max_W cond /
    limit - 1`` grows without bound): with the worst case on, one row per
    hill of W the search climbed, largest first (the first the maximum over
    W), else one row of the samples' maximum."""

    route: str
    values: dict
    grads: dict
    constraints: dict
    constraint_grads: dict
    reach: np.ndarray
    fd_error: dict = field(default_factory=dict)
    reason: str = ""


# ---------------------------------------------------------------------- the CasADi route (its function: .casadi_fn)
def _close(a, b) -> bool:
    ok = np.isfinite(a) & np.isfinite(b)
    if not ok.any():
        return True
    scale = np.max(np.abs(b[ok])) or 1.0
    return bool(np.max(np.abs(a[ok] - b[ok])) <= CHECK_RTOL * scale)


def ad_available(evaluator: Evaluator) -> bool:
    """Whether the evaluator's mechanism has a CasADi model that reads every free variable."""
    builder = symbolic_model(evaluator.mechanism.name)
    return builder is not None and _ad_function(evaluator.mechanism.name, builder, tuple(evaluator.free)) is not None


def _ad_matrices(evaluator: Evaluator, mech, designs: dict, X: np.ndarray, values_only: bool = False):
    """(J, dJ, M, dM, Q, dQ) on the AD route, each (D, N, ...), or a reason
    string; ``values_only``: the mechanism's matrices and derivatives with no
    component (the route is not checked: a caller asks for values only at
    designs of a route it has checked)."""
    cls = evaluator.mechanism
    builder = symbolic_model(cls.name)
    if builder is None:
        return "no CasADi model"
    got = _ad_function(cls.name, builder, tuple(evaluator.free))
    if got is None:
        return "the CasADi model does not read every free design variable"
    fn, model = got
    D, N, nf = len(next(iter(designs.values()))), X.shape[0], len(evaluator.free)
    needs_M = any(r.kind == "dynamic" for r in evaluator.requests_all)
    if needs_M and model.kinetic_fn is None:
        return "the CasADi model has no kinetic energy"
    with np.errstate(all="ignore"):
        st = mech.state(X)        # one inverse kinematics for Q, J and M
        Q = np.broadcast_to(st.q, (D, N, model.n_act))
        Jm = np.broadcast_to(st.J, (D, N, model.n_act, model.dof))
    if not set(model.param_names) <= set(mech.params):
        return "the CasADi model reads parameters the mechanism does not have"
    if values_only:
        with np.errstate(all="ignore"):
            M = np.broadcast_to(st.matrices({"M"})["M"], Jm.shape) if needs_M else None
        none = np.zeros(Jm.shape + (0,))
        return Jm, none, M, None if M is None else none, Q, np.zeros(Q.shape + (0,))
    n = D * N
    outs = _mapped(fn, n)(*_arguments(X, Q, mech.params, model.param_names))
    J = _columns(outs[0], model.n_act, n, model.dof)
    dJ = _vec_columns(outs[1], model.n_act, model.dof, n, nf)
    dQ = _columns(outs[2], model.n_act, n, nf)
    reach = np.all(np.isfinite(Q.reshape(n, -1)), axis=-1)
    Jm_f = Jm.reshape(n, model.n_act, model.dof)
    if not _close(J[reach], Jm_f[reach]):
        # the mechanism's J may be the model's dq/dx times a pose map of its
        # own (3-SPS-S: J = (dl/dX) E(X)^-1 for the angular velocity)
        if not hasattr(mech, "jacobian_euler"):
            return "the CasADi Jacobian differs from the mechanism's"
        with np.errstate(all="ignore"):
            Je = np.broadcast_to(mech.jacobian_euler(X), (D, N, model.n_act, model.dof)).reshape(n, model.n_act, model.dof)
        if needs_M or not _close(J[reach], Je[reach]):
            return "the CasADi Jacobian differs from the mechanism's"
        Tm = np.full_like(J, np.nan)
        Tm[reach] = _solve(J[reach], Jm_f[reach])          # E^-1, a map of the pose alone
        dJ = np.einsum("nikp,nkj->nijp", dJ, Tm)
    M = dM = None
    if needs_M:
        with np.errstate(all="ignore"):
            Mm = np.broadcast_to(st.matrices({"M"})["M"], (D, N, model.n_act, model.dof)).reshape(n, model.n_act, model.dof)
        Mp = _columns(outs[3], model.dof, n, model.dof)
        dMp = _vec_columns(outs[4], model.dof, model.dof, n, nf)
        Jr = Jm_f[reach]
        if not _close(_solve(np.swapaxes(Jr, -1, -2), Mp[reach]), Mm[reach]):
            return "the CasADi mass matrix differs from the mechanism's"
        dM = np.full(dMp.shape, np.nan)
        rhs = dMp[reach] - np.einsum("nkip,nkj->nijp", dJ[reach], Mm[reach])
        dM[reach] = _solve(np.swapaxes(Jr, -1, -2)[:, None], rhs.transpose(0, 3, 1, 2)).transpose(0, 2, 3, 1)
        M = Mm
    shape = (D, N)
    rs = lambda a: None if a is None else a.reshape(shape + a.shape[1:])  # noqa: E731
    return Jm, rs(dJ), rs(M), rs(dM), Q, rs(dQ)


# ---------------------------------------------------------------------- assembly
def _mean(local, grad, reach, weights):
    """Global mean over the reachable points and its derivative: (D,), (D, n)."""
    w = np.where(reach, 1.0 if weights is None else np.asarray(weights, dtype=float), 0.0)
    tot = w.sum(axis=-1)
    with np.errstate(all="ignore"):
        v = np.sum(np.where(reach, local, 0.0) * w, axis=-1) / tot
        g = np.sum(np.where(reach[..., None], grad, 0.0) * w[..., None], axis=-2) / tot[:, None]
    return np.where(tot > 0, v, np.nan), np.where(tot[:, None] > 0, g, np.nan)


def _extra(evaluator: Evaluator, X: np.ndarray, values_only: bool = False):
    """Extra objectives (closed-form functions of the design) and their central differences."""
    if not evaluator.extra:
        return {}, {}
    D, n = X.shape
    if values_only:
        vals = evaluator.extra_values(evaluator.designs(X))
        return vals, {k: np.zeros((D, 0)) for k in vals}
    h = 1e-7 * (evaluator.xu - evaluator.xl)
    offs = np.concatenate([np.zeros((1, n)), np.diag(h), -np.diag(h)])
    vals = evaluator.extra_values(evaluator.designs((X[:, None, :] + offs[None]).reshape(-1, n)))
    out, grads = {}, {}
    for k, v in vals.items():
        v = v.reshape(D, 2 * n + 1)
        out[k], grads[k] = v[:, 0], (v[:, 1:n + 1] - v[:, n + 1:]) / (2 * h)
    return out, grads


def _hill_constraints(evaluator: Evaluator, designs: dict, hills: np.ndarray, limit: float, n: int, local,
                      mech=None):
    """The AD route's constraints ``log(cond / limit)`` (D, k) and their
    derivatives (D, k, n) at the local maximum of each hill of W the search
    climbed (``hills`` (D, k, dof)), largest first: where the largest moves
    from one hill to another the maximum over W has a kink, and the polish
    sees each hill before it becomes the largest.  An unreachable pose is a
    violation (1); a hill not climbed an inactive row (-10, no derivative).
    ``local(mechanism, design, poses)`` gives cond at the poses (K,), whether
    each is reachable (K,) and cond's derivative (K, n), or None when it
    cannot answer (then None).  ``mech``: the mechanism of ``designs``,
    taken for the design itself where there is one design (a polish step)."""
    D, k, _ = hills.shape
    c, g = np.full((D, k), -10.0), np.zeros((D, k, n))
    for i in range(D):
        on = np.flatnonzero(np.all(np.isfinite(hills[i]), axis=1))
        if not on.size:
            continue
        di = {key: v[i:i + 1] for key, v in designs.items()}
        mi = mech if D == 1 and mech is not None else \
            evaluator.mechanism(**{**evaluator.fixed, **{key: v[:, None] for key, v in di.items()}})
        got = local(mi, di, hills[i][on])
        if got is None:
            return None
        v, reach, gv = got
        good = reach & np.isfinite(v)
        with np.errstate(all="ignore"):
            c[i, on] = np.where(good, np.log(v / limit), 1.0)
            g[i, on] = np.where(good[:, None], gv / v[:, None], 0.0)
    order = np.argsort(-c, axis=1, kind="stable")
    return np.take_along_axis(c, order, axis=1), np.take_along_axis(g, order[..., None], axis=1)


def _numpy_local(evaluator: Evaluator, req, values_only: bool):
    """:func:`_hill_constraints`'s ``local`` from the numpy matrices (and CasADi's derivatives)."""
    def local(mi, di, poses):
        Ji, dJi, Mi, dMi, Qi, _ = _ad_matrices(evaluator, mi, di, poses, values_only)
        with np.errstate(all="ignore"):
            v, gv = local_derivative(req.kind, req.convention, req.option_dict(), Ji, dJi, Mi, dMi)
        return v[0], np.all(np.isfinite(Qi[0]), axis=-1), gv[0]
    return local


def _compiled_local(req):
    """:func:`_hill_constraints`'s ``local`` from the compiled path (values only: no derivative column)."""
    def local(mi, di, poses):
        with np.errstate(all="ignore"):
            at = mi.local_values_at([req], poses[None])
        if at is None:
            return None
        v = np.asarray(at[0][req.name], dtype=float)[0]
        return v, np.asarray(at[1], dtype=bool)[0], np.zeros((len(v), 0))
    return local


def _compiled_values(evaluator: Evaluator, X: np.ndarray):
    """The values-only answer of the AD route from the mechanism's compiled
    path (``Mechanism.local_values`` at W, ``local_values_at`` at the hills'
    poses): the same quantities as the numpy matrices give, equal to
    round-off, for SLSQP's line searches, which ask for values alone about four
    times per iteration.  (values, grads, constraints, constraint grads, the
    reachable fraction), or None where the compiled path does not answer every
    request or a constraint needs the actuators (stroke limits)."""
    builder = symbolic_model(evaluator.mechanism.name)
    ad = None if builder is None else _ad_function(evaluator.mechanism.name, builder, tuple(evaluator.free))
    needs_M = any(r.kind == "dynamic" for r in evaluator.requests_all)
    if ad is None or (needs_M and ad[1].kinetic_fn is None) or evaluator.stroke_limits is not None:
        return None                                   # not the AD route, or a constraint on the actuators
    designs = evaluator.designs(X)
    mech = evaluator.mechanism(**{**evaluator.fixed, **{k: v[:, None] for k, v in designs.items()}})
    if not set(ad[1].param_names) <= set(mech.params):
        return None
    with np.errstate(all="ignore"):
        got = mech.local_values(evaluator.requests_all, evaluator.workspace.X)
    if got is None:
        return None
    local, reach = {k: np.asarray(v, dtype=float) for k, v in got[0].items()}, np.asarray(got[1], dtype=bool)
    D, N = reach.shape
    weights = getattr(evaluator.workspace, "weights", None)
    values, grads = {}, {}
    for name in evaluator.index_names:
        values[name], grads[name] = _mean(local[name], np.zeros((D, N, 0)), reach, weights)
    name = evaluator._cond if evaluator._cond is not None else _COND
    ok = reach & np.isfinite(local[name])
    limit = getattr(evaluator, "limit", evaluator.threshold)
    with np.errstate(all="ignore"):
        cons = np.where(ok, np.log(local[name] / limit), 1.0)
    if getattr(evaluator, "worst_case", False):       # each hill's maximum, as _hill_constraints gives it
        req = next(r for r in evaluator.requests_all if r.name == name)
        hills = worstcase.worst_poses(evaluator.mechanism, evaluator.fixed, designs, evaluator.workspace, req,
                                      np.where(ok, local[name], np.inf), limit, hills=True)
        got = _hill_constraints(evaluator, designs, hills, limit, 0, _compiled_local(req), mech)
        if got is None:
            return None
        cons = np.concatenate([cons, got[0]], axis=1)
    return values, grads, {"singularity": cons}, {"singularity": np.zeros(cons.shape + (0,))}, reach.mean(axis=-1)


def _ad(evaluator: Evaluator, X: np.ndarray, values_only: bool = False):
    if values_only:
        got = _compiled_values(evaluator, X)
        if got is not None:
            values, grads, cons, cgrads, reach = got
            ev, eg = _extra(evaluator, X, True)
            return Derivatives("ad", {**values, **ev}, {**grads, **eg}, cons, cgrads, reach)
    designs = evaluator.designs(X)
    mech = evaluator.mechanism(**{**evaluator.fixed, **{k: v[:, None] for k, v in designs.items()}})
    got = _ad_matrices(evaluator, mech, designs, evaluator.workspace.X, values_only)
    if isinstance(got, str):
        return got
    J, dJ, M, dM, Q, dQ = got
    reach = np.all(np.isfinite(Q), axis=-1)
    weights = getattr(evaluator.workspace, "weights", None)
    values, grads, local, local_grads = {}, {}, {}, {}
    Js = np.where(reach[..., None, None], J, np.eye(*J.shape[-2:]))
    dJs = np.where(reach[..., None, None, None], dJ, 0.0)
    Ms = None if M is None else np.where(reach[..., None, None], M, np.eye(*M.shape[-2:]))
    dMs = None if dM is None else np.where(reach[..., None, None, None], dM, 0.0)
    with np.errstate(all="ignore"):
        for r in evaluator.requests_all:
            v, g = local_derivative(r.kind, r.convention, r.option_dict(), Js, dJs, Ms, dMs)
            local[r.name], local_grads[r.name] = v, g
            if r.name in evaluator.index_names:
                values[r.name], grads[r.name] = _mean(v, g, reach, weights)
    name = evaluator._cond if evaluator._cond is not None else _COND
    ok = reach & np.isfinite(local[name])
    limit = getattr(evaluator, "limit", evaluator.threshold)
    with np.errstate(all="ignore"):
        cons = {"singularity": np.where(ok, np.log(local[name] / limit), 1.0)}
        cgrads = {"singularity": np.where(ok[..., None], local_grads[name] / local[name][..., None], 0.0)}
    if getattr(evaluator, "worst_case", False):       # and at each design's worst pose of the continuous W
        req = next(r for r in evaluator.requests_all if r.name == name)
        hills = worstcase.worst_poses(evaluator.mechanism, evaluator.fixed, designs, evaluator.workspace, req,
                                      np.where(ok, local[name], np.inf), limit, hills=True)
        c, g = _hill_constraints(evaluator, designs, hills, limit, cgrads["singularity"].shape[-1],
                                 _numpy_local(evaluator, req, values_only), mech)
        cons["singularity"] = np.concatenate([cons["singularity"], c], axis=1)
        cgrads["singularity"] = np.concatenate([cgrads["singularity"], g], axis=1)
    if evaluator.stroke_limits is not None:
        lo, hi = evaluator.stroke_limits
        D, N, a = Q.shape
        okq = np.broadcast_to(reach[..., None], Q.shape)
        span = hi - lo
        pad = getattr(evaluator, "margin", 0.0) * span     # the Evaluator's limits, narrowed by its margin
        cons["stroke_low"] = np.where(okq, (lo + pad - Q) / span, 1.0).reshape(D, N * a)
        cons["stroke_high"] = np.where(okq, (Q - hi + pad) / span, 1.0).reshape(D, N * a)
        dq = np.where(okq[..., None], dQ, 0.0)
        cgrads["stroke_low"] = (-dq / span).reshape(D, N * a, -1)
        cgrads["stroke_high"] = (dq / span).reshape(D, N * a, -1)
    ev, eg = _extra(evaluator, X, values_only)
    values.update(ev)
    grads.update(eg)
    return Derivatives("ad", values, grads, cons, cgrads, reach.mean(axis=-1))


def derivatives(evaluator: Evaluator, X: np.ndarray, route: str = "auto", values_only: bool = False) -> Derivatives:
    """Global index values and derivatives and the smooth constraints at
    designs X (D, n_free): the AD route where the mechanism has one
    (``route="auto"`` or ``"ad"``), central differences otherwise or with
    ``route="fd"``.  ``values_only``: the same values without derivatives
    (grads with no column), on the route named (``auto`` counts as ``ad``).
    A request repeated while it is among the :data:`MEMO` last of this
    Evaluator gets the same answer object back: read it, do not change it."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    memo = _MEMOS.get(evaluator)
    if memo is None:
        memo = _MEMOS[evaluator] = OrderedDict()
    key = (X.shape, np.ascontiguousarray(X).tobytes(), route, bool(values_only), fast.enabled(),
           *(getattr(evaluator, k, None) for k in _SETTINGS))
    got = memo.get(key)
    if got is None:
        got = memo[key] = _derivatives(evaluator, X, route, values_only)
        if len(memo) > MEMO:
            memo.popitem(last=False)
    else:
        memo.move_to_end(key)
    return got


def _derivatives(evaluator: Evaluator, X: np.ndarray, route: str, values_only: bool) -> Derivatives:
    if route != "fd":
        got = _ad(evaluator, X, values_only)
        if not isinstance(got, str):
            return got
        if route == "ad":
            raise ValueError(f"no AD route for {evaluator.mechanism.name}: {got}")
        return Derivatives(**fd_derivatives(evaluator, X, got, values_only))
    return Derivatives(**fd_derivatives(evaluator, X, "asked for", values_only))
