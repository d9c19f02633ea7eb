"""The engine's kernel of chain mechanisms (docs/lower-mobility.md): one
compiled code for every chain shape (joint kinds, counts and sizes read at
run time from the arrays of :mod:`.chain_layout`), so a new chain shape does
not compile again.

Per (design, workspace point), the numpy path's formulas
(:mod:`optdesign.mechanisms.described.chain_solve`, ``.chain_poe``,
``.chain_dynamics``), as scalar code per point (:mod:`.chain_closure`,
:mod:`.chain_dense`, :mod:`.chain_bodies`):

* the defined branch: the continuation from the design's home configuration
  (solved by the numpy path, passed in ``UH``) along the straight segment
  from the home pose's independent coordinates to the point, with the numpy
  path's adaptive steps, tests and tolerances;
* du/dx = -Fu^+ Fp at the solution, the Jacobian J = dq/dx (chain actuators
  from du/dx, shorthand legs from their closed forms: G S P), through the
  declared coordinate map's derivative Df where there is one;
* the mass matrix M_p in the independent coordinates from the platform and
  every link with a mass (:func:`.chain_bodies._mass`; shorthand legs'
  bodies are not here: the packing leaves the dynamic index of such
  mechanisms to the numpy path);

then the engine's tail on blocks of BLK points (:func:`.kernels.tail_j`,
``tail_w``, ``tail_codes``): J^-1, the singular values, W = U^T M_p, the
reach codes (0 unreachable, 1 reachable, 2 left to the numpy path), and the
same chunk statistics as :func:`.kernels.run_tasks`, so results do not
depend on the number of threads.  The values agree with the numpy path's to
round-off (its LAPACK solves against this scalar code), not bit for bit.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..fast._jit import JITABLE as _JITABLE
from ..fast._jit import NJIT as _NJIT
from . import kernels as _kernels
from .chain_bodies import _mass, _shorthand
from .chain_closure import _continuation, _system
from .chain_dense import _lsq
from .chain_layout import F_L, F_P0, G_ACT, G_VOFF, H_DOF, H_N, H_NEQ, H_NU, H_NVAR, H_PTYPE
from .digest import leaf, sources_digest
from .kernels import WORDS, _carve, _chunk_stats, combine, tail_codes, tail_j, tail_w  # noqa: F401 (WORDS, combine)
from .layout import BLK, CHUNK, NMAX, NVAL, VOK

#: numba's cache of these kernels watches this file only: it records the
#: digest of the other files compiled into them (kernels.py and its own
#: sources, the chain modules); tests/test_chain_compiled.py checks it
CHAIN_DIGEST = "061ed59b75e3b8ca"

_SOURCES = ("engine/kernels.py", "engine/chain_layout.py", "engine/chain_dense.py", "engine/chain_closure.py",
            "engine/chain_bodies.py") + _kernels._SOURCES


def chain_digest() -> str:
    """sha256 (first 16 hex digits) of the files compiled into these kernels besides this one."""
    return sources_digest(_SOURCES)


if chain_digest() != CHAIN_DIGEST or not _kernels._NJIT.get("cache", True):
    import warnings

    warnings.warn(f"{__name__}: {', '.join(_SOURCES)} changed (digest {chain_digest()}, recorded {CHAIN_DIGEST}): "
                  "the chain kernels compile without numba's cache until CHAIN_DIGEST is updated",
                  RuntimeWarning, stacklevel=1)
    _NJIT = {**_NJIT, "cache": False}


# ---------------------------------------------------------------------- one point
@leaf
def _workspace(dof, n, nvar, nu, neq):
    """One thread's per-point scratch for these sizes."""
    r = max(n, 1)
    wk = (np.zeros(dof), np.zeros(6), np.zeros(3), np.zeros((3, 3)), np.zeros((6, dof)), np.zeros((nvar, 6)),
          np.zeros((nvar, 3, 3)), np.zeros((nvar, 3)), np.zeros((3, 3)), np.zeros(3), np.zeros((3, 3)), np.zeros(3))
    cur = (np.zeros(nu), np.zeros(neq), np.zeros((neq, nu)), np.zeros((neq, n)))
    new = (np.zeros(nu), np.zeros(neq), np.zeros((neq, nu)), np.zeros((neq, n)))
    la = (np.zeros((max(neq, nu), nu)), np.zeros((max(neq, nu), r)), np.zeros((nu, r)),
          np.zeros(max(neq, nu) + 1, dtype=np.int64), np.zeros((neq, 1)))
    vec = (np.zeros(nu), np.zeros(nu), np.zeros(n), np.zeros(n))
    mats = (np.zeros(nu), np.zeros((nu, nu)), np.zeros((nu, n)), np.zeros((dof, n)), np.zeros((6, n)),
            np.zeros((n, n)), np.zeros((6, n)), np.zeros(6), np.zeros((n, n)))
    # the system at the design's home (u0, p0): F, Fu, Fp
    home = (np.zeros(neq), np.zeros((neq, nu)), np.zeros((neq, n)))
    return wk, cur, new, la, vec, mats, home


