"""The closure equations of a chain description and their solution with a
defined branch: inverse kinematics (independent pose coordinates -> every
chain's joint values and the parasitic coordinates) and forward kinematics
(actuator values -> the whole pose), by vectorized Newton.

The unknowns of the inverse problem are ``u = (theta of chain 1, ...,
theta of chain m, x_par)``; the equations are every chain's closure
(:func:`.chain_poe.leg_rows`).  The forward problem's unknowns are the passive
joint values and the whole pose; its equations add the shorthand legs'
distances ``(|b - a(q)|^2 - l^2) / (2 L)``.  A system with more equations than
unknowns (an overconstrained mechanism, e.g. the 2-CPR/RRR) is solved in the
least-squares sense (Gauss-Newton; it is consistent at a solution).

**The branch.**  The home configuration of a design is the solution Newton
(damped) reaches at the home pose from the joints' ``home`` values and the
pose's ``home`` (parasitic coordinates included).  Every other pose is the
solution connected to it by continuation along the straight segment from the
home pose's independent coordinates (forward kinematics: the home actuator
values) to the target, in steps of a tangent predictor and a Newton
corrector; a step is refused when Newton does not converge, the correction is
larger than half the predicted step (a jump to another branch) or the
Jacobian's orientation flips (``det(Fu_prev^T Fu) <= 0``: a singularity was
crossed).  Each point starts with one step over the whole segment; a refused
step is retried from the last accepted point with a quarter of the length, an
accepted one doubles it; where the step falls below 1/256 of the segment the
answer is NaN (never another branch's numbers).
A result is a solution when ``max |F| <= TOL L`` (L the length scale).
"""
from __future__ import annotations

import numpy as np

from .chain_poe import chain_poe, leg_rows, lsq
from .poses import frames, rate_map, twist_columns

__all__ = ["TOL", "H_MIN", "full_rate_map", "flat_constants", "take", "ik_system", "fk_system", "newton",
           "continuation"]

#: a solution's residual, relative to the length scale
TOL = 1e-11
#: the residual Newton polishes a solution to, relative to the length scale
POLISH = 1e-14
#: the smallest step of the continuation (a share of the segment)
H_MIN = 1.0 / 256
_KEYS = ("axis", "point", "side", "offset", "home", "end", "P")
_BASE = ("A", "P", "U", "R0", "S0", "La", "Lr", "centre", "fixed")


def full_rate_map(spec, fr) -> np.ndarray:
    """S (..., 6, n) with xi = S xdot for every coordinate of the pose type."""
    S = rate_map(spec, fr)
    if S is not None:
        return S
    shape = fr.origin.shape[:-1]
    out = np.zeros(shape + (6, spec.dof))
    for j, c in enumerate(twist_columns(spec)):
        out[..., c, j] = 1.0
    return out


def _gather(a, S, didx):
    a = np.asarray(a, dtype=float)
    D = int(np.prod(S)) if S else 1
    a = np.broadcast_to(a, tuple(S) + a.shape[len(S):])
    return a.reshape((D,) + a.shape[len(S):])[didx]


def flat_constants(cc, didx) -> dict:
    """The constants of each point of a flat batch (design index didx (B,))."""
    S = cc.base.shape
    legs = []
    for leg in cc.legs:
        d = {k: _gather(getattr(leg, k), S, didx) for k in _KEYS}
        d.update(codes=leg.codes, closure=leg.closure, act=leg.act)
        legs.append(d)
    C = cc.base
    out = {"legs": legs, "length": _gather(cc.length, S, didx), "kind": C.kind, "groups": _groups(cc.legs, legs)}
    for k in _BASE:
        out["b_" + k] = _gather(getattr(C, k), S, didx)
    return out


