"""The legs' closures and the bodies' mass coefficients of the engine, per
block of BLK points (structure of arrays, the point loop innermost): per leg
the closed-form inverse kinematics of its kind and branch, the rod ``d``,
``d.t`` and the twist row ``g_i = (d, r x d) / (d.t)``; J = G S (S: a
selection of twist components, or the Euler columns); and the rigid-body
matrix of the platform and the legs' shares that move with it.

The formulas of the numpy path (:mod:`optdesign.mechanisms.described.poses`,
``.legs``, ``.dynamics``), in the same order where the order decides the
reachable mask.
"""
from __future__ import annotations

import math

import numpy as np
from numba import uint64 as _u

from .digest import leaf
from .layout import (BA, BLK, BS, BW, CT_ROLL, FCEN, FCOM, FIP, FMP, FRE, FRO_, FRR, GAL, GDE, GG, GGA, GK, GR, LA,
                    LE1, LE2, LFROD, LI12, LIROD, LLA, LLR, LM1, LM2, LMACT, LMROD, LP, LR0, LS0, LSG, LU, VOK)

__all__ = ["legs", "pose_rows", "rigid"]


@leaf
def _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, rot):
    """r = R P and b = (o + centre) + r at point j of the frame block (R = I
    for a translation pose, whose frame block has no R rows)."""
    if rot:
        r0 = FRb[_u(FRR * BLK + j)] * P0 + FRb[_u((FRR + 1) * BLK + j)] * P1 + FRb[_u((FRR + 2) * BLK + j)] * P2
        r1 = FRb[_u((FRR + 3) * BLK + j)] * P0 + FRb[_u((FRR + 4) * BLK + j)] * P1 + FRb[_u((FRR + 5) * BLK + j)] * P2
        r2 = FRb[_u((FRR + 6) * BLK + j)] * P0 + FRb[_u((FRR + 7) * BLK + j)] * P1 + FRb[_u((FRR + 8) * BLK + j)] * P2
    else:
        r0 = P0
        r1 = P1
        r2 = P2
    b0 = (FRb[_u(FRO_ * BLK + j)] + o0) + r0
    b1 = (FRb[_u((FRO_ + 1) * BLK + j)] + o1) + r1
    b2 = (FRb[_u((FRO_ + 2) * BLK + j)] + o2) + r2
    return r0, r1, r2, b0, b1, b2


@leaf
def _twist_row(Li, j, r0, r1, r2, d0, d1, d2, den):
    """g_i = (d, r x d) / den."""
    iv = 1.0 / den
    Li[GG * BLK + j] = d0 * iv
    Li[(GG + 1) * BLK + j] = d1 * iv
    Li[(GG + 2) * BLK + j] = d2 * iv
    Li[(GG + 3) * BLK + j] = (r1 * d2 - r2 * d1) * iv
    Li[(GG + 4) * BLK + j] = (r2 * d0 - r0 * d2) * iv
    Li[(GG + 5) * BLK + j] = (r0 * d1 - r1 * d0) * iv


@leaf
def _rod_coefficients(Li, j, r0, r1, r2, t0, t1, t2, mr, ir, f, l2, ma):
    """The leg's bodies in M_p (rod of mass mr centred at a + f d, transverse
    inertia ir, actuator body ma): with bdot = Vb xi, qdot = J xi and K = t.bdot,
    the rod's centre moves with (1 - f) t J + f Vb and turns with
    d x (Vb - t J) / l^2; as d.(Vb - t J) = 0 and |d| = l,

        mr |(1-f) t J + f Vb|^2 + ir |Vb - t J|^2 / l^2 + ma J^2
          = alpha |Vb|^2 + gamma J^2 + delta 2 J K,

    alpha = mr f^2 + ir / l^2, gamma = mr (1-f)^2 |t|^2 + ir |t|^2 / l^2 + ma,
    delta = mr f (1-f) - ir / l^2.  Stores K's twist row (t, r x t)."""
    tt = t0 * t0 + t1 * t1 + t2 * t2
    il = ir / l2
    g = 1.0 - f
    Li[GAL * BLK + j] = mr * f * f + il
    Li[GGA * BLK + j] = (mr * g * g + il) * tt + ma
    Li[GDE * BLK + j] = mr * f * g - il
    Li[GK * BLK + j] = t0
    Li[(GK + 1) * BLK + j] = t1
    Li[(GK + 2) * BLK + j] = t2
    Li[(GK + 3) * BLK + j] = r1 * t2 - r2 * t1
    Li[(GK + 4) * BLK + j] = r2 * t0 - r0 * t2
    Li[(GK + 5) * BLK + j] = r0 * t1 - r1 * t0


