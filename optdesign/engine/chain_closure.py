"""The closures of a chain mechanism in the chain kernel (:mod:`.chain_kernels`),
scalar code per point: the platform frame and rate map of a whole pose, one
chain's product of exponentials, the system F, Fu = dF/du, Fp = dF/dx of the
inverse problem (:func:`optdesign.mechanisms.described.chain_solve.ik_system`),
Newton and the continuation from the home configuration along the straight
segment (``chain_solve.newton``, ``chain_solve.continuation``: the same steps,
tests and tolerances, so the same branch)."""
from __future__ import annotations

import math

from .chain_dense import _det_positive, _finite, _lsq, _rodrigues
from .chain_layout import (
    E_END,
    E_P,
    F_CEN,
    F_FIX,
    F_L,
    G_CLOSURE,
    G_K,
    G_ROFF,
    G_VOFF,
    H_MIN,
    ITERS,
    POLISH,
    TOL,
    TOL_STEP,
    V_AXIS,
    V_POINT,
    V_SIDE,
)
from .digest import leaf


# ---------------------------------------------------------------------- the pose and the chains
@leaf
def _frame(ptype, roles, X, dof, GFd, rv, o, R, S):
    """The platform frame (origin o, R) and the rate map S (6, dof) of the
    whole pose X (poses.frames, chain_solve.full_rate_map)."""
    rv[0] = 0.0
    rv[1] = 0.0
    rv[2] = 0.0
    rv[3] = GFd[F_FIX]
    rv[4] = GFd[F_FIX + 1]
    rv[5] = GFd[F_FIX + 2]
    for i in range(dof):
        rv[roles[i]] = X[i]
    for a in range(3):
        for b in range(3):
            R[a, b] = 1.0 if a == b else 0.0
    cp = math.cos(rv[4])
    sp = math.sin(rv[4])
    cy = math.cos(rv[5])
    sy = math.sin(rv[5])
    if ptype == 1:
        R[0, 0] = cy
        R[0, 1] = -sy
        R[1, 0] = sy
        R[1, 1] = cy
    elif ptype >= 2:
        cr = math.cos(rv[3])
        sr = math.sin(rv[3])
        R[0, 0] = cy * cp
        R[0, 1] = cy * sp * sr - sy * cr
        R[0, 2] = cy * sp * cr + sr * sy
        R[1, 0] = sy * cp
        R[1, 1] = sy * sp * sr + cy * cr
        R[1, 2] = sy * sp * cr - cy * sr
        R[2, 0] = -sp
        R[2, 1] = cp * sr
        R[2, 2] = cp * cr
    for a in range(3):
        o[a] = GFd[F_CEN + a] if ptype == 2 else rv[a]
    for a in range(6):
        for j in range(dof):
            S[a, j] = 0.0
    for j in range(dof):
        r = roles[j]
        if ptype <= 1 or r < 3 or r == 5:
            S[r, j] = 1.0
        elif r == 3:
            S[3, j] = cy * cp
            S[4, j] = sy * cp
            S[5, j] = -sp
        else:
            S[3, j] = -sy
            S[4, j] = cy


