"""The dynamic index's product W = U^T M_p (or M_p itself) from the rigid-body
rows B, the legs' coefficients and the Jacobian rows, for any size n and any
pose-column kinds (read at run time).

Blocks of BLK points in structure-of-arrays form, as :mod:`.inverse` (the
same operations, in the same order, as the fixed-size code of
:mod:`.codegen`: tests/test_engine.py).  ``S``: scratch rows (layout.SROWS).
"""
from __future__ import annotations

import numpy as np
from numba import uint64 as _u

from .digest import keyed, leaf
from .layout import BA, BLK, BS, BW, CT_ROLL, FRE, GDE, GGA

__all__ = ["dyn"]

@leaf
def _b_row(k, l):
    """Entry (k, l), k <= l, of the rigid-body matrix from the rows of B
    (:func:`.kernels._rigid`): (row, sign), row -1 for a zero entry."""
    if l < 3:
        return (BA, 1.0) if k == l else (-1, 0.0)
    if k < 3:
        # -[s]x = [[0, s2, -s1], [-s2, 0, s0], [s1, -s0, 0]]
        c = l - 3
        if k == c:
            return -1, 0.0
        if k == 0:
            return (BS + 2, 1.0) if c == 1 else (BS + 1, -1.0)
        if k == 1:
            return (BS + 2, -1.0) if c == 0 else (BS, 1.0)
        return (BS + 1, 1.0) if c == 0 else (BS, -1.0)
    if k == l:
        return BW + k - 3, 1.0
    if k == 3:
        return (BW + 3, 1.0) if l == 4 else (BW + 4, 1.0)
    return BW + 5, 1.0


@leaf
def _b_entry(B, k, l, j, row, sign):
    return 0.0 if row < 0 else (B[_u(row * BLK + j)] if sign > 0.0 else -B[_u(row * BLK + j)])


@leaf
def _euler(kind, k):
    """The component k of an Euler column (CT_ROLL: e0, e1, e2 on 3, 4, 5;
    CT_PITCH: e3, e4 on 3, 4): the row of the frame data's FRE rows, -1 if none."""
    if kind == CT_ROLL:
        return k - 3 if k >= 3 else -1
    return k if (k == 3 or k == 4) else -1


@leaf
def _dyn_small(Lg, J, Kp, U, W, S, n, rods, m, om, oq, ov):
    """W = U^T M_p for n <= 3 (U = J^-1, exact to a few ulps) with the legs'
    terms taken through J U = I instead of through M_p: U^T J_i^T = e_i, so

        W = U^T T + diag(gamma) J + diag(delta) K + (U^T K^T) diag(delta) J

    (T = S^T B S at rows om, D = diag(delta) J at rows oq; U^T K^T into rows
    ov).  The terms gamma J^T J of M_p grow like |J|^2 near a singular pose and
    cancel in U^T M_p; here they never form (the 3-P(4S) kernel's form)."""
    if rods:
        for i in range(n):
            for k in range(n):
                o = ov + (i * n + k) * BLK
                for l in range(n):
                    ou = (l * n + i) * BLK
                    ok = (k * n + l) * BLK
                    if l == 0:
                        for j in range(m):
                            S[_u(o + j)] = U[_u(ou + j)] * Kp[_u(ok + j)]
                    else:
                        for j in range(m):
                            S[_u(o + j)] += U[_u(ou + j)] * Kp[_u(ok + j)]
    for i in range(n):
        oga = GGA * BLK
        ode = GDE * BLK
        for b in range(n):
            ow = (i * n + b) * BLK
            oj = (i * n + b) * BLK
            for j in range(m):
                t = U[_u(i * BLK + j)] * S[_u(om + b * BLK + j)]
                for k in range(1, n):
                    t = t + U[_u((k * n + i) * BLK + j)] * S[_u(om + (min(k, b) * n + max(k, b)) * BLK + j)]
                t = t + Lg[i, _u(oga + j)] * J[_u(oj + j)]
                if rods:
                    t = t + Lg[i, _u(ode + j)] * Kp[_u(oj + j)]
                    v = S[_u(ov + (i * n) * BLK + j)] * S[_u(oq + b * BLK + j)]
                    for k in range(1, n):
                        v = v + S[_u(ov + (i * n + k) * BLK + j)] * S[_u(oq + (k * n + b) * BLK + j)]
                    t = t + v
                W[_u(ow + j)] = t


