"""The chain kernel's (:mod:`.chain_kernels`) quantities at a solution, scalar
code per point: a shorthand leg's twist row at the platform frame
(:func:`optdesign.mechanisms.described.legs.leg_state`) and the mass matrix in
the independent coordinates from the platform and every link with a mass
(:func:`optdesign.mechanisms.described.chain_dynamics.chain_dynamics`'s M)."""
from __future__ import annotations

import math

import numpy as np

from .chain_layout import (
    B_C,
    B_I,
    B_M,
    F_COM,
    F_IP,
    F_MP,
    G_VOFF,
    S_A,
    S_LA,
    S_LR,
    S_P,
    S_R0,
    S_S0,
    S_SIGN,
    S_U,
)
from .digest import leaf


@leaf
def _shorthand(kind, branch, SFi, o, R, G):
    """A shorthand leg's twist row G (6,) at the platform frame (o, R)
    (legs.leg_state); False where the leg does not close."""
    P0 = SFi[S_P]
    P1 = SFi[S_P + 1]
    P2 = SFi[S_P + 2]
    r0 = R[0, 0] * P0 + R[0, 1] * P1 + R[0, 2] * P2
    r1 = R[1, 0] * P0 + R[1, 1] * P1 + R[1, 2] * P2
    r2 = R[2, 0] * P0 + R[2, 1] * P1 + R[2, 2] * P2
    b0 = o[0] + r0
    b1 = o[1] + r1
    b2 = o[2] + r2
    A0 = SFi[S_A]
    A1 = SFi[S_A + 1]
    A2 = SFi[S_A + 2]
    w0 = b0 - A0
    w1 = b1 - A1
    w2 = b2 - A2
    ww = w0 * w0 + w1 * w1 + w2 * w2
    Lr = SFi[S_LR]
    if kind == 0:
        U0 = SFi[S_U]
        U1 = SFi[S_U + 1]
        U2 = SFi[S_U + 2]
        uw = U0 * w0 + U1 * w1 + U2 * w2
        disc = Lr ** 2 - ww + uw * uw
        if not disc >= 0.0:
            return False
        root = math.sqrt(disc)
        qm = uw - root
        qp = uw + root
        plus = branch == 1
        if branch >= 2:
            am = (A0 + qm * U0) ** 2 + (A1 + qm * U1) ** 2 + (A2 + qm * U2) ** 2
            ap = (A0 + qp * U0) ** 2 + (A1 + qp * U1) ** 2 + (A2 + qp * U2) ** 2
            far = ap > am
            plus = far if branch == 2 else not far
        q = qp if plus else qm
        den = -root if plus else root
        d0 = b0 - (A0 + q * U0)
        d1 = b1 - (A1 + q * U1)
        d2 = b2 - (A2 + q * U2)
    elif kind == 1:
        La = SFi[S_LA]
        sg = SFi[S_SIGN]
        Pc = w0 * SFi[S_R0] + w1 * SFi[S_R0 + 1] + w2 * SFi[S_R0 + 2]
        Qc = w0 * SFi[S_S0] + w1 * SFi[S_S0 + 1] + w2 * SFi[S_S0 + 2]
        Cc = (ww + La * La - Lr ** 2) / (2.0 * La)
        h2 = Pc * Pc + Qc * Qc - Cc * Cc
        if not h2 >= 0.0 or sg != sg:
            return False
        hh = math.sqrt(h2)
        phi0 = math.atan2(Qc, Pc)
        delta = math.atan2(hh, Cc)
        plus = sg > 0
        q = phi0 + delta if plus else phi0 - delta
        q = q - 2.0 * np.pi * np.round(q / (2.0 * np.pi))
        cq = math.cos(q)
        sq = math.sin(q)
        den = -La * hh if plus else La * hh
        d0 = b0 - (A0 + La * (cq * SFi[S_R0] + sq * SFi[S_S0]))
        d1 = b1 - (A1 + La * (cq * SFi[S_R0 + 1] + sq * SFi[S_S0 + 1]))
        d2 = b2 - (A2 + La * (cq * SFi[S_R0 + 2] + sq * SFi[S_S0 + 2]))
    else:
        den = math.sqrt(ww)
        d0 = w0
        d1 = w1
        d2 = w2
    G[0] = d0 / den
    G[1] = d1 / den
    G[2] = d2 / den
    G[3] = (r1 * d2 - r2 * d1) / den
    G[4] = (r2 * d0 - r0 * d2) / den
    G[5] = (r0 * d1 - r1 * d0) / den
    return True