@leaf
def _chain(k, voff, vcode, VFd, endref, u, tw, Rl, pl, Rc, pc, D, tmp):
    """One chain's product of exponentials at its joint values u[voff:voff + k]
    (chain_poe.chain_poe): the variables' spatial twists tw[v] (omega; v), the
    motion after each variable (Rl[v], pl[v]); the last link's motion into
    (Rc, pc) and its end point returned in tmp[0:3]."""
    for a in range(3):
        pc[a] = 0.0
        for b in range(3):
            Rc[a, b] = 1.0 if a == b else 0.0
    for j in range(k):
        v = voff + j
        a0 = VFd[v, V_AXIS]
        a1 = VFd[v, V_AXIS + 1]
        a2 = VFd[v, V_AXIS + 2]
        th = u[v]
        ra0 = Rc[0, 0] * a0 + Rc[0, 1] * a1 + Rc[0, 2] * a2
        ra1 = Rc[1, 0] * a0 + Rc[1, 1] * a1 + Rc[1, 2] * a2
        ra2 = Rc[2, 0] * a0 + Rc[2, 1] * a1 + Rc[2, 2] * a2
        code = vcode[v]
        if code == 0:
            c0 = VFd[v, V_POINT]
            c1 = VFd[v, V_POINT + 1]
            c2 = VFd[v, V_POINT + 2]
            q0 = Rc[0, 0] * c0 + Rc[0, 1] * c1 + Rc[0, 2] * c2 + pc[0]
            q1 = Rc[1, 0] * c0 + Rc[1, 1] * c1 + Rc[1, 2] * c2 + pc[1]
            q2 = Rc[2, 0] * c0 + Rc[2, 1] * c1 + Rc[2, 2] * c2 + pc[2]
            tw[v, 0] = ra0
            tw[v, 1] = ra1
            tw[v, 2] = ra2
            tw[v, 3] = q1 * ra2 - q2 * ra1
            tw[v, 4] = q2 * ra0 - q0 * ra2
            tw[v, 5] = q0 * ra1 - q1 * ra0
            _rodrigues(a0, a1, a2, th, D)
            tmp[0] = c0 - (D[0, 0] * c0 + D[0, 1] * c1 + D[0, 2] * c2)
            tmp[1] = c1 - (D[1, 0] * c0 + D[1, 1] * c1 + D[1, 2] * c2)
            tmp[2] = c2 - (D[2, 0] * c0 + D[2, 1] * c1 + D[2, 2] * c2)
        elif code == 1:
            tw[v, 0] = 0.0
            tw[v, 1] = 0.0
            tw[v, 2] = 0.0
            tw[v, 3] = ra0
            tw[v, 4] = ra1
            tw[v, 5] = ra2
            tmp[0] = a0 * th
            tmp[1] = a1 * th
            tmp[2] = a2 * th
        else:
            e0 = VFd[v, V_SIDE]
            e1 = VFd[v, V_SIDE + 1]
            e2 = VFd[v, V_SIDE + 2]
            _rodrigues(a0, a1, a2, th, D)
            s0 = D[0, 0] * e0 + D[0, 1] * e1 + D[0, 2] * e2
            s1 = D[1, 0] * e0 + D[1, 1] * e1 + D[1, 2] * e2
            s2 = D[2, 0] * e0 + D[2, 1] * e1 + D[2, 2] * e2
            x0 = a1 * s2 - a2 * s1
            x1 = a2 * s0 - a0 * s2
            x2 = a0 * s1 - a1 * s0
            tw[v, 0] = 0.0
            tw[v, 1] = 0.0
            tw[v, 2] = 0.0
            tw[v, 3] = Rc[0, 0] * x0 + Rc[0, 1] * x1 + Rc[0, 2] * x2
            tw[v, 4] = Rc[1, 0] * x0 + Rc[1, 1] * x1 + Rc[1, 2] * x2
            tw[v, 5] = Rc[2, 0] * x0 + Rc[2, 1] * x1 + Rc[2, 2] * x2
            tmp[0] = s0 - e0
            tmp[1] = s1 - e1
            tmp[2] = s2 - e2
        n0 = Rc[0, 0] * tmp[0] + Rc[0, 1] * tmp[1] + Rc[0, 2] * tmp[2] + pc[0]
        n1 = Rc[1, 0] * tmp[0] + Rc[1, 1] * tmp[1] + Rc[1, 2] * tmp[2] + pc[1]
        n2 = Rc[2, 0] * tmp[0] + Rc[2, 1] * tmp[1] + Rc[2, 2] * tmp[2] + pc[2]
        pc[0] = n0
        pc[1] = n1
        pc[2] = n2
        if code == 0:
            for a in range(3):
                r0 = Rc[a, 0]
                r1 = Rc[a, 1]
                r2 = Rc[a, 2]
                Rc[a, 0] = r0 * D[0, 0] + r1 * D[1, 0] + r2 * D[2, 0]
                Rc[a, 1] = r0 * D[0, 1] + r1 * D[1, 1] + r2 * D[2, 1]
                Rc[a, 2] = r0 * D[0, 2] + r1 * D[1, 2] + r2 * D[2, 2]
        for a in range(3):
            pl[v, a] = pc[a]
            for b in range(3):
                Rl[v, a, b] = Rc[a, b]
    for a in range(3):
        tmp[a] = Rc[a, 0] * endref[0] + Rc[a, 1] * endref[1] + Rc[a, 2] * endref[2] + pc[a]


