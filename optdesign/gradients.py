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
  from its matrix in closed form (:func:`local_derivative`);
* ``fd`` -- central differences on the vectorized evaluation, the checked
  fallback where a mechanism has no AD route (described mechanisms, a free
  parameter the CasADi model does not read, a Jacobian convention it does not
  share): one evaluation of ``4 n + 1`` designs (steps h and 2h), the
  difference of the two estimates kept as an error estimate (``fd_error``).
  With the worst case over W on, the stencil is evaluated on the samples
  only: the constraints on maxima over W take their values from the search
  at the design itself and their derivatives from the differences of the
  local quantity at the pose of each maximum (the envelope theorem), so a
  derivative costs one search per design, not one per stencil design.

Global indices are the means over the reachable points (eq. 29, with the
workspace's quadrature weights where it has them), so their derivative is the
mean of the local derivatives at a design whose points are all reachable.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import worstcase
from .evaluate import _COND, Evaluator
from .local_derivatives import local_derivative, solve as _solve
from .mechanisms import symbolic_model

__all__ = ["Derivatives", "derivatives", "local_derivative", "ad_available"]

#: relative agreement the CasADi matrices must have with the mechanism's own
CHECK_RTOL = 1e-8
#: central-difference step, relative to the width of the design box
FD_STEP = 2e-6


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
    they are the Evaluator's own (one value each, the maximum over W)."""

    route: str
    values: dict
    grads: dict
    constraints: dict
    constraint_grads: dict
    reach: np.ndarray
    fd_error: dict = field(default_factory=dict)
    reason: str = ""


# ---------------------------------------------------------------------- index derivatives
# ---------------------------------------------------------------------- the CasADi route
_FUNCTIONS: dict = {}


def _ad_function(name: str, builder, free: tuple[str, ...]):
    """The CasADi function (x, q, p) -> J, dJ/dp, dq/dp[, M_p, dM_p/dp] of a
    mechanism for the free parameters ``free`` (cached per process), or None
    when the model does not read every free parameter."""
    key = (name, free)
    if key in _FUNCTIONS:
        return _FUNCTIONS[key]
    import casadi as ca

    model = builder()
    fn = None
    if set(free) <= set(model.param_names):
        x, q = ca.SX.sym("x", model.dof), ca.SX.sym("q", model.n_act)
        syms = {k: ca.SX.sym(k) for k in model.param_names}
        P = ca.vertcat(*[syms[k] for k in model.param_names])
        Pf = ca.vertcat(*[syms[k] for k in free])
        f = model.closure_fn(x, q, syms)
        fq = ca.jacobian(f, q)
        J = -ca.solve(fq, ca.jacobian(f, x))
        dq = -ca.solve(fq, ca.jacobian(f, Pf))

        def total(A):
            v = ca.vec(A)
            return ca.jacobian(v, Pf) + ca.mtimes(ca.jacobian(v, q), dq)

        outs = [J, total(J), dq]
        if model.kinetic_fn is not None:
            xd = ca.SX.sym("xd", model.dof)
            T = model.kinetic_fn(x, q, xd, ca.mtimes(J, xd), syms)
            Mp = ca.substitute(ca.jacobian(ca.gradient(T, xd), xd), xd, ca.DM.zeros(model.dof))
            outs += [Mp, total(Mp)]
        fn = (ca.Function(f"design_derivatives_{name}", [x, q, P], outs), model)
    _FUNCTIONS[key] = fn
    return fn


def _columns(out, rows: int, n: int, cols: int) -> np.ndarray:
    """A mapped CasADi output (rows, n * cols) -> (n, rows, cols)."""
    return np.asarray(out, dtype=float).reshape(rows, n, cols).transpose(1, 0, 2)


def _vec_columns(out, rows: int, cols: int, n: int, nf: int) -> np.ndarray:
    """A mapped derivative of vec(A) (A rows x cols): (rows * cols, n * nf) -> (n, rows, cols, nf)."""
    a = np.asarray(out, dtype=float).reshape(rows * cols, n, nf).transpose(1, 0, 2)
    return a.reshape(n, cols, rows, nf).transpose(0, 2, 1, 3)


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
    pv = np.stack([np.broadcast_to(np.asarray(mech.params[k], dtype=float).reshape(-1, 1), (D, N)).ravel()
                   for k in model.param_names])
    n = D * N
    Xc = np.broadcast_to(X, (D, N, X.shape[1])).reshape(n, -1)
    outs = fn.map(n)(Xc.T, np.nan_to_num(Q.reshape(n, -1)).T, pv)
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


def _ad(evaluator: Evaluator, X: np.ndarray, values_only: bool = False):
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
        poses = worstcase.worst_poses(evaluator.mechanism, evaluator.fixed, designs, evaluator.workspace, req,
                                      np.where(ok, local[name], np.inf))
        c, g = [], []
        for i in range(len(X)):
            di = {k: v[i:i + 1] for k, v in designs.items()}
            mi = evaluator.mechanism(**{**evaluator.fixed, **{k: v[:, None] for k, v in di.items()}})
            Ji, dJi, Mi, dMi, Qi, _ = _ad_matrices(evaluator, mi, di, poses[i][None], values_only)
            if not (np.all(np.isfinite(Qi)) and np.all(np.isfinite(Ji))):     # an unreachable worst pose: a violation
                c.append(1.0)
                g.append(np.zeros(cgrads["singularity"].shape[-1]))
                continue
            with np.errstate(all="ignore"):
                v, gv = local_derivative(req.kind, req.convention, req.option_dict(), Ji, dJi, Mi, dMi)
                good = bool(np.all(np.isfinite(Qi)) and np.isfinite(v).all())
                c.append(np.log(v[0, 0] / limit) if good else 1.0)
                g.append(gv[0, 0] / v[0, 0] if good else np.zeros(gv.shape[-1]))
        cons["singularity"] = np.concatenate([cons["singularity"], np.array(c)[:, None]], axis=1)
        cgrads["singularity"] = np.concatenate([cgrads["singularity"], np.array(g)[:, None, :]], axis=1)
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


def _fd(evaluator: Evaluator, X: np.ndarray, reason: str = "", values_only: bool = False):
    """Central differences with steps h and 2h in one call of the Evaluator
    (its compiled path where the mechanism has one)."""
    D, n = X.shape
    if values_only:
        res = evaluator(X)
        cons = {k: np.asarray(res["constraints"][k], dtype=float)[:, None]
                for k in ("singularity", "stroke_low", "stroke_high") if k in res["constraints"]}
        return Derivatives("fd", dict(res["values"]), {k: np.zeros((D, 0)) for k in res["values"]}, cons,
                           {k: np.zeros((D, 1, 0)) for k in cons}, np.asarray(res["reachable_fraction"]), {}, reason)
    h = FD_STEP * (evaluator.xu - evaluator.xl)
    E = np.diag(h)
    offs = np.concatenate([np.zeros((1, n)), E, -E, 2 * E, -2 * E])          # (4n + 1, n)
    stencil = (X[:, None, :] + offs[None]).reshape(-1, n)
    worst = bool(getattr(evaluator, "worst_case", False)) and hasattr(evaluator, "worst_poses")
    # with the worst case over W: the maxima at X from the search, their
    # derivatives at the poses found (the envelope theorem), the stencil
    # evaluated on the samples only (no search per stencil design)
    res = evaluator(stencil, worst_case=False) if worst else evaluator(stencil)

    def diff(a):
        """(value at X, derivative (h and 2h combined, Richardson), error estimate |g_h - g_2h| / 3)."""
        a = np.asarray(a, dtype=float).reshape(D, 4 * n + 1)
        g1 = (a[:, 1:n + 1] - a[:, n + 1:2 * n + 1]) / (2 * h)
        g2 = (a[:, 2 * n + 1:3 * n + 1] - a[:, 3 * n + 1:]) / (4 * h)
        return a[:, 0], (4 * g1 - g2) / 3, np.abs(g1 - g2) / 3

    values, grads, err, cons, cgrads = {}, {}, {}, {}, {}
    for k, v in res["values"].items():
        values[k], grads[k], err[k] = diff(v)
    for k in ("singularity", "stroke_low", "stroke_high"):
        if k in res["constraints"]:
            v, g, _ = diff(res["constraints"][k])
            cons[k], cgrads[k] = v[:, None], g[:, None, :]
    if worst:
        _envelope(evaluator, X, stencil, diff, cons, cgrads)
    reach = np.asarray(res["reachable_fraction"]).reshape(D, 4 * n + 1)[:, 0]
    return Derivatives("fd", values, grads, cons, cgrads, reach, err, reason)


def _envelope(evaluator: Evaluator, X: np.ndarray, stencil: np.ndarray, diff, cons: dict, cgrads: dict) -> None:
    """The worst-case constraints of :func:`_fd` at the designs X (D, n): their
    values from the Evaluator (the continuous search), their derivatives the
    central differences over the stencil of the local quantity at the pose of
    each maximum (for a design the search skips, infeasible on the samples
    already: the samples' maximum and its differences, as computed)."""
    base = evaluator(X)["constraints"]
    where = evaluator.worst_poses(X)
    if where is None:
        return
    D, n = X.shape
    S = stencil.shape[0] // D
    designs = evaluator.designs(stencil)
    req = next(r for r in evaluator.requests_all if r.name == (evaluator._cond or _COND))
    fs = worstcase.local_functions(evaluator.mechanism, evaluator.fixed, designs, req.kind, req.convention,
                                   stroke=evaluator.stroke_limits is not None)
    index = np.arange(D * S)
    lo, hi = evaluator.stroke_limits or (0.0, 0.0)
    pad = evaluator.margin * (hi - lo)
    rows = {"singularity": ("cond", lambda v: np.where(np.isfinite(v), v / evaluator.limit - 1.0, np.nan)),
            "stroke_high": ("q_max", lambda v: np.where(np.isfinite(v), v - (hi - pad), np.nan)),
            "stroke_low": ("q_min_neg", lambda v: np.where(np.isfinite(v), lo + pad + v, np.nan))}
    for k, (quantity, form) in rows.items():
        if k not in cons:
            continue
        P = where["q_min" if quantity == "q_min_neg" else quantity]
        known = np.all(np.isfinite(P), axis=1)
        if not known.any():
            continue
        poses = np.repeat(np.where(known[:, None], P, 0.0), S, axis=0)[None]       # (1, D S, dof)
        with np.errstate(all="ignore"):
            v = form(np.asarray(fs[quantity](index)(poses), float)[0])
            _, g, _ = diff(v)
        c = np.asarray(base[k], float)
        good = known & np.isfinite(c) & np.all(np.isfinite(g), axis=1)
        cons[k] = np.where(known[:, None], c[:, None], cons[k])
        cgrads[k] = np.where(good[:, None, None], g[:, None, :], np.where(known[:, None, None], 0.0, cgrads[k]))


def derivatives(evaluator: Evaluator, X: np.ndarray, route: str = "auto", values_only: bool = False) -> Derivatives:
    """Global index values and derivatives and the smooth constraints at
    designs X (D, n_free): the AD route where the mechanism has one
    (``route="auto"`` or ``"ad"``), central differences otherwise or with
    ``route="fd"``.  ``values_only``: the same values without derivatives
    (grads with no column), on the route named (``auto`` counts as ``ad``)."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    if route != "fd":
        got = _ad(evaluator, X, values_only)
        if not isinstance(got, str):
            return got
        if route == "ad":
            raise ValueError(f"no AD route for {evaluator.mechanism.name}: {got}")
        return _fd(evaluator, X, got, values_only)
    return _fd(evaluator, X, "asked for", values_only)