@leaf
def _mass(Xi, Um, o, R, GFd, legs, bod, BFd, tw, Rl, pl, n, M, T6):
    """M_p (n, n) in the independent coordinates (chain_dynamics.chain_dynamics's
    M): the platform through Xi = S P (6, n) and every link with a mass through
    its twist sum_(j<=v) T_j du_j/dx (Um = du/dx, mapped)."""
    for a in range(n):
        for b in range(n):
            M[a, b] = 0.0
    nb = bod.shape[0]
    for bi in range(-1, nb):
        if bi < 0:          # the platform
            m = GFd[F_MP]
            c0 = GFd[F_COM]
            c1 = GFd[F_COM + 1]
            c2 = GFd[F_COM + 2]
            Ro = R
            p0 = o[0]
            p1 = o[1]
            p2 = o[2]
            Ib = GFd[F_IP:F_IP + 9]
            for c in range(n):
                for a in range(6):
                    T6[a, c] = Xi[a, c]
            # T6's rows 3..5 are the velocity of the origin: the point at o has v + w x 0
            cx = Ro[0, 0] * c0 + Ro[0, 1] * c1 + Ro[0, 2] * c2
            cy = Ro[1, 0] * c0 + Ro[1, 1] * c1 + Ro[1, 2] * c2
            cz = Ro[2, 0] * c0 + Ro[2, 1] * c1 + Ro[2, 2] * c2
            # Xi is (v_o, omega): reorder into (omega, v) at the centre below
            for c in range(n):
                v0 = T6[0, c]
                v1 = T6[1, c]
                v2 = T6[2, c]
                w0 = T6[3, c]
                w1 = T6[4, c]
                w2 = T6[5, c]
                T6[0, c] = w0
                T6[1, c] = w1
                T6[2, c] = w2
                T6[3, c] = v0 + (w1 * cz - w2 * cy)
                T6[4, c] = v1 + (w2 * cx - w0 * cz)
                T6[5, c] = v2 + (w0 * cy - w1 * cx)
        else:
            li = bod[bi, 0]
            v = bod[bi, 1]
            voff = legs[li, G_VOFF]
            m = BFd[bi, B_M]
            c0 = BFd[bi, B_C]
            c1 = BFd[bi, B_C + 1]
            c2 = BFd[bi, B_C + 2]
            Ro = Rl[voff + v]
            p0 = pl[voff + v, 0]
            p1 = pl[voff + v, 1]
            p2 = pl[voff + v, 2]
            Ib = BFd[bi, B_I:B_I + 9]
            cx = Ro[0, 0] * c0 + Ro[0, 1] * c1 + Ro[0, 2] * c2 + p0
            cy = Ro[1, 0] * c0 + Ro[1, 1] * c1 + Ro[1, 2] * c2 + p1
            cz = Ro[2, 0] * c0 + Ro[2, 1] * c1 + Ro[2, 2] * c2 + p2
            for c in range(n):
                for a in range(6):
                    s = tw[voff, a] * Um[voff, c]
                    for j in range(1, v + 1):
                        s += tw[voff + j, a] * Um[voff + j, c]
                    T6[a, c] = s
            # (omega; v at the base origin) -> the velocity of the centre v + omega x c
            for c in range(n):
                w0 = T6[0, c]
                w1 = T6[1, c]
                w2 = T6[2, c]
                T6[3, c] = T6[3, c] + (w1 * cz - w2 * cy)
                T6[4, c] = T6[4, c] + (w2 * cx - w0 * cz)
                T6[5, c] = T6[5, c] + (w0 * cy - w1 * cx)
        # I_w = Ro I Ro^T
        for a in range(n):
            for b in range(a, n):
                s = m * (T6[3, a] * T6[3, b] + T6[4, a] * T6[4, b] + T6[5, a] * T6[5, b])
                for x in range(3):
                    ix = 0.0
                    for y in range(3):
                        iw = 0.0
                        for k in range(3):
                            iw += Ro[x, k] * (Ib[k * 3] * Ro[y, 0] + Ib[k * 3 + 1] * Ro[y, 1] + Ib[k * 3 + 2] * Ro[y, 2])
                        ix += iw * T6[y, b]
                    s += T6[x, a] * ix
                M[a, b] += s
    for a in range(n):
        for b in range(a):
            M[a, b] = M[b, a]