@leaf
def _design(I, VFd, LFd, GFd, uh, ws):
    """Per design, before its points: the continuation's weights and the
    system at its home configuration (the start of every point's segment)."""
    hdr, roles, cidx, legs, vcode = I[0], I[1], I[2], I[3], I[4]
    n = hdr[H_N]
    _weights(hdr, roles, cidx, vcode, GFd, ws[5][0])
    F0, Fu0, Fp0 = ws[6]
    _system(uh, GFd[F_P0:F_P0 + n], hdr[H_PTYPE], roles, cidx, legs, vcode, VFd, LFd, GFd, hdr[H_DOF], n,
            hdr[H_NVAR], hdr[H_NU], F0, Fu0, Fp0, ws[0])


@leaf
def _weights(hdr, roles, cidx, vcode, GFd, wt):
    """Per unknown: L for angles, 1 for lengths (the continuation's jump test;
    ChainMechanism._weights)."""
    L = GFd[F_L]
    nvar = hdr[H_NVAR]
    for v in range(nvar):
        wt[v] = 1.0 if vcode[v] == 1 else L
    for i in range(hdr[H_DOF]):
        c = cidx[i]
        if c < 0:
            wt[nvar - 1 - c] = L if roles[i] >= 3 else 1.0


@leaf
def _point(I, VFd, LFd, SFd, BFd, GFd, uh, x, Df, dyn_, ws):
    """J (n, n) and, with dyn_, M_p (n, n) of one design at the independent
    coordinates x (the pose's, through the map) into ws's mats[5], mats[8];
    False where the point is not reachable (no solution on the branch, a
    rank-deficient Fu, a shorthand leg that does not close, J not finite)."""
    hdr, roles, cidx, legs, vcode, acts, sh, bod = I
    ptype = hdr[H_PTYPE]
    dof = hdr[H_DOF]
    n = hdr[H_N]
    nvar = hdr[H_NVAR]
    nu = hdr[H_NU]
    neq = hdr[H_NEQ]
    wk, cur, new, la, vec, mats, home = ws
    wt, G, Um, P, Xi, Jp, T6, Gs, Mp = mats
    W, Wb, X1, piv, _ = la
    args = (ptype, roles, cidx, legs, vcode, VFd, LFd, GFd, dof, n, nvar, nu, neq, wk)
    if not _continuation(x, uh, GFd[F_P0:F_P0 + n], home[1:], wt, args, cur, new, la, vec, G):
        return False
    # du/dx = -Fu^+ Fp at the solution: the continuation's last step ends at p
    # = x exactly, its Newton's last system (cur's Fu, Fp; the frame and the
    # chains' motions in wk) is the one at the solution (chain_state evaluates
    # it again: the same numbers)
    Fu = cur[2]
    Fp = cur[3]
    if not _lsq(Fu, Fp, neq, nu, n, X1, W, Wb, piv):
        return False
    for r in range(nu):
        for c in range(n):
            s = 0.0
            for k in range(n):
                s += X1[r, k] * Df[k * n + c]
            Um[r, c] = -s
    for i in range(dof):
        ci = cidx[i]
        for c in range(n):
            P[i, c] = Df[ci * n + c] if ci >= 0 else Um[nvar - 1 - ci, c]
    R = wk[3]
    o = wk[2]
    S = wk[4]
    for a in range(6):
        for c in range(n):
            s = 0.0
            for i in range(dof):
                s += S[a, i] * P[i, c]
            Xi[a, c] = s
    for a in range(n):
        src = acts[a, 0]
        li = acts[a, 1]
        if src == 0:
            row = legs[li, G_VOFF] + legs[li, G_ACT]
            for c in range(n):
                Jp[a, c] = Um[row, c]
        else:
            if not _shorthand(sh[li, 0], sh[li, 1], SFd[li], o, R, Gs):
                return False
            for c in range(n):
                s = 0.0
                for k in range(6):
                    s += Gs[k] * Xi[k, c]
                Jp[a, c] = s
    for a in range(n):
        for c in range(n):
            x_ = Jp[a, c]
            if x_ - x_ != 0.0:
                return False
    if dyn_:
        _mass(Xi, Um, o, R, GFd, legs, bod, BFd, wk[5], wk[6], wk[7], n, Mp, T6)
    return True