def _groups(specs, legs) -> list:
    """The legs with the same joints (a pattern's) stacked on an axis after the
    batch's, so that one :func:`.chain_poe.chain_poe` call serves them all:
    per group its legs' indices, their unknowns' columns ``cols`` (G, k) in the
    inverse problem and ``pcols`` (G, k - 1) of the passive ones in the forward
    problem, their closure rows ``rows`` (G, m), and the arrays (B, G, ...)."""
    key = lambda leg: (leg.codes, leg.closure, leg.act)  # noqa: E731
    order, off, poff, roff = {}, [], [], []
    o = po = r = 0
    for i, leg in enumerate(specs):
        order.setdefault(key(leg), []).append(i)
        off.append(o)
        poff.append(po)
        roff.append(r)
        o, po, r = o + leg.k, po + leg.k - (leg.act is not None), r + leg.rows
    out = []
    for (codes, closure, act), idx in order.items():
        k, m = len(codes), specs[idx[0]].rows
        g = {"legs": idx, "codes": codes, "closure": closure, "act": act,
             "cols": np.array([[off[i] + j for j in range(k)] for i in idx], dtype=int).reshape(len(idx), k),
             "pcols": np.array([[poff[i] + j for j in range(k - (act is not None))] for i in idx],
                               dtype=int).reshape(len(idx), -1),
             "rows": np.array([[roff[i] + j for j in range(m)] for i in idx], dtype=int)}
        for name in _KEYS:
            g[name] = np.stack([legs[i][name] for i in idx], 1)
        out.append(g)
    return out


def _take_dict(d, idx):
    return {k: (v[idx] if isinstance(v, np.ndarray) and k not in _INDEX else v) for k, v in d.items()}


_INDEX = ("cols", "pcols", "rows")


def take(fc: dict, idx) -> dict:
    out = {"legs": [_take_dict(leg, idx) for leg in fc["legs"]], "groups": [_take_dict(g, idx) for g in fc["groups"]],
           "kind": fc["kind"]}
    for k, v in fc.items():
        if k not in ("legs", "kind", "groups"):
            out[k] = v[idx]
    return out


def _pose(spec, fc, X):
    fr = frames(spec, X, fc["b_centre"], fc["b_fixed"])
    return fr, full_rate_map(spec, fr)


def _sizes(fc):
    m = sum(g["rows"].size for g in fc["groups"])
    return m


def ik_system(desc, fc, u, p):
    """F (B, m), Fu (B, m, nu), Fp (B, m, n_ind) of the inverse problem."""
    spec = desc.pose
    ind, par = list(spec.independent_index), list(spec.parasitic_index)
    B, nu = u.shape
    X = np.zeros((B, spec.dof))
    X[:, ind] = p
    X[:, par] = u[:, nu - len(par):]
    fr, S = _pose(spec, fc, X)
    m = _sizes(fc)
    F, Fu, Fp = np.zeros((B, m)), np.zeros((B, m, nu)), np.zeros((B, m, len(ind)))
    L = fc["length"][:, None]
    pcols = np.arange(nu - len(par), nu)
    for g in fc["groups"]:
        ch = chain_poe(g, u[:, g["cols"]])
        f, Ft, Fx = leg_rows(g, ch, fr.R[:, None], fr.origin[:, None], L)     # (B, G, m_g, ...)
        R = g["rows"]
        F[:, R] = f
        Fu[:, R[:, :, None], g["cols"][:, None, :]] = Ft
        Fu[:, R[:, :, None], pcols[None, None, :]] = Fx @ S[:, None][..., par]
        Fp[:, R] = Fx @ S[:, None][..., ind]
    return F, Fu, Fp


def _targets(fc, i, q):
    """Shorthand leg i: actuated point a, da/dq, squared length and its q-derivative."""
    kind = int(fc["kind"][i])
    A = fc["b_A"][:, i]
    if kind == 0:
        U = fc["b_U"][:, i]
        return A + q[:, None] * U, U, fc["b_Lr"][:, i] ** 2, 0.0 * q
    if kind == 1:
        La = fc["b_La"][:, i][:, None]
        c, s = np.cos(q)[:, None], np.sin(q)[:, None]
        R0, S0 = fc["b_R0"][:, i], fc["b_S0"][:, i]
        return A + La * (c * R0 + s * S0), La * (-s * R0 + c * S0), fc["b_Lr"][:, i] ** 2, 0.0 * q
    return A, 0.0 * A, q * q, 2.0 * q