@keyed
def dyn(B, Lg, J, Kp, FRb, U, W, S, n, ct, rods, m, mass_only, sel):
    """W = U^T M_p (U from :func:`inverse`; upper triangular for n >= 4), or
    M_p itself (mass_only), without M_p stored: M_p = S^T B S + sum_i [gamma_i
    J_i^T J_i + delta_i (J_i^T K_i + K_i^T J_i)] as s_a.(B s_b) + sum_i (J_ia
    P_ib + K_ia D_ib), P_ib = gamma_i J_ib + delta_i K_ib, D_ib = delta_i J_ib,
    the pose columns s of the kinds ct (a twist component or an Euler column,
    whose entries are in the frame data's FRE rows); for n <= 3 the legs'
    terms of W without M_p (:func:`_dyn_small`).  S rows: (B s_b)_k at (b 6 +
    k), then M_p (n n), then P, D, U^T K^T (n n each).  sel: the kernel's
    selector, not read; this function is the overload of ``kernels.dyn_sel``
    for the generic tier."""
    comp = np.zeros(6, dtype=np.bool_)
    for c in range(n):
        kc = ct[c]
        if kc < 6:
            comp[kc] = True
        else:
            for k in range(3, 6 if kc == CT_ROLL else 5):
                comp[k] = True
    # T_b[k] = (B s_b)_k for the components k the columns meet
    for b in range(n):
        kb = ct[b]
        for k in range(6):
            if not comp[k]:
                continue
            o = (b * 6 + k) * BLK
            if kb < 6:
                row, sign = _b_row(min(k, kb), max(k, kb))
                for j in range(m):
                    S[_u(o + j)] = _b_entry(B, 0, 0, j, row, sign)
            else:
                first = True
                for l in range(3, 6):
                    e = _euler(kb, l)
                    if e < 0:
                        continue
                    row, sign = _b_row(min(k, l), max(k, l))
                    if first:
                        for j in range(m):
                            S[_u(o + j)] = FRb[_u((FRE + e) * BLK + j)] * _b_entry(B, 0, 0, j, row, sign)
                    else:
                        for j in range(m):
                            S[_u(o + j)] += FRb[_u((FRE + e) * BLK + j)] * _b_entry(B, 0, 0, j, row, sign)
                    first = False
    om = n * 6 * BLK
    op = om + n * n * BLK
    oq = op + n * n * BLK
    ov = oq + n * n * BLK
    small = n <= 3 and not mass_only
    for i in range(n):
        oga = (GGA * BLK)
        ode = (GDE * BLK)
        for b in range(n):
            o = (i * n + b) * BLK
            if rods:
                for j in range(m):
                    jb = J[_u(o + j)]
                    de = Lg[i, _u(ode + j)]
                    S[_u(op + o + j)] = Lg[i, _u(oga + j)] * jb + de * Kp[_u(o + j)]
                    S[_u(oq + o + j)] = de * jb
            else:
                for j in range(m):
                    S[_u(op + o + j)] = Lg[i, _u(oga + j)] * J[_u(o + j)]
    for a in range(n):
        ka = ct[a]
        for b in range(a, n):
            o = om + (a * n + b) * BLK
            # s_a . (B s_b)
            if ka < 6:
                ot = (b * 6 + ka) * BLK
                for j in range(m):
                    S[_u(o + j)] = S[_u(ot + j)]
            else:
                first = True
                for l in range(3, 6):
                    e = _euler(ka, l)
                    if e < 0:
                        continue
                    ot = (b * 6 + l) * BLK
                    if first:
                        for j in range(m):
                            S[_u(o + j)] = FRb[_u((FRE + e) * BLK + j)] * S[_u(ot + j)]
                    else:
                        for j in range(m):
                            S[_u(o + j)] += FRb[_u((FRE + e) * BLK + j)] * S[_u(ot + j)]
                    first = False
            if small:       # the legs enter W directly (below), not through M_p
                continue
            # + the legs' sum
            oja = a * BLK
            ojb = b * BLK
            if rods:
                for j in range(m):
                    t = J[_u(oja + j)] * S[_u(op + ojb + j)] + Kp[_u(oja + j)] * S[_u(oq + ojb + j)]
                    for i in range(1, n):
                        r = i * n * BLK
                        t = t + J[_u(r + oja + j)] * S[_u(op + r + ojb + j)]
                        t = t + Kp[_u(r + oja + j)] * S[_u(oq + r + ojb + j)]
                    S[_u(o + j)] = S[_u(o + j)] + t
            else:
                for j in range(m):
                    t = J[_u(oja + j)] * S[_u(op + ojb + j)]
                    for i in range(1, n):
                        r = i * n * BLK
                        t = t + J[_u(r + oja + j)] * S[_u(op + r + ojb + j)]
                    S[_u(o + j)] = S[_u(o + j)] + t
    if mass_only:
        for a in range(n):
            for b in range(n):
                o = om + (min(a, b) * n + max(a, b)) * BLK
                ow = (a * n + b) * BLK
                for j in range(m):
                    W[_u(ow + j)] = S[_u(o + j)]
        return
    if small:
        _dyn_small(Lg, J, Kp, U, W, S, n, rods, m, om, oq, ov)
        return
    upper = n >= 4
    for i in range(n):
        for b in range(n):
            ow = (i * n + b) * BLK
            kmax = i + 1 if upper else n
            for k in range(kmax):
                ou = (k * n + i) * BLK
                o = om + (min(k, b) * n + max(k, b)) * BLK
                if k == 0:
                    for j in range(m):
                        W[_u(ow + j)] = U[_u(ou + j)] * S[_u(o + j)]
                else:
                    for j in range(m):
                        W[_u(ow + j)] += U[_u(ou + j)] * S[_u(o + j)]