@leaf
def _system(u, p, ptype, roles, cidx, legs, vcode, VFd, LFd, GFd, dof, n, nvar, nu, F, Fu, Fp, wk):
    """F (neq), Fu (neq, nu), Fp (neq, n) of the inverse problem at unknowns u
    and independent coordinates p (chain_solve.ik_system); the whole pose,
    its frame and the chains' motions stay in wk."""
    X, rv, o, R, S, tw, Rl, pl, Rc, pc, D, tmp = wk
    for i in range(dof):
        c = cidx[i]
        X[i] = p[c] if c >= 0 else u[nvar - 1 - c]
    _frame(ptype, roles, X, dof, GFd, rv, o, R, S)
    L = GFd[F_L]
    for i in range(F.shape[0]):
        F[i] = 0.0
        for c in range(nu):
            Fu[i, c] = 0.0
        for c in range(n):
            Fp[i, c] = 0.0
    for li in range(legs.shape[0]):
        k = legs[li, G_K]
        voff = legs[li, G_VOFF]
        ro = legs[li, G_ROFF]
        _chain(k, voff, vcode, VFd, LFd[li, E_END:E_END + 3], u, tw, Rl, pl, Rc, pc, D, tmp)
        e0 = tmp[0]
        e1 = tmp[1]
        e2 = tmp[2]
        P0 = LFd[li, E_P]
        P1 = LFd[li, E_P + 1]
        P2 = LFd[li, E_P + 2]
        r0 = R[0, 0] * P0 + R[0, 1] * P1 + R[0, 2] * P2
        r1 = R[1, 0] * P0 + R[1, 1] * P1 + R[1, 2] * P2
        r2 = R[2, 0] * P0 + R[2, 1] * P1 + R[2, 2] * P2
        F[ro] = e0 - (o[0] + r0)
        F[ro + 1] = e1 - (o[1] + r1)
        F[ro + 2] = e2 - (o[2] + r2)
        frame = legs[li, G_CLOSURE] == 1
        for j in range(k):
            v = voff + j
            w0 = tw[v, 0]
            w1 = tw[v, 1]
            w2 = tw[v, 2]
            Fu[ro, v] = tw[v, 3] + (w1 * e2 - w2 * e1)
            Fu[ro + 1, v] = tw[v, 4] + (w2 * e0 - w0 * e2)
            Fu[ro + 2, v] = tw[v, 5] + (w0 * e1 - w1 * e0)
            if frame:
                Fu[ro + 3, v] = L * w0
                Fu[ro + 4, v] = L * w1
                Fu[ro + 5, v] = L * w2
        # df/dxi = -[I, -skew(r)] (and -L [0, I]), times the rate map's columns
        for c in range(dof):
            s0 = S[3, c]
            s1 = S[4, c]
            s2 = S[5, c]
            g0 = -S[0, c] + (r1 * s2 - r2 * s1)
            g1 = -S[1, c] + (r2 * s0 - r0 * s2)
            g2 = -S[2, c] + (r0 * s1 - r1 * s0)
            ci = cidx[c]
            if ci >= 0:
                Fp[ro, ci] = g0
                Fp[ro + 1, ci] = g1
                Fp[ro + 2, ci] = g2
                if frame:
                    Fp[ro + 3, ci] = -L * s0
                    Fp[ro + 4, ci] = -L * s1
                    Fp[ro + 5, ci] = -L * s2
            else:
                col = nvar - 1 - ci
                Fu[ro, col] = g0
                Fu[ro + 1, col] = g1
                Fu[ro + 2, col] = g2
                if frame:
                    Fu[ro + 3, col] = -L * s0
                    Fu[ro + 4, col] = -L * s1
                    Fu[ro + 5, col] = -L * s2
        if frame:
            # L vee(E - E^T) / 2, E = R_end R^T
            E01 = Rc[0, 0] * R[1, 0] + Rc[0, 1] * R[1, 1] + Rc[0, 2] * R[1, 2]
            E02 = Rc[0, 0] * R[2, 0] + Rc[0, 1] * R[2, 1] + Rc[0, 2] * R[2, 2]
            E10 = Rc[1, 0] * R[0, 0] + Rc[1, 1] * R[0, 1] + Rc[1, 2] * R[0, 2]
            E12 = Rc[1, 0] * R[2, 0] + Rc[1, 1] * R[2, 1] + Rc[1, 2] * R[2, 2]
            E20 = Rc[2, 0] * R[0, 0] + Rc[2, 1] * R[0, 1] + Rc[2, 2] * R[0, 2]
            E21 = Rc[2, 0] * R[1, 0] + Rc[2, 1] * R[1, 1] + Rc[2, 2] * R[1, 2]
            F[ro + 3] = L * (0.5 * (E21 - E12))
            F[ro + 4] = L * (0.5 * (E02 - E20))
            F[ro + 5] = L * (0.5 * (E10 - E01))


@leaf
def _maxabs(F):
    """max |F|, NaN if any entry is NaN (numpy's max)."""
    r = 0.0
    for i in range(F.shape[0]):
        x = abs(F[i])
        if x != x:
            return x
        r = x if x > r else r
    return r