def fk_system(desc, fc, u, p):
    """F, Fu, Fp of the forward problem: u = (passive joint values, whole pose),
    p the actuator values in the description's order."""
    spec = desc.pose
    B, nu = u.shape
    n = spec.dof
    X = u[:, nu - n:]
    fr, S = _pose(spec, fc, X)
    col = {(src, i): j for j, (_, src, i) in enumerate(desc.actuators)}
    m = _sizes(fc)
    Fc, Fuc, Fpc = np.zeros((B, m)), np.zeros((B, m, nu)), np.zeros((B, m, p.shape[1]))
    L = fc["length"][:, None]
    xcols = np.arange(nu - n, nu)
    for g in fc["groups"]:
        a = g["act"]
        th = u[:, g["pcols"]]                                                  # (B, G, k - 1 or k)
        if a is not None:
            acols = np.array([col[("chain", i)] for i in g["legs"]])
            qa = p[:, acols] - g["offset"][:, :, a]
            th = np.concatenate([th[:, :, :a], qa[:, :, None], th[:, :, a:]], -1)
        ch = chain_poe(g, th)
        f, Ft, Fx = leg_rows(g, ch, fr.R[:, None], fr.origin[:, None], L)
        R = g["rows"]
        keep = [j for j in range(len(g["codes"])) if j != a]
        Fc[:, R] = f
        Fuc[:, R[:, :, None], g["pcols"][:, None, :]] = Ft[..., keep]
        Fuc[:, R[:, :, None], xcols[None, None, :]] = Fx @ S[:, None]
        if a is not None:
            Fpc[:, R, acols[:, None]] = Ft[..., a]
    Fs, Fus, Fps = [Fc], [Fuc], [Fpc]
    r = np.einsum("bjk,bik->bij", fr.R, fc["b_P"])
    L = fc["length"]
    for i in range(len(fc["kind"])):
        j = col[("leg", i)]
        a, t, L2, dL2 = _targets(fc, i, p[:, j])
        d = fr.origin + r[:, i] - a
        f = (np.sum(d * d, -1) - L2) / (2 * L)
        Fxi = np.concatenate([d, np.cross(r[:, i], d)], -1) / L[:, None]
        Fu = np.zeros((B, 1, nu))
        Fu[:, 0, nu - n:] = np.einsum("bk,bkj->bj", Fxi, S)
        Fp = np.zeros((B, 1, p.shape[1]))
        Fp[:, 0, j] = (-2.0 * np.sum(d * t, -1) - dL2) / (2 * L)
        Fs.append(f[:, None])
        Fus.append(Fu)
        Fps.append(Fp)
    return np.concatenate(Fs, 1), np.concatenate(Fus, 1), np.concatenate(Fps, 1)


def _pinv_step(A, b):
    """The minimum-norm least-squares step (pseudo-inverse, relative cutoff 1e-10)."""
    good = np.all(np.isfinite(A), axis=(-1, -2)) & np.all(np.isfinite(b), axis=-1)
    P = np.linalg.pinv(np.where(good[:, None, None], A, 0.0), rcond=1e-10)
    return np.where(good[:, None], np.einsum("bij,bj->bi", P, np.where(good[:, None], b, 0.0)), np.nan)