@leaf
def _leg_prismatic(L, F, d, i, ptype, FRb, br, m, Li, V, dyn_, rot):
    """Slider at a = A + q u, rod of length l: q = u.w -+ sqrt((u.w)^2 - |w|^2 + l^2)."""
    A0 = L[d, i, LA]
    A1 = L[d, i, LA + 1]
    A2 = L[d, i, LA + 2]
    u0 = L[d, i, LU]
    u1 = L[d, i, LU + 1]
    u2 = L[d, i, LU + 2]
    Lr = L[d, i, LLR]
    mr = L[d, i, LMROD]
    ir = L[d, i, LIROD]
    f = L[d, i, LFROD]
    ma = L[d, i, LMACT]
    P0 = L[d, i, LP]
    P1 = L[d, i, LP + 1]
    P2 = L[d, i, LP + 2]
    o0 = F[d, FCEN] if ptype == 2 else 0.0
    o1 = F[d, FCEN + 1] if ptype == 2 else 0.0
    o2 = F[d, FCEN + 2] if ptype == 2 else 0.0
    for j in range(m):
        r0, r1, r2, b0, b1, b2 = _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, rot)
        Li[GR * BLK + j] = r0
        Li[(GR + 1) * BLK + j] = r1
        Li[(GR + 2) * BLK + j] = r2
        w0 = b0 - A0
        w1 = b1 - A1
        w2 = b2 - A2
        ww = w0 * w0 + w1 * w1 + w2 * w2
        uw = u0 * w0 + u1 * w1 + u2 * w2
        disc = Lr * Lr - ww + uw * uw
        closes = disc >= 0.0
        V[VOK * BLK + j] = V[VOK * BLK + j] if closes else 0.0
        root = math.sqrt(disc if closes else 0.0)
        qm = uw - root
        qp = uw + root
        am0 = A0 + qm * u0
        am1 = A1 + qm * u1
        am2 = A2 + qm * u2
        ap0 = A0 + qp * u0
        ap1 = A1 + qp * u1
        ap2 = A2 + qp * u2
        far = ap0 * ap0 + ap1 * ap1 + ap2 * ap2 > am0 * am0 + am1 * am1 + am2 * am2
        plus = (br == 1) | ((br == 2) & far) | ((br == 3) & (not far))
        q = qp if plus else qm
        den = -root if plus else root
        d0 = b0 - (A0 + q * u0)
        d1 = b1 - (A1 + q * u1)
        d2 = b2 - (A2 + q * u2)
        _twist_row(Li, j, r0, r1, r2, d0, d1, d2, den)
        if dyn_:
            _rod_coefficients(Li, j, r0, r1, r2, u0, u1, u2, mr, ir, f, Lr * Lr, ma)


@leaf
def _wrap(q):
    return q - 2.0 * math.pi * np.round(q / (2.0 * math.pi))


