"""Leg kinds: the closure of each leg, its closed-form inverse kinematics and
its row of the Jacobian.

Every leg joins a point ``a(q)`` moved by its actuated joint to the platform
point ``b(x) = o(x) + R(x) P`` (``P`` in the platform frame); with ``w = b - A``:

* ``prismatic``: ``a = A + q u`` (|u| = 1) and a rod of length ``l``:
  ``f = |w - q u|^2 - l^2 = 0``, so ``q = u.w -+ sqrt((u.w)^2 - |w|^2 + l^2)``
  (``minus``: the smaller stroke, the 3-P(4S) paper's; ``plus``; or ``outer``
  / ``inner``: the root whose slider lies farther from / nearer to the base
  origin);
* ``revolute``: a crank of length ``L_a`` about the unit axis ``k`` through
  ``A``, ``a = A + L_a (cos q r + sin q s)`` with ``r`` the crank direction at
  q = 0 (perpendicular to k) and ``s = k x r``, and a rod of length ``l``:
  ``f = |w|^2 - 2 L_a (cos q w.r + sin q w.s) + L_a^2 - l^2 = 0``, i.e.
  ``P cos q + Q sin q = C`` with ``P = w.r``, ``Q = w.s``,
  ``C = (|w|^2 + L_a^2 - l^2) / (2 L_a)``:
  ``q = atan2(Q, P) +- atan2(sqrt(P^2 + Q^2 - C^2), C)`` (``plus``; ``minus``;
  ``outer``: the root whose crank tip lies farther from the base origin at the
  home pose, the Delta robot's elbow-out, kept over the whole workspace;
  ``inner``), in (-pi, pi].  ``outer`` / ``inner`` are settled once per design
  by the sign of ``sigma = k.(w x A)`` at home (the farther tip is the ``+``
  root where sigma > 0), so the solution is continuous over W and never left
  to round-off; a design where sigma is 0 at home (motor axes through the
  base origin, e.g. radial axes of a 6-RUS) has no outer root and is refused
  (:mod:`.checks`), or reaches nothing in an evaluation;
* ``strut``: the actuated length itself, ``f = |w|^2 - q^2 = 0``, ``q = |w|``.

A pose is reachable when every leg closes; otherwise every actuator value of
that pose is NaN.

The Jacobian row: with ``d = b - a`` (the rod; ``w`` for a strut) and the
actuated point's velocity ``t qdot`` (``t = u``; ``t = L_a (-sin q r + cos q s)``;
for a strut ``d.t`` is replaced by ``q``), ``df/dq = -2 d.t`` and
``df/dxi = 2 (d, r x d)`` for the platform twist xi = (v, omega) (because
``bdot = v + omega x r``, ``r = R P``), so

    qdot = G xi,  G = (d, r x d) / (d.t)  =  -(df/dq)^-1 df/dxi,

and in pose coordinates ``J = G S(x)`` (optdesign.mechanisms.described.poses).
``d.t`` is taken from the closed form (``+-sqrt(disc)``, ``-+L_a sqrt(P^2 + Q^2 - C^2)``),
which is exact where the leg is singular (d.t = 0).
"""
from __future__ import annotations

import numpy as np

from .constants import Constants
from .poses import Frames, frames

__all__ = ["leg_state"]


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def _wrap(q):
    return q - 2.0 * np.pi * np.round(q / (2.0 * np.pi))