def newton(fun, u, p, length, iters: int = 8, tol: float = TOL, damped: bool = False, target: float = POLISH):
    """Newton (Gauss-Newton) on fun(u, p) from u (B, nu): (u, converged (B,),
    (F, Fu, Fp) at u); it iterates while ``max |F| > target L`` and a point has
    converged when ``max |F| <= tol L``; ``damped``: halve a step while the
    residual grows, with pseudo-inverse steps (the home configuration: the
    load checks then say what is singular)."""
    u = np.array(u, dtype=float)
    with np.errstate(all="ignore"):
        sys = fun(u, p)
        res = np.max(np.abs(sys[0]), axis=-1)
        for _ in range(iters):
            conv = res <= np.minimum(tol, target) * length
            if np.all(conv | ~np.isfinite(res)):
                break
            du = np.where(conv[:, None], 0.0, _pinv_step(sys[1], sys[0]) if damped else lsq(sys[1], sys[0]))
            step = np.ones(len(u))
            un = u - du
            sn = fun(un, p)
            rn = np.max(np.abs(sn[0]), axis=-1)
            for _h in range(12 if damped else 0):
                worse = ~(rn <= res) & ~conv & np.all(np.isfinite(du), axis=-1)
                if not np.any(worse):
                    break
                step = np.where(worse, 0.5 * step, step)
                ut = u - step[:, None] * du
                st = fun(ut, p)
                rt = np.max(np.abs(st[0]), axis=-1)
                un = np.where(worse[:, None], ut, un)
                sn = tuple(np.where(worse.reshape((-1,) + (1,) * (x.ndim - 1)), y, x) for x, y in zip(sn, st))
                rn = np.where(worse, rt, rn)
            u, sys, res = un, sn, rn
        conv = res <= tol * length
    return u, conv, sys


def _norm(v, w):
    return np.sqrt(np.sum((v * w) ** 2, axis=-1))


def continuation(fun, fc, u0, p0, p1, weights):
    """Solutions (B, nu) connected to (u0, p0) along the segment p0 -> p1 and the
    mask of the solved points (NaN elsewhere); ``fun(fc, u, p)`` is the system,
    ``weights`` (B, nu) scale the unknowns to lengths (L for angles, 1 for
    lengths) in the jump test.

    Each point walks from t = 0 to 1 with its own step h (first 1): a tangent
    predictor and Newton; an accepted step doubles h (at most to the rest of
    the segment), a refused one divides it by 4 and is retried from the last
    accepted point; a point whose h falls below ``H_MIN`` is refused."""
    B = len(u0)
    u = np.array(u0, dtype=float)
    L = fc["length"]
    t, h = np.zeros(B), np.ones(B)
    active = np.all(np.isfinite(u0), axis=-1) & np.all(np.isfinite(p1), axis=-1)
    ok = np.zeros(B, dtype=bool)
    with np.errstate(all="ignore"):
        _, Fu, Fp = fun(fc, u, p0)
        while np.any(active):
            i = np.flatnonzero(active)
            sub = take(fc, i)
            tn = np.minimum(t[i] + h[i], 1.0)
            last = tn >= 1.0
            d = p1[i] - p0[i]
            p = np.where(last[:, None], p1[i], p0[i] + tn[:, None] * d)
            du = -lsq(Fu[i], np.einsum("bij,bj->bi", Fp[i], (tn - t[i])[:, None] * d))
            pred = u[i] + du
            tol = np.where(last, TOL, 1e-8)
            un, conv, (_, Fun, Fpn) = newton(lambda x, q: fun(sub, x, q), pred, p, L[i], tol=tol,
                                             target=np.where(last, POLISH, 1e-8))
            jump = _norm(un - pred, weights[i]) > 0.5 * _norm(du, weights[i]) + 1e-9 * L[i]
            G = np.swapaxes(Fu[i], -1, -2) @ Fun
            G = np.where(np.all(np.isfinite(G), axis=(-1, -2))[:, None, None], G, 0.0)
            flip = ~(np.linalg.det(G) > 0)
            acc = conv & ~jump & ~flip & np.all(np.isfinite(un), axis=-1)
            ia = i[acc]
            u[ia], Fu[ia], Fp[ia], t[ia] = un[acc], Fun[acc], Fpn[acc], tn[acc]
            h[ia] = np.minimum(2.0 * h[ia], 1.0)
            ok[i[acc & last]] = True
            active[i[acc & last]] = False
            ir = i[~acc]
            h[ir] = 0.25 * h[ir]
            active[ir[h[ir] < H_MIN]] = False
    return np.where(ok[:, None], u, np.nan), ok