@leaf
def _leg_revolute(L, F, d, i, ptype, FRb, br, m, Li, V, dyn_, rot):
    """Crank of length L_a about k through A (tip A + L_a (cos q r0 + sin q s0)),
    rod of length l: q = atan2(Q, P) +- atan2(sqrt(P^2 + Q^2 - C^2), C)."""
    A0 = L[d, i, LA]
    A1 = L[d, i, LA + 1]
    A2 = L[d, i, LA + 2]
    La = L[d, i, LLA]
    Lr = L[d, i, LLR]
    R00 = L[d, i, LR0]
    R01 = L[d, i, LR0 + 1]
    R02 = L[d, i, LR0 + 2]
    S00 = L[d, i, LS0]
    S01 = L[d, i, LS0 + 1]
    S02 = L[d, i, LS0 + 2]
    mr = L[d, i, LMROD]
    ir = L[d, i, LIROD]
    f = L[d, i, LFROD]
    ma = L[d, i, LMACT]
    sg = L[d, i, LSG]          # the root settled per design (Constants.sign)
    P0 = L[d, i, LP]
    P1 = L[d, i, LP + 1]
    P2 = L[d, i, LP + 2]
    o0 = F[d, FCEN] if ptype == 2 else 0.0
    o1 = F[d, FCEN + 1] if ptype == 2 else 0.0
    o2 = F[d, FCEN + 2] if ptype == 2 else 0.0
    for j in range(m):
        r0, r1, r2, b0, b1, b2 = _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, rot)
        Li[GR * BLK + j] = r0
        Li[(GR + 1) * BLK + j] = r1
        Li[(GR + 2) * BLK + j] = r2
        w0 = b0 - A0
        w1 = b1 - A1
        w2 = b2 - A2
        ww = w0 * w0 + w1 * w1 + w2 * w2
        Pc = w0 * R00 + w1 * R01 + w2 * R02
        Qc = w0 * S00 + w1 * S01 + w2 * S02
        Cc = (ww + La * La - Lr * Lr) / (2.0 * La)
        h2 = Pc * Pc + Qc * Qc - Cc * Cc
        closes = (h2 >= 0.0) and (sg == sg)       # sg NaN: outer / inner not defined for this design
        V[VOK * BLK + j] = V[VOK * BLK + j] if closes else 0.0
        h = math.sqrt(h2 if closes else 0.0)
        phi0 = math.atan2(Qc, Pc)
        dl = math.atan2(h, Cc)
        qp = _wrap(phi0 + dl)
        qm = _wrap(phi0 - dl)
        cpp = math.cos(qp)
        spp = math.sin(qp)
        cmm = math.cos(qm)
        smm = math.sin(qm)
        plus = sg > 0.0
        cq = cpp if plus else cmm
        sq = spp if plus else smm
        c0 = cq * R00 + sq * S00
        c1 = cq * R01 + sq * S01
        c2 = cq * R02 + sq * S02
        den = -La * h if plus else La * h
        d0 = b0 - (A0 + La * c0)
        d1 = b1 - (A1 + La * c1)
        d2 = b2 - (A2 + La * c2)
        _twist_row(Li, j, r0, r1, r2, d0, d1, d2, den)
        if dyn_:
            t0 = La * (-sq * R00 + cq * S00)
            t1 = La * (-sq * R01 + cq * S01)
            t2 = La * (-sq * R02 + cq * S02)
            _rod_coefficients(Li, j, r0, r1, r2, t0, t1, t2, mr, ir, f, Lr * Lr, ma)