def leg_state(C: Constants, spec, X: np.ndarray, fr: Frames | None = None) -> dict:
    """Inverse kinematics and per-leg geometry at poses X (..., N, dof).

    Returns ``q`` (..., N, n) (NaN where the pose is not reachable),
    ``reachable`` (..., N), and per leg (..., N, n, 3): ``r`` = R P, ``b``,
    ``a`` (actuated point), ``d`` (rod vector; w for struts), ``t``
    (d a / d q; the unit leg vector for struts), ``chat`` (unit crank
    direction, revolute), and ``den`` (..., N, n) = d.t (q for struts), ``G``
    (..., N, n, 6) the twist Jacobian rows, ``frames``."""
    X = np.asarray(X, dtype=float)
    if fr is None:
        fr = frames(spec, X, C.centre, C.fixed)
    r = np.einsum("...jk,...ik->...ij", fr.R, C.P)
    b = fr.origin[..., None, :] + r
    w = b - C.A
    shape = w.shape[:-1]
    kind = C.kind
    br = C.branch
    ww = _dot(w, w)
    q = np.zeros(shape)
    den = np.zeros(shape)
    a = np.zeros(w.shape)
    t = np.zeros(w.shape)
    chat = np.zeros(w.shape)
    with np.errstate(all="ignore"):
        if np.any(kind == 0):
            U = C.U
            uw = _dot(U, w)
            disc = C.Lr ** 2 - ww + uw * uw
            root = np.sqrt(np.where(disc >= 0.0, disc, np.nan))
            qm = uw - root
            qp = uw + root
            plus = br == 1
            if np.any(br >= 2):
                am = C.A + qm[..., None] * U
                ap = C.A + qp[..., None] * U
                far = _dot(ap, ap) > _dot(am, am)
                plus = np.where(br == 2, far, np.where(br == 3, ~far, plus))
            qq = np.where(plus, qp, qm)
            sel = kind == 0
            q = np.where(sel, qq, q)
            den = np.where(sel, np.where(plus, -root, root), den)
            aa = C.A + qq[..., None] * U
            a = np.where(sel[:, None], aa, a)
            t = np.where(sel[:, None], np.broadcast_to(U, w.shape), t)
        if np.any(kind == 1):
            La = C.La
            Pc = _dot(w, C.R0)
            Qc = _dot(w, C.S0)
            Cc = (ww + La * La - C.Lr ** 2) / (2.0 * La)
            h2 = Pc * Pc + Qc * Qc - Cc * Cc
            h = np.sqrt(np.where(h2 >= 0.0, h2, np.nan))
            phi0 = np.arctan2(Qc, Pc)
            delta = np.arctan2(h, Cc)
            qp = _wrap(phi0 + delta)
            qm = _wrap(phi0 - delta)
            cp_, sp_ = np.cos(qp), np.sin(qp)
            cm_, sm_ = np.cos(qm), np.sin(qm)
            # the root settled per design (Constants.sign: outer / inner at the home pose)
            sg = C.sign
            plus = sg > 0
            qq = np.where(plus, qp, qm)
            qq = np.where(np.isnan(sg), np.nan, qq)      # outer / inner not defined: no pose reached
            cq = np.where(plus, cp_, cm_)
            sq = np.where(plus, sp_, sm_)
            ch = cq[..., None] * C.R0 + sq[..., None] * C.S0
            sel = kind == 1
            q = np.where(sel, qq, q)
            den = np.where(sel, np.where(plus, -La * h, La * h), den)
            a = np.where(sel[:, None], C.A + La[..., None] * ch, a)
            t = np.where(sel[:, None], La[..., None] * (-sq[..., None] * C.R0 + cq[..., None] * C.S0), t)
            chat = np.where(sel[:, None], ch, chat)
        if np.any(kind == 2):
            ls = np.sqrt(ww)
            sel = kind == 2
            q = np.where(sel, ls, q)
            den = np.where(sel, ls, den)
            a = np.where(sel[:, None], np.broadcast_to(C.A, w.shape), a)
            t = np.where(sel[:, None], w / ls[..., None], t)
        d = np.where((kind == 2)[:, None], w, b - a)
        ok = np.all(np.isfinite(q), axis=-1)
        q = np.where(ok[..., None], q, np.nan)
        G = np.concatenate([d, np.cross(r, d)], axis=-1) / den[..., None]
        G = np.where(ok[..., None, None], G, np.nan)
    return {"q": q, "reachable": ok, "r": r, "b": b, "w": w, "a": a, "d": d, "t": t, "chat": chat, "den": den,
            "G": G, "frames": fr}