@leaf
def _newton(u, p, tol, target, args, F, Fu, Fp, la):
    """Newton (Gauss-Newton) from u in place (chain_solve.newton, undamped):
    while max |F| > min(tol, target) L, at most ITERS steps; returns whether
    max |F| <= tol L; F, Fu, Fp at the final u."""
    ptype, roles, cidx, legs, vcode, VFd, LFd, GFd, dof, n, nvar, nu, neq, wk = args
    W, Wb, X1, piv, rhs = la
    L = GFd[F_L]
    _system(u, p, ptype, roles, cidx, legs, vcode, VFd, LFd, GFd, dof, n, nvar, nu, F, Fu, Fp, wk)
    res = _maxabs(F)
    lim = min(tol, target) * L
    for _ in range(ITERS):
        if res <= lim or res != res:
            break
        for i in range(neq):
            rhs[i, 0] = F[i]
        if not _lsq(Fu, rhs, neq, nu, 1, X1, W, Wb, piv):
            return False
        for c in range(nu):
            u[c] = u[c] - X1[c, 0]
        _system(u, p, ptype, roles, cidx, legs, vcode, VFd, LFd, GFd, dof, n, nvar, nu, F, Fu, Fp, wk)
        res = _maxabs(F)
    return res <= tol * L


@leaf
def _continuation(p1, u0, p0, start, wt, args, cur, new, la, vec, G):
    """The solution connected to (u0, p0) along the segment p0 -> p1
    (chain_solve.continuation, one point): into cur's u, with F, Fu, Fp
    there; False where none is found (a step below H_MIN).  start: (Fu, Fp)
    at (u0, p0), the same for every point of a design (:func:`_system`, once
    per design by the caller)."""
    ptype, roles, cidx, legs, vcode, VFd, LFd, GFd, dof, n, nvar, nu, neq, wk = args
    u, F, Fu, Fp = cur
    un, Fn, Fun, Fpn = new
    W, Wb, X1, piv, rhs = la
    pred, du, p, dp = vec
    L = GFd[F_L]
    for c in range(nu):
        if not _finite(u0[c]):
            return False
        u[c] = u0[c]
    for i in range(n):
        if not _finite(p1[i]):
            return False
    Fu0, Fp0 = start
    for i in range(neq):
        for c in range(nu):
            Fu[i, c] = Fu0[i, c]
        for c in range(n):
            Fp[i, c] = Fp0[i, c]
    t = 0.0
    h = 1.0
    while True:
        tn = min(t + h, 1.0)
        last = tn >= 1.0
        for i in range(n):
            d = p1[i] - p0[i]
            p[i] = p1[i] if last else p0[i] + tn * d
            dp[i] = (tn - t) * d
        for r in range(neq):
            s = 0.0
            for i in range(n):
                s += Fp[r, i] * dp[i]
            rhs[r, 0] = s
        acc = _lsq(Fu, rhs, neq, nu, 1, X1, W, Wb, piv)
        if acc:
            for c in range(nu):
                du[c] = -X1[c, 0]
                pred[c] = u[c] + du[c]
                un[c] = pred[c]
            conv = _newton(un, p, TOL if last else TOL_STEP, POLISH if last else TOL_STEP, args, Fn, Fun, Fpn, la)
            a = 0.0
            b = 0.0
            fin = True
            for c in range(nu):
                x = (un[c] - pred[c]) * wt[c]
                a += x * x
                y = du[c] * wt[c]
                b += y * y
                fin = fin and _finite(un[c])
            jump = math.sqrt(a) > 0.5 * math.sqrt(b) + 1e-9 * L
            acc = conv and fin and not jump
            if acc:
                # the closures' Jacobian keeps its orientation: det(Fu_prev^T Fu) > 0
                good = True
                for r in range(nu):
                    for c in range(nu):
                        s = 0.0
                        for i in range(neq):
                            s += Fu[i, r] * Fun[i, c]
                        G[r, c] = s
                        good = good and _finite(s)
                acc = good and _det_positive(G, nu, piv)
        if acc:
            for c in range(nu):
                u[c] = un[c]
            for i in range(neq):
                F[i] = Fn[i]
                for c in range(nu):
                    Fu[i, c] = Fun[i, c]
                for c in range(n):
                    Fp[i, c] = Fpn[i, c]
            t = tn
            h = min(2.0 * h, 1.0)
            if last:
                return True
        else:
            h = 0.25 * h
            if h < H_MIN:
                return False