@leaf
def _leg_strut(L, F, d, i, ptype, FRb, m, Li, dyn_, rot):
    """Strut of actuated length q = |w|.  Bodies: the lower part (mass m1,
    centre e1 from A) and the upper part (m2, centre e2 from b), inertia I12
    between them, all turning with n x bdot / q; with p = (bdot - n (n.bdot)) / q
    (so |n x bdot|^2 / q^2 = |p|^2, bdot.p = q |p|^2) their energy is

        m1 e1^2 |p|^2 + m2 |bdot - e2 p|^2 + I12 |p|^2 = alpha |bdot|^2 + gamma (n.bdot)^2,

    c = m1 e1^2 + I12 + m2 (e2^2 - 2 e2 q), alpha = m2 + c / q^2, gamma = -c / q^2
    (n.bdot = J xi: the strut's row)."""
    A0 = L[d, i, LA]
    A1 = L[d, i, LA + 1]
    A2 = L[d, i, LA + 2]
    m1 = L[d, i, LM1]
    e1 = L[d, i, LE1]
    m2 = L[d, i, LM2]
    e2 = L[d, i, LE2]
    i12 = L[d, i, LI12]
    c_ = m1 * e1 * e1 + i12 + m2 * e2 * e2
    P0 = L[d, i, LP]
    P1 = L[d, i, LP + 1]
    P2 = L[d, i, LP + 2]
    o0 = F[d, FCEN] if ptype == 2 else 0.0
    o1 = F[d, FCEN + 1] if ptype == 2 else 0.0
    o2 = F[d, FCEN + 2] if ptype == 2 else 0.0
    for j in range(m):
        r0, r1, r2, b0, b1, b2 = _platform_point(FRb, j, P0, P1, P2, o0, o1, o2, rot)
        Li[GR * BLK + j] = r0
        Li[(GR + 1) * BLK + j] = r1
        Li[(GR + 2) * BLK + j] = r2
        w0 = b0 - A0
        w1 = b1 - A1
        w2 = b2 - A2
        q = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        iq = 1.0 / q
        Li[GG * BLK + j] = w0 * iq
        Li[(GG + 1) * BLK + j] = w1 * iq
        Li[(GG + 2) * BLK + j] = w2 * iq
        Li[(GG + 3) * BLK + j] = (r1 * w2 - r2 * w1) * iq
        Li[(GG + 4) * BLK + j] = (r2 * w0 - r0 * w2) * iq
        Li[(GG + 5) * BLK + j] = (r0 * w1 - r1 * w0) * iq
        if dyn_:
            c = c_ - 2.0 * m2 * e2 * q
            iq = c * (iq * iq)
            Li[GAL * BLK + j] = m2 + iq
            Li[GGA * BLK + j] = -iq
    if dyn_:
        # no rod: delta = 0 and K = 0 (read only where another leg has a rod)
        for k in range(7):
            for j in range(m):
                Li[(GDE if k == 6 else GK + k) * BLK + j] = 0.0


@leaf
def legs(L, F, d, ptype, kind, branch, FRb, m, Lg, V, dyn_, rot):
    """Every leg's closure, twist row and (dyn_) body coefficients at the block's points."""
    for i in range(kind.shape[0]):
        Li = Lg[i]
        k = kind[i]
        if k == 0:
            _leg_prismatic(L, F, d, i, ptype, FRb, branch[i], m, Li, V, dyn_, rot)
        elif k == 1:
            _leg_revolute(L, F, d, i, ptype, FRb, branch[i], m, Li, V, dyn_, rot)
        else:
            _leg_strut(L, F, d, i, ptype, FRb, m, Li, dyn_, rot)


@leaf
def pose_rows(Lg, src, ct, FRb, m, J, n):
    """J[i, c] = (twist row src of leg i) . (column c of S)."""
    for i in range(n):
        Li = Lg[i]
        for c in range(n):
            k = ct[c]
            o = (i * n + c) * BLK
            if k < 6:
                for j in range(m):
                    J[o + j] = Li[(src + k) * BLK + j]
            elif k == CT_ROLL:
                for j in range(m):
                    J[o + j] = ((Li[(src + 3) * BLK + j] * FRb[_u(FRE * BLK + j)]
                                 + Li[(src + 4) * BLK + j] * FRb[_u((FRE + 1) * BLK + j)])
                                + Li[(src + 5) * BLK + j] * FRb[_u((FRE + 2) * BLK + j)])
            else:
                for j in range(m):
                    J[o + j] = (Li[(src + 3) * BLK + j] * FRb[_u((FRE + 3) * BLK + j)]
                                + Li[(src + 4) * BLK + j] * FRb[_u((FRE + 4) * BLK + j)])