@leaf
def _w_of(U, Mb, Wm, n, m):
    """W = U^T M_p (rows of BLK; U upper triangular for n >= 4, as tail_j leaves it)."""
    upper = n >= 4
    for i in range(n):
        for b in range(n):
            ow = (i * n + b) * BLK
            kmax = i + 1 if upper else n
            for j in range(m):
                s = 0.0
                for k in range(kmax):
                    s += U[(k * n + i) * BLK + j] * Mb[(k * n + b) * BLK + j]
                Wm[ow + j] = s


@njit(inline="always", **_JITABLE)
def _chain_block(I, VFd, LFd, SFd, BFd, GFd, uh, PXd, lo, m, want, flags, scratch, vb, cb, ws):
    """Values and reach codes of one design at the m points lo.. of PXd: value
    v of point j into vb[v CHUNK + j], its code into cb[j] (as kernels._block)."""
    n = I[0][H_N]
    dyn_ = flags[0]
    _, mats, _, T, V, S = scratch
    J = mats[0]
    U = mats[1]
    Mb = mats[2]
    Wm = mats[3]
    Jp = ws[5][5]
    Mp = ws[5][8]
    for j in range(m):
        row = PXd[lo + j]
        ok = _point(I, VFd, LFd, SFd, BFd, GFd, uh, row[:n], row[n:], dyn_, ws)
        V[VOK * BLK + j] = 1.0 if ok else 0.0
        for r in range(n):
            for c in range(n):
                e = 1.0 if r == c else 0.0
                J[(r * n + c) * BLK + j] = Jp[r, c] if ok else e
                if dyn_:
                    Mb[(r * n + c) * BLK + j] = Mp[r, c] if ok else e
    tail_j(J, U, V, T, S, vb, cb, n, m, flags, None)
    if dyn_:
        _w_of(U, Mb, Wm, n, m)
        tail_w(Wm, V, T, S, vb, n, m, None)
    tail_codes(vb, cb, want, m)


