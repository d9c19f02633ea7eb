"""Numba kernels of described mechanisms: one generic kernel for every leg
kind and pose type, driven by per-design constant arrays.

Per (design, workspace point), the same formulas as the numpy path
(:mod:`.poses`, :mod:`.legs`, :mod:`.dynamics`), in the same order where the
order decides the reachable mask:

* the platform frame (origin, ``R = Rz(yaw) Ry(pitch) Rx(roll)``) and the rate
  map ``S`` (6 x dof; a selection of twist components for translation, planar
  poses and the ``angular_velocity`` convention);
* per leg the closed-form inverse kinematics of its kind and branch, the rod
  ``d``, ``d.t`` and the row ``J_i = (d, r x d) S / (d.t)``;
* ``J^-1`` by Gauss-Jordan elimination with partial pivoting (its determinant
  on the way), the Frobenius norms of J and J^-1;
* singular values (stiffness, 2-norm condition) by one-sided Jacobi rotations
  on J, which give every singular value to high relative accuracy;
* the dynamic index: the pose-space mass matrix from the bodies (in pose
  coordinates directly: every body's velocity map is ``V_xi S``),
  ``M = J^-T M_p``, and sigma_max(M) by one-sided Jacobi;
* a reach code: 0 unreachable, 1 reachable, 2 reachable but ill-conditioned
  (``cond_F(J) >= HARD`` or anything not finite), left to the numpy path.

The reductions: fixed chunks of CHUNK points per design, each with its count,
sum, min, max and centred sum of squares, combined in chunk order, so results
do not depend on the number of threads.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ...fast._jit import NJIT as _NJIT

CHUNK = 256
#: cond_F(J) = ||J||_F ||J^-1||_F from which a point is left to LAPACK (the numpy path)
HARD = 1000.0
#: local values (rows of the kernel's output)
DYN, SMIN2, SMIN, FRO, TWO, DET, IFRO = 0, 1, 2, 3, 4, 5, 6
COL0 = 7            # COL0 + a: squared norm of column a of J (axis stiffness)
NVAL = 13
#: layout of the per-leg constants L (D, n, NL)
LA, LP, LU, LR0, LS0 = 0, 3, 6, 9, 12
LLA, LLR, LMACT, LMROD, LIROD, LFROD, LM1, LE1, LM2, LE2, LI12 = range(15, 26)
NL = 26
#: layout of the per-design constants F (D, NF)
FCEN, FFIX, FMP, FIP, FCOM = 0, 3, 6, 7, 16
NF = 19


@njit(inline="always", **_NJIT)
def _wrap(q):
    return q - 2.0 * math.pi * np.round(q / (2.0 * math.pi))


@njit(inline="always", **_NJIT)
def _frame(ptype, roles, X, jx, F, d, R, o, ang):
    """Origin o (3), R (3, 3), angles (roll, pitch, yaw) into ang, as poses.frames."""
    ang[0] = F[d, FFIX]
    ang[1] = F[d, FFIX + 1]
    ang[2] = F[d, FFIX + 2]
    o[0] = 0.0
    o[1] = 0.0
    o[2] = 0.0
    for i in range(roles.shape[0]):
        r = roles[i]
        if r < 3:
            o[r] = X[jx, i]
        else:
            ang[r - 3] = X[jx, i]
    if ptype == 2:
        o[0] = F[d, FCEN]
        o[1] = F[d, FCEN + 1]
        o[2] = F[d, FCEN + 2]
    if ptype == 0:
        for i in range(3):
            for j in range(3):
                R[i, j] = 1.0 if i == j else 0.0
    elif ptype == 1:
        c = math.cos(ang[2])
        s = math.sin(ang[2])
        R[0, 0] = c
        R[0, 1] = -s
        R[0, 2] = 0.0
        R[1, 0] = s
        R[1, 1] = c
        R[1, 2] = 0.0
        R[2, 0] = 0.0
        R[2, 1] = 0.0
        R[2, 2] = 1.0
    else:
        cr = math.cos(ang[0])
        sr = math.sin(ang[0])
        cp = math.cos(ang[1])
        sp = math.sin(ang[1])
        cy = math.cos(ang[2])
        sy = math.sin(ang[2])
        R[0, 0] = cy * cp
        R[0, 1] = cy * sp * sr - sy * cr
        R[0, 2] = cy * sp * cr + sr * sy
        R[1, 0] = sy * cp
        R[1, 1] = sy * sp * sr + cy * cr
        R[1, 2] = sy * sp * cr - cy * sr
        R[2, 0] = -sp
        R[2, 1] = cp * sr
        R[2, 2] = cp * cr


@njit(inline="always", **_NJIT)
def _rate_map(ptype, conv, roles, cols, ang, S):
    """S (6, dof): pose rates -> twist (or the selection of twist components)."""
    dof = roles.shape[0]
    for k in range(6):
        for j in range(dof):
            S[k, j] = 0.0
    if conv == 1 or ptype < 2:
        for j in range(dof):
            S[cols[j], j] = 1.0
        return
    cp = math.cos(ang[1])
    sp = math.sin(ang[1])
    cy = math.cos(ang[2])
    sy = math.sin(ang[2])
    for j in range(dof):
        r = roles[j]
        if r < 3:
            S[r, j] = 1.0
        elif r == 3:
            S[3, j] = cy * cp
            S[4, j] = sy * cp
            S[5, j] = -sp
        elif r == 4:
            S[3, j] = -sy
            S[4, j] = cy
        else:
            S[5, j] = 1.0


@njit(inline="always", **_NJIT)
def _legs(kind, branch, L, d, R, o, S, sel, cols, J, geo):
    """Inverse kinematics and J rows; geo[i] = (r 0:3, d 3:6, t 6:9, den 9, q 10,
    chat 11:14).  Returns False if a leg does not close."""
    n = kind.shape[0]
    dof = S.shape[1]
    for i in range(n):
        P0 = L[d, i, LP]
        P1 = L[d, i, LP + 1]
        P2 = L[d, i, LP + 2]
        r0 = R[0, 0] * P0 + R[0, 1] * P1 + R[0, 2] * P2
        r1 = R[1, 0] * P0 + R[1, 1] * P1 + R[1, 2] * P2
        r2 = R[2, 0] * P0 + R[2, 1] * P1 + R[2, 2] * P2
        b0 = o[0] + r0
        b1 = o[1] + r1
        b2 = o[2] + r2
        A0 = L[d, i, LA]
        A1 = L[d, i, LA + 1]
        A2 = L[d, i, LA + 2]
        w0 = b0 - A0
        w1 = b1 - A1
        w2 = b2 - A2
        ww = w0 * w0 + w1 * w1 + w2 * w2
        k = kind[i]
        br = branch[i]
        c0 = c1 = c2 = 0.0
        if k == 0:
            u0 = L[d, i, LU]
            u1 = L[d, i, LU + 1]
            u2 = L[d, i, LU + 2]
            uw = u0 * w0 + u1 * w1 + u2 * w2
            Lr = L[d, i, LLR]
            disc = Lr * Lr - ww + uw * uw
            if not disc >= 0.0:
                return False
            root = math.sqrt(disc)
            qm = uw - root
            qp = uw + root
            plus = br == 1
            if br >= 2:
                am0 = A0 + qm * u0
                am1 = A1 + qm * u1
                am2 = A2 + qm * u2
                ap0 = A0 + qp * u0
                ap1 = A1 + qp * u1
                ap2 = A2 + qp * u2
                far = ap0 * ap0 + ap1 * ap1 + ap2 * ap2 > am0 * am0 + am1 * am1 + am2 * am2
                plus = far if br == 2 else not far
            q = qp if plus else qm
            den = -root if plus else root
            a0 = A0 + q * u0
            a1 = A1 + q * u1
            a2 = A2 + q * u2
            t0, t1, t2 = u0, u1, u2
            d0 = b0 - a0
            d1 = b1 - a1
            d2 = b2 - a2
        elif k == 1:
            La = L[d, i, LLA]
            Lr = L[d, i, LLR]
            R00 = L[d, i, LR0]
            R01 = L[d, i, LR0 + 1]
            R02 = L[d, i, LR0 + 2]
            S00 = L[d, i, LS0]
            S01 = L[d, i, LS0 + 1]
            S02 = L[d, i, LS0 + 2]
            Pc = w0 * R00 + w1 * R01 + w2 * R02
            Qc = w0 * S00 + w1 * S01 + w2 * S02
            Cc = (ww + La * La - Lr * Lr) / (2.0 * La)
            h2 = Pc * Pc + Qc * Qc - Cc * Cc
            if not h2 >= 0.0:
                return False
            h = math.sqrt(h2)
            phi0 = math.atan2(Qc, Pc)
            dl = math.atan2(h, Cc)
            qp = _wrap(phi0 + dl)
            qm = _wrap(phi0 - dl)
            cpp = math.cos(qp)
            spp = math.sin(qp)
            cmm = math.cos(qm)
            smm = math.sin(qm)
            plus = br == 1
            if br >= 2:
                tp0 = A0 + La * (cpp * R00 + spp * S00)
                tp1 = A1 + La * (cpp * R01 + spp * S01)
                tp2 = A2 + La * (cpp * R02 + spp * S02)
                tm0 = A0 + La * (cmm * R00 + smm * S00)
                tm1 = A1 + La * (cmm * R01 + smm * S01)
                tm2 = A2 + La * (cmm * R02 + smm * S02)
                far = tp0 * tp0 + tp1 * tp1 + tp2 * tp2 > tm0 * tm0 + tm1 * tm1 + tm2 * tm2
                plus = far if br == 2 else not far
            q = qp if plus else qm
            cq = cpp if plus else cmm
            sq = spp if plus else smm
            c0 = cq * R00 + sq * S00
            c1 = cq * R01 + sq * S01
            c2 = cq * R02 + sq * S02
            den = -La * h if plus else La * h
            a0 = A0 + La * c0
            a1 = A1 + La * c1
            a2 = A2 + La * c2
            t0 = La * (-sq * R00 + cq * S00)
            t1 = La * (-sq * R01 + cq * S01)
            t2 = La * (-sq * R02 + cq * S02)
            d0 = b0 - a0
            d1 = b1 - a1
            d2 = b2 - a2
        else:
            q = math.sqrt(ww)
            den = q
            t0 = w0 / q
            t1 = w1 / q
            t2 = w2 / q
            d0, d1, d2 = w0, w1, w2
        g0 = d0 / den
        g1 = d1 / den
        g2 = d2 / den
        g3 = (r1 * d2 - r2 * d1) / den
        g4 = (r2 * d0 - r0 * d2) / den
        g5 = (r0 * d1 - r1 * d0) / den
        if sel:
            for j in range(dof):
                c = cols[j]
                J[i, j] = g0 if c == 0 else g1 if c == 1 else g2 if c == 2 else g3 if c == 3 else g4 if c == 4 else g5
        else:
            for j in range(dof):
                J[i, j] = (((((g0 * S[0, j] + g1 * S[1, j]) + g2 * S[2, j]) + g3 * S[3, j]) + g4 * S[4, j])
                           + g5 * S[5, j])
        geo[i, 0] = r0
        geo[i, 1] = r1
        geo[i, 2] = r2
        geo[i, 3] = d0
        geo[i, 4] = d1
        geo[i, 5] = d2
        geo[i, 6] = t0
        geo[i, 7] = t1
        geo[i, 8] = t2
        geo[i, 9] = den
        geo[i, 10] = q
        geo[i, 11] = c0
        geo[i, 12] = c1
        geo[i, 13] = c2
    return True


@njit(inline="always", **_NJIT)
def _inverse(J, Ji, W):
    """Ji = J^-1 by Gauss-Jordan with partial pivoting (W: n x 2n scratch);
    returns |det J| (0 if a pivot vanishes or is not finite)."""
    n = J.shape[0]
    for i in range(n):
        for j in range(n):
            W[i, j] = J[i, j]
            W[i, n + j] = 1.0 if i == j else 0.0
    det = 1.0
    for c in range(n):
        p = c
        best = abs(W[c, c])
        for r in range(c + 1, n):
            if abs(W[r, c]) > best:
                best = abs(W[r, c])
                p = r
        if not (best > 0.0 and best < np.inf):
            return 0.0
        if p != c:
            for j in range(2 * n):
                tmp = W[c, j]
                W[c, j] = W[p, j]
                W[p, j] = tmp
        piv = W[c, c]
        det *= piv
        inv = 1.0 / piv
        for j in range(2 * n):
            W[c, j] *= inv
        for r in range(n):
            if r != c:
                f = W[r, c]
                if f != 0.0:
                    for j in range(2 * n):
                        W[r, j] -= f * W[c, j]
    for i in range(n):
        for j in range(n):
            Ji[i, j] = W[i, n + j]
    return abs(det)


@njit(inline="always", **_NJIT)
def _jacobi_sv(B, s):
    """Singular values of the square B (destroyed) into s, by one-sided Jacobi
    (Hestenes) rotations of its columns; returns (sigma_max, sigma_min)."""
    n = B.shape[0]
    for sweep in range(60):
        rotated = False
        for p in range(n - 1):
            for q in range(p + 1, n):
                al = 0.0
                be = 0.0
                ga = 0.0
                for i in range(n):
                    x = B[i, p]
                    y = B[i, q]
                    al += x * x
                    be += y * y
                    ga += x * y
                if ga == 0.0 or abs(ga) <= 1e-15 * math.sqrt(al * be):
                    continue
                rotated = True
                ze = (be - al) / (2.0 * ga)
                t = (1.0 if ze >= 0 else -1.0) / (abs(ze) + math.sqrt(1.0 + ze * ze))
                c = 1.0 / math.sqrt(1.0 + t * t)
                sn = c * t
                for i in range(n):
                    x = B[i, p]
                    y = B[i, q]
                    B[i, p] = c * x - sn * y
                    B[i, q] = sn * x + c * y
        if not rotated:
            break
    hi = 0.0
    lo = np.inf
    for j in range(n):
        v = 0.0
        for i in range(n):
            v += B[i, j] * B[i, j]
        v = math.sqrt(v)
        s[j] = v
        hi = max(hi, v)
        lo = min(lo, v)
    return hi, lo


@njit(inline="always", **_NJIT)
def _addq(M, m, V, dof):
    """M += m V^T V for V (3, dof)."""
    if m == 0.0:
        return
    for a in range(dof):
        for b in range(a, dof):
            v = V[0, a] * V[0, b] + V[1, a] * V[1, b] + V[2, a] * V[2, b]
            M[a, b] += m * v


@njit(inline="always", **_NJIT)
def _mass(kind, L, F, d, R, S, translation, J, geo, M, V1, V2, V3, Vb):
    """Pose-space mass matrix (upper triangle filled, then mirrored) from the bodies."""
    n = kind.shape[0]
    dof = S.shape[1]
    for a in range(dof):
        for b in range(dof):
            M[a, b] = 0.0
    for i in range(n):
        r0, r1, r2 = geo[i, 0], geo[i, 1], geo[i, 2]
        d0, d1, d2 = geo[i, 3], geo[i, 4], geo[i, 5]
        t0, t1, t2 = geo[i, 6], geo[i, 7], geo[i, 8]
        # Vb = [I, -skew(r)] S: column j = S_v,j + S_w,j x r
        if translation:
            for j in range(dof):
                Vb[0, j] = S[0, j]
                Vb[1, j] = S[1, j]
                Vb[2, j] = S[2, j]
        else:
            for j in range(dof):
                w0, w1, w2 = S[3, j], S[4, j], S[5, j]
                Vb[0, j] = S[0, j] + (w1 * r2 - w2 * r1)
                Vb[1, j] = S[1, j] + (w2 * r0 - w0 * r2)
                Vb[2, j] = S[2, j] + (w0 * r1 - w1 * r0)
        k = kind[i]
        if k != 2:
            f = L[d, i, LFROD]
            l2 = L[d, i, LLR] * L[d, i, LLR]
            for j in range(dof):
                Jr = J[i, j]
                x0 = Vb[0, j] - t0 * Jr
                x1 = Vb[1, j] - t1 * Jr
                x2 = Vb[2, j] - t2 * Jr
                V1[0, j] = (1.0 - f) * (t0 * Jr) + f * Vb[0, j]
                V1[1, j] = (1.0 - f) * (t1 * Jr) + f * Vb[1, j]
                V1[2, j] = (1.0 - f) * (t2 * Jr) + f * Vb[2, j]
                V2[0, j] = (d1 * x2 - d2 * x1) / l2
                V2[1, j] = (d2 * x0 - d0 * x2) / l2
                V2[2, j] = (d0 * x1 - d1 * x0) / l2
            _addq(M, L[d, i, LMROD], V1, dof)
            _addq(M, L[d, i, LIROD], V2, dof)
            ma = L[d, i, LMACT]
            if ma != 0.0:
                for a in range(dof):
                    for b in range(a, dof):
                        M[a, b] += ma * (J[i, a] * J[i, b])
        else:
            q = geo[i, 10]
            n0, n1, n2 = d0 / q, d1 / q, d2 / q
            e1 = L[d, i, LE1]
            e2 = L[d, i, LE2]
            for j in range(dof):
                nv = n0 * Vb[0, j] + n1 * Vb[1, j] + n2 * Vb[2, j]
                p0 = (Vb[0, j] - n0 * nv) / q
                p1 = (Vb[1, j] - n1 * nv) / q
                p2 = (Vb[2, j] - n2 * nv) / q
                V1[0, j] = e1 * p0
                V1[1, j] = e1 * p1
                V1[2, j] = e1 * p2
                V2[0, j] = Vb[0, j] - e2 * p0
                V2[1, j] = Vb[1, j] - e2 * p1
                V2[2, j] = Vb[2, j] - e2 * p2
                V3[0, j] = (n1 * Vb[2, j] - n2 * Vb[1, j]) / q
                V3[1, j] = (n2 * Vb[0, j] - n0 * Vb[2, j]) / q
                V3[2, j] = (n0 * Vb[1, j] - n1 * Vb[0, j]) / q
            _addq(M, L[d, i, LM1], V1, dof)
            _addq(M, L[d, i, LM2], V2, dof)
            _addq(M, L[d, i, LI12], V3, dof)
    # platform: centre of mass rc = R c, inertia R I R^T
    c0, c1, c2 = F[d, FCOM], F[d, FCOM + 1], F[d, FCOM + 2]
    rc0 = R[0, 0] * c0 + R[0, 1] * c1 + R[0, 2] * c2
    rc1 = R[1, 0] * c0 + R[1, 1] * c1 + R[1, 2] * c2
    rc2 = R[2, 0] * c0 + R[2, 1] * c1 + R[2, 2] * c2
    for j in range(dof):
        w0, w1, w2 = S[3, j], S[4, j], S[5, j]
        Vb[0, j] = S[0, j] + (w1 * rc2 - w2 * rc1)
        Vb[1, j] = S[1, j] + (w2 * rc0 - w0 * rc2)
        Vb[2, j] = S[2, j] + (w0 * rc1 - w1 * rc0)
    _addq(M, F[d, FMP], Vb, dof)
    if translation:
        for a in range(dof):
            for b in range(a):
                M[a, b] = M[b, a]
        return
    # R I R^T applied to the angular columns
    for j in range(dof):
        for k in range(3):
            V1[k, j] = R[0, k] * S[3, j] + R[1, k] * S[4, j] + R[2, k] * S[5, j]   # R^T w
    for a in range(dof):
        for b in range(a, dof):
            v = 0.0
            for k in range(3):
                for m in range(3):
                    v += V1[k, a] * F[d, FIP + 3 * k + m] * V1[m, b]
            M[a, b] += v
    for a in range(dof):
        for b in range(a):
            M[a, b] = M[b, a]


@njit(inline="always", **_NJIT)
def _point(ptype, conv, roles, cols, kind, branch, L, F, d, X, jx, want, dyn, needs_sv, want_cols, m2, m1, vals):
    """Local values of design d at pose X[jx] into vals (NVAL); returns the reach code.
    m2, m1: the scratch matrices and vectors (see _chunk)."""
    R, S, J, Ji, W, B, geo, M, Mi, V1, V2, V3, Vb = m2
    o, ang, s = m1
    _frame(ptype, roles, X, jx, F, d, R, o, ang)
    _rate_map(ptype, conv, roles, cols, ang, S)
    sel = conv == 1 or ptype < 2
    if not _legs(kind, branch, L, d, R, o, S, sel, cols, J, geo):
        return 0
    n = J.shape[0]
    det = _inverse(J, Ji, W)
    if not det > 0.0:
        return 2
    f2 = 0.0
    i2 = 0.0
    for i in range(n):
        for j in range(n):
            f2 += J[i, j] * J[i, j]
            i2 += Ji[i, j] * Ji[i, j]
    cf = math.sqrt(f2 * i2)
    if not cf < HARD:
        return 2
    vals[FRO] = cf
    vals[IFRO] = 1.0 / cf
    vals[DET] = det
    if want_cols:
        for a in range(n):
            v = 0.0
            for i in range(n):
                v += J[i, a] * J[i, a]
            vals[COL0 + a] = v
    if needs_sv:
        for i in range(n):
            for j in range(n):
                B[i, j] = J[i, j]
        hi, lo = _jacobi_sv(B, s)
        vals[SMIN] = lo
        vals[SMIN2] = lo * lo
        vals[TWO] = hi / lo
    if dyn:
        _mass(kind, L, F, d, R, S, ptype == 0, J, geo, M, V1, V2, V3, Vb)
        for a in range(n):
            for b in range(n):
                v = 0.0
                for c in range(n):
                    v += Ji[c, a] * M[c, b]
                Mi[a, b] = v
        hi, lo = _jacobi_sv(Mi, s)
        vals[DYN] = hi
    for v in range(NVAL):
        if want[v] and not (vals[v] < np.inf and vals[v] > -np.inf):
            return 2
    return 1


@njit(**_NJIT)
def _scratch(n):
    """Scratch matrices (R, S, J, J^-1, Gauss-Jordan, SVD, leg geometry, M_p, M,
    body maps x 4) and vectors (origin, angles, singular values) of one task."""
    m2 = (np.empty((3, 3)), np.empty((6, n)), np.empty((n, n)), np.empty((n, n)), np.empty((n, 2 * n)),
          np.empty((n, n)), np.empty((n, 14)), np.empty((n, n)), np.empty((n, n)), np.empty((3, n)),
          np.empty((3, n)), np.empty((3, n)), np.empty((3, n)))
    return m2, (np.empty(3), np.empty(3), np.empty(n))


@njit(**_NJIT)
def _chunk(ptype, conv, roles, cols, kind, branch, L, F, d, X, lo, hi, want, codes, out):
    """Codes of points lo..hi-1 and the chunk's (sum, min, max, centred sum of
    squares) per wanted value into out (NVAL, 4); returns the count."""
    n = kind.shape[0]
    m2, m1 = _scratch(n)
    vals = np.zeros(NVAL)
    buf = np.empty((NVAL, hi - lo))
    dyn = want[DYN]
    needs_sv = want[SMIN] or want[SMIN2] or want[TWO]
    want_cols = False
    for v in range(COL0, NVAL):
        want_cols = want_cols or want[v]
    k = 0
    for j in range(lo, hi):
        c = _point(ptype, conv, roles, cols, kind, branch, L, F, d, X, j, want, dyn, needs_sv, want_cols, m2, m1, vals)
        codes[j - lo] = c
        if c == 1:
            for v in range(NVAL):
                buf[v, k] = vals[v]
            k += 1
    for v in range(NVAL):
        if not want[v] or k == 0:
            continue
        s = 0.0
        mn = np.inf
        mx = -np.inf
        for i in range(k):
            x = buf[v, i]
            s += x
            mn = min(mn, x)
            mx = max(mx, x)
        mu = s / k
        m2 = 0.0
        for i in range(k):
            e = buf[v, i] - mu
            m2 += e * e
        out[v, 0] = s
        out[v, 1] = mn
        out[v, 2] = mx
        out[v, 3] = m2
    return k


@njit(parallel=True, **_NJIT)
def summary(ptype, conv, roles, cols, kind, branch, L, F, X, want):
    """Per-design statistics (D, NVAL, 4: sum, min, max, centred sum of squares)
    over the points of code 1, their counts (D,), the codes (D, N) (int8)."""
    D = L.shape[0]
    N = X.shape[0]
    nch = (N + CHUNK - 1) // CHUNK
    codes = np.empty((D, N), dtype=np.int8)
    part = np.empty((D, nch, NVAL, 4))
    cnt = np.empty((D, nch), dtype=np.int64)
    for t in prange(D * nch):
        d = t // nch
        c = t % nch
        lo = c * CHUNK
        hi = min(lo + CHUNK, N)
        cnt[d, c] = _chunk(ptype, conv, roles, cols, kind, branch, L, F, d, X, lo, hi, want, codes[d, lo:hi], part[d, c])
    stats = np.full((D, NVAL, 4), np.nan)
    counts = np.zeros(D, dtype=np.int64)
    for d in range(D):
        k = 0
        for c in range(nch):
            k += cnt[d, c]
        counts[d] = k
        if k == 0:
            continue
        for v in range(NVAL):
            if not want[v]:
                continue
            s = 0.0
            mn = np.inf
            mx = -np.inf
            for c in range(nch):
                if cnt[d, c] > 0:
                    s += part[d, c, v, 0]
                    mn = min(mn, part[d, c, v, 1])
                    mx = max(mx, part[d, c, v, 2])
            mu = s / k
            m2 = 0.0
            for c in range(nch):
                kc = cnt[d, c]
                if kc > 0:
                    e = part[d, c, v, 0] / kc - mu
                    m2 += part[d, c, v, 3] + kc * (e * e)
            stats[d, v, 0] = s
            stats[d, v, 1] = mn
            stats[d, v, 2] = mx
            stats[d, v, 3] = m2
    return stats, counts, codes