# ---------------------------------------------------------------------- mass matrix
@leaf
def rigid(ptype, F, d, FRb, m, Lg, B, n, rot):
    """The rigid-body matrix sum_b m_b [I, -[r_b]x; [r_b]x, |r_b|^2 I - r_b r_b^T]
    of the platform (mass at R c) and the legs' shares alpha_i at r_i, plus the
    platform's R I_p R^T (rot: the pose has angles), as its ten numbers: rows
    BA (the mass), BS..BS+2 (the first moment s: the block -[s]x), BW..BW+5
    (the angular block: 00, 11, 22, 01, 02, 12).  Translation: the mass only."""
    mp = F[d, FMP]
    if ptype == 0:
        for j in range(m):
            a = mp
            for i in range(n):
                a += Lg[i, GAL * BLK + j]
            B[BA * BLK + j] = a
        return
    k0 = F[d, FCOM]
    k1 = F[d, FCOM + 1]
    k2 = F[d, FCOM + 2]
    I00 = F[d, FIP]
    I01 = F[d, FIP + 1]
    I02 = F[d, FIP + 2]
    I11 = F[d, FIP + 4]
    I12 = F[d, FIP + 5]
    I22 = F[d, FIP + 8]
    for j in range(m):
        R00 = FRb[_u(FRR * BLK + j)]
        R01 = FRb[_u((FRR + 1) * BLK + j)]
        R02 = FRb[_u((FRR + 2) * BLK + j)]
        R10 = FRb[_u((FRR + 3) * BLK + j)]
        R11 = FRb[_u((FRR + 4) * BLK + j)]
        R12 = FRb[_u((FRR + 5) * BLK + j)]
        R20 = FRb[_u((FRR + 6) * BLK + j)]
        R21 = FRb[_u((FRR + 7) * BLK + j)]
        R22 = FRb[_u((FRR + 8) * BLK + j)]
        c0 = R00 * k0 + R01 * k1 + R02 * k2
        c1 = R10 * k0 + R11 * k1 + R12 * k2
        c2 = R20 * k0 + R21 * k1 + R22 * k2
        a = mp
        s0 = mp * c0
        s1 = mp * c1
        s2 = mp * c2
        q00 = mp * (c0 * c0)
        q11 = mp * (c1 * c1)
        q22 = mp * (c2 * c2)
        q01 = mp * (c0 * c1)
        q02 = mp * (c0 * c2)
        q12 = mp * (c1 * c2)
        for i in range(n):
            al = Lg[i, GAL * BLK + j]
            r0 = Lg[i, GR * BLK + j]
            r1 = Lg[i, (GR + 1) * BLK + j]
            r2 = Lg[i, (GR + 2) * BLK + j]
            a += al
            s0 += al * r0
            s1 += al * r1
            s2 += al * r2
            q00 += al * (r0 * r0)
            q11 += al * (r1 * r1)
            q22 += al * (r2 * r2)
            q01 += al * (r0 * r1)
            q02 += al * (r0 * r2)
            q12 += al * (r1 * r2)
        tr = q00 + q11 + q22
        w00 = tr - q00
        w11 = tr - q11
        w22 = tr - q22
        w01 = -q01
        w02 = -q02
        w12 = -q12
        if rot:
            # R I_p R^T
            x00 = R00 * I00 + R01 * I01 + R02 * I02
            x01 = R00 * I01 + R01 * I11 + R02 * I12
            x02 = R00 * I02 + R01 * I12 + R02 * I22
            x10 = R10 * I00 + R11 * I01 + R12 * I02
            x11 = R10 * I01 + R11 * I11 + R12 * I12
            x12 = R10 * I02 + R11 * I12 + R12 * I22
            x20 = R20 * I00 + R21 * I01 + R22 * I02
            x21 = R20 * I01 + R21 * I11 + R22 * I12
            x22 = R20 * I02 + R21 * I12 + R22 * I22
            w00 += x00 * R00 + x01 * R01 + x02 * R02
            w11 += x10 * R10 + x11 * R11 + x12 * R12
            w22 += x20 * R20 + x21 * R21 + x22 * R22
            w01 += x00 * R10 + x01 * R11 + x02 * R12
            w02 += x00 * R20 + x01 * R21 + x02 * R22
            w12 += x10 * R20 + x11 * R21 + x12 * R22
        B[BA * BLK + j] = a
        B[BS * BLK + j] = s0
        B[(BS + 1) * BLK + j] = s1
        B[(BS + 2) * BLK + j] = s2
        B[BW * BLK + j] = w00
        B[(BW + 1) * BLK + j] = w11
        B[(BW + 2) * BLK + j] = w22
        B[(BW + 3) * BLK + j] = w01
        B[(BW + 4) * BLK + j] = w02
        B[(BW + 5) * BLK + j] = w12