# ---------------------------------------------------------------------- the tasks
@njit(nogil=True, **_NJIT)
def run_tasks(w, nw, I, VF, LF, SF, BF, GF, UH, PX, N, want, flags, codes, part, cnt, keep, buf):
    """Tasks w, w + nw, ... of the D ceil(N / CHUNK) tasks (CHUNK points of one
    design each), as :func:`.kernels.run_tasks`: reach codes into codes (D,
    N), each task's statistics into part (D, nch, NVAL, 4) and its count into
    cnt (D, nch); keep (D, NVAL, N) every point's wanted values, or (0, 0, 0).
    I: the integer arrays (hdr, roles, cidx, legs, vcode, acts, sh, bod); VF,
    LF, SF, BF, GF, UH: the per-design arrays; PX (1 or D, N, n + n n): the
    points (:mod:`.chain_layout`); flags (6,): dynamic, sigma_min, sigma_max,
    column norms (the rest unused).  Releases the GIL."""
    hdr = I[0]
    n = hdr[H_N]
    D = GF.shape[0]
    nch = (N + CHUNK - 1) // CHUNK
    ntask = D * nch
    if n < 1 or n > NMAX or w >= ntask:
        return
    scratch, _, vals, cbuf = _carve(buf[w], n)
    ws = _workspace(hdr[H_DOF], n, hdr[H_NVAR], hdr[H_NU], hdr[H_NEQ])
    per_design = PX.shape[0] > 1
    for t in range(w, ntask, nw):
        d = t // nch
        c = t % nch
        lo = c * CHUNK
        n_pts = min(lo + CHUNK, N) - lo
        PXd = PX[d] if per_design else PX[0]
        _design(I, VF[d], LF[d], GF[d], UH[d], ws)
        for b in range(0, n_pts, BLK):
            m = min(BLK, n_pts - b)
            _chain_block(I, VF[d], LF[d], SF[d], BF[d], GF[d], UH[d], PXd, lo + b, m, want, flags, scratch,
                         vals[b:], cbuf[b:], ws)
        cnt[d, c] = _chunk_stats(vals, cbuf, n_pts, want, part[d, c])
        cd = codes[d, lo:lo + n_pts]
        for j in range(n_pts):
            cd[j] = np.int8(cbuf[j])
        if keep.shape[0] > 0:
            for v in range(NVAL):
                if want[v]:
                    kv = keep[d, v, lo:lo + n_pts]
                    for j in range(n_pts):
                        kv[j] = vals[v * CHUNK + j]


# ---------------------------------------------------------------------- tests: the routines on stacks
@njit(**_NJIT)
def system_stack(I, VF, LF, GF, U, Pin):
    """(F (K, neq), Fu (K, neq, nu), Fp (K, neq, n)) of design k at unknowns
    U[k] and independent coordinates Pin[k] (chain_solve.ik_system)."""
    hdr = I[0]
    K = U.shape[0]
    dof, n, nvar, nu, neq = hdr[H_DOF], hdr[H_N], hdr[H_NVAR], hdr[H_NU], hdr[H_NEQ]
    ws = _workspace(dof, n, nvar, nu, neq)
    F = np.zeros((K, neq))
    Fu = np.zeros((K, neq, nu))
    Fp = np.zeros((K, neq, n))
    for k in range(K):
        _system(U[k], Pin[k], hdr[H_PTYPE], I[1], I[2], I[3], I[4], VF[k], LF[k], GF[k], dof, n, nvar, nu, F[k],
                Fu[k], Fp[k], ws[0])
    return F, Fu, Fp


@njit(**_NJIT)
def continuation_stack(I, VF, LF, GF, UH, P1):
    """(u (K, nu), ok (K,)): the continuation of design k from its home UH[k] to P1[k]."""
    hdr = I[0]
    K = P1.shape[0]
    dof, n, nvar, nu, neq = hdr[H_DOF], hdr[H_N], hdr[H_NVAR], hdr[H_NU], hdr[H_NEQ]
    ws = _workspace(dof, n, nvar, nu, neq)
    wk, cur, new, la, vec, mats, home = ws
    out = np.full((K, nu), np.nan)
    ok = np.zeros(K, dtype=np.bool_)
    args0 = (hdr[H_PTYPE], I[1], I[2], I[3], I[4])
    for k in range(K):
        _design(I, VF[k], LF[k], GF[k], UH[k], ws)
        args = args0 + (VF[k], LF[k], GF[k], dof, n, nvar, nu, neq, wk)
        ok[k] = _continuation(P1[k], UH[k], GF[k, F_P0:F_P0 + n], home[1:], mats[0], args, cur, new, la, vec,
                              mats[1])
        if ok[k]:
            for c in range(nu):
                out[k, c] = cur[0][c]
    return out, ok
