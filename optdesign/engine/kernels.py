"""The engine's numba kernels: one compiled code for every mechanism shape.

Everything that differs between mechanisms is data: the leg kinds and
branches (``kind``, ``branch``), the pose-column kinds (``ct``), the pose
type and the per-design constants (``L`` per leg, ``F`` per design, packed by
the mechanism: :mod:`optdesign.mechanisms.described.compiled`), and the size
n (legs = pose coordinates, at most NMAX), which the routines read at run
time.  So the kernels compile once per machine (numba's cache), not once per
shape.

Points are processed in blocks of BLK as structure-of-arrays: every
intermediate quantity is a row of BLK values (``A[(r n + c) BLK + j]`` for
entry (r, c) of point j), and every stage is a loop over the block's points
whose body is straight-line code, so that LLVM vectorizes it across points.

Per (design, workspace point), the formulas of the numpy path
(:mod:`optdesign.mechanisms.described.poses`, ``.legs``, ``.dynamics``), in the
same order where the order decides the reachable mask:

* the platform frame ``R`` and the rate map's Euler columns come from the
  numpy path itself (``FR``: computed once per call, per point, by the caller);
* per leg the closed-form inverse kinematics of its kind and branch, the rod
  ``d``, ``d.t`` and the twist row ``g_i = (d, r x d) / (d.t)``; J = G S
  (S: a selection of twist components, or the Euler columns);
* J^-1 (adjugate with compensated minors, n <= 3) or R^-1 of J = QR
  (Householder, n >= 4): ``|det J|``, ``||J^-1||_F`` and the singular values
  of J^-1 (:mod:`.dense`);
* every singular value an index needs is the largest of some matrix:
  ``sigma_min(J)^2 = 1 / lambda_max(J^-1 J^-T)``, ``sigma_max(J)^2 =
  lambda_max(J^T J)``, and for the dynamic index ``M = J^-T M_p`` so
  ``sigma_max(M)^2 = lambda_max(W^T W)`` with ``W = U^T M_p``;
* the pose-space mass matrix from the bodies, without forming the bodies'
  velocity maps: ``M_p = S^T B S + sum_i [gamma_i J_i^T J_i + delta_i
  (J_i^T K_i + K_i^T J_i)]`` with B the rigid-body matrix of the platform and
  the bodies' shares that move with the platform points (see
  :func:`_rod_coefficients`, :func:`_leg_strut`), J_i the Jacobian row and K_i
  the row of ``t.bdot``;
* a reach code: 0 unreachable, 1 reachable, 2 reachable but ill-conditioned
  (``cond_F(J) >= HARD``, HARD_SMALL for n <= 3, or anything not finite),
  left to the numpy path.

The reductions: fixed chunks of CHUNK points per design, each with its count,
sum, min, max and centred sum of squares in point order, combined in chunk
order, so results do not depend on the number of threads.  The threads are
the caller's (:func:`run_tasks` releases the GIL; each thread takes every
nw-th task), which compiles far faster than a numba parallel loop.
"""
from __future__ import annotations

import math

import llvmlite.binding as _llvm
import numpy as np
from numba import njit, types
from numba import uint64 as _u
from numba.extending import overload, register_jitable

from ..fast._jit import JITABLE as _JITABLE
from ..fast._jit import NJIT as _NJIT
from ..fast._jit import chunk_moments
from ..fast._jit import lambda_max_psd as _lmax3_point
from . import layout as _layout
from .codegen import GLOBALS, KernelSpec, routine_source
from .digest import LEAF_SOURCES, leaf, sources_digest
from .eigen import COLS, ROWS, bisect_flagged, lmax
from .inverse import inverse
from .layout import (BLK, CHUNK, COL0, DET, DYN, FRO, GG, GK, HARD, HARD_SMALL, IFRO, NB, NEWTON, NEWTON_DYN, NFR, NLG,
                    NMAX, NVAL, NVS, SMIN, SMIN2, SROWS, TWO, VDET, VI2, VLJ, VLU, VLW, VMASK, VOK)
from .legs import legs, pose_rows, rigid
from .mass import dyn

#: numba's cache of these kernels watches this file only, while the code of
#: legs.py, inverse.py, eigen.py, mass.py and codegen.py, the numbers of
#: layout.py (and its ids from optdesign/formulas.py) and the helpers of
#: optdesign/fast/_jit.py are compiled into them: this
#: file records their digest, so that editing them means editing this file
#: too (tests/test_engine.py checks it); until then the kernels compile
#: without the cache (a warning says so), never from a stale one
ENGINE_DIGEST = "3744339e8a20445b"

_SOURCES = tuple(f for f in LEAF_SOURCES if f != "engine/kernels.py" and "chain_" not in f)


def engine_digest() -> str:
    """sha256 (first 16 hex digits) of the files compiled into these kernels besides this one."""
    return sources_digest(_SOURCES)


if engine_digest() != ENGINE_DIGEST:
    import warnings

    warnings.warn(f"{__name__}: {', '.join(_SOURCES)} changed (digest {engine_digest()}, recorded {ENGINE_DIGEST}): "
                  "the kernels compile without numba's cache until ENGINE_DIGEST is updated",
                  RuntimeWarning, stacklevel=1)
    _NJIT = {**_NJIT, "cache": False}

# LLVM's loop strength reduction is the largest single pass of the kernels'
# machine code (a tenth of the first compile) and gains them nothing measurable
# (docs/performance.md): off for the compiles of this process (an LLVM option
# is global: numba code compiled later in the process is built without it too)
_llvm.set_option("optdesign", "--disable-lsr")

#: the chunk reductions only: reassociation lets LLVM vectorize the sums (the
#: order is still fixed by the code, so results do not depend on threads)
_JITABLE_RED = {**_JITABLE, "fastmath": {"reassoc", "nsz"}}
#: the generic routines (:func:`.inverse.inverse`, :func:`.eigen.lmax`,
#: :func:`.mass.dyn`, named with the digest where they are defined) as the
#: selector overloads compile them: cached like the routines they call
#: (:func:`.digest.leaf`)
_CACHED = {**_JITABLE, "cache": True}


# ---------------------------------------------------------------------- the specialized tier
# The dense routines come in two forms that give the same bits: the generic
# ones of .dense (n read at run time: one compiled code for every shape) and
# the fixed-size straight-line code .codegen writes for one shape (faster for
# n >= 4, compiled once per shape).  The kernels take a selector ``sel``:
# None for the generic routines, or ``KernelSpec.numba_args()`` (a tuple of n
# zeros and a record array whose field names say the spec), whose *types*
# numba specializes on; each @overload below picks the routine from them (the
# generic routine itself, which takes sel and ignores it: a wrapper around it
# would be one more library for numba to optimize and generate).
def _bisect_nt(T, out, V, nt, m):
    bisect_flagged(T, out, V, len(nt), m)


register_jitable(**_JITABLE)(_bisect_nt)

_GEN_NAMES = {"math": math, "np": np, "_u": _u, "_lmax3_point": _lmax3_point, "_bisect_flagged": _bisect_nt,
              **{k: getattr(_layout, k) for k in GLOBALS if hasattr(_layout, k)}}


def _generated(stub, n, spec=None):
    """The generated routine ``stub`` for size n (and spec) as a jitable function."""
    ns = dict(_GEN_NAMES)
    exec(compile(routine_source(stub, n, spec), "<optdesign engine, generated>", "exec"), ns)  # noqa: S102
    return register_jitable(**_JITABLE)(ns["impl"])


def _sel_spec(sel):
    """(n, KernelSpec) from the type of a selector (None: the generic routines)."""
    if isinstance(sel, types.NoneType):
        return None
    return sel.types[0].count, KernelSpec.of_type(sel.types[1])


def inverse_sel(A, U, V, S, n, m, sel):
    """:func:`.dense.inverse`, or its generated fixed-size form (see above)."""


@overload(inverse_sel, jit_options=_CACHED)
def _ov_inverse_generic(A, U, V, S, n, m, sel):
    return inverse if isinstance(sel, types.NoneType) else None


@overload(inverse_sel, jit_options=_JITABLE)
def _ov_inverse_sel(A, U, V, S, n, m, sel):
    sp = _sel_spec(sel)
    if sp is None:
        return None
    if sp[0] <= 3:
        return inverse
    gen = _generated("_inverse", sp[0])
    return lambda A, U, V, S, n, m, sel: gen(A, U, V, sel[0], m)


def lmax_sel(X, out, T, V, S, n, m, mode, iters, sel):
    """:func:`.dense.lmax`, or its generated fixed-size form (mode, iters:
    compile-time there, ROWS/COLS and NEWTON/NEWTON_DYN as the kernel calls it)."""


@overload(lmax_sel, jit_options=_CACHED)
def _ov_lmax_generic(X, out, T, V, S, n, m, mode, iters, sel):
    return lmax if isinstance(sel, types.NoneType) else None


@overload(lmax_sel, jit_options=_JITABLE)
def _ov_lmax_sel(X, out, T, V, S, n, m, mode, iters, sel):
    sp = _sel_spec(sel)
    if sp is None:
        return None
    rows = _generated("_lmax_rows", sp[0])
    cols = _generated("_lmax_cols", sp[0])
    # the same code when NEWTON_DYN == NEWTON: compiled once
    same = routine_source("_lmax_dyn", sp[0]) == routine_source("_lmax_cols", sp[0])
    dynl = cols if same else _generated("_lmax_dyn", sp[0])

    def impl(X, out, T, V, S, n, m, mode, iters, sel):
        if mode == ROWS:
            rows(X, out, T, V, sel[0], m)
        elif iters == NEWTON:
            cols(X, out, T, V, sel[0], m)
        else:
            dynl(X, out, T, V, sel[0], m)
    return impl


def dyn_sel(B, Lg, J, Kp, FRb, U, W, S, n, ct, rods, m, mass_only, sel):
    """:func:`.dense.dyn`, or its generated form for the spec."""


@overload(dyn_sel, jit_options=_CACHED)
def _ov_dyn_generic(B, Lg, J, Kp, FRb, U, W, S, n, ct, rods, m, mass_only, sel):
    return dyn if isinstance(sel, types.NoneType) else None


@overload(dyn_sel, jit_options=_JITABLE)
def _ov_dyn_sel(B, Lg, J, Kp, FRb, U, W, S, n, ct, rods, m, mass_only, sel):
    sp = _sel_spec(sel)
    if sp is None:
        return None
    w = _generated("_dyn_w", sp[0], sp[1])
    mp = _generated("_mass_p", sp[0], sp[1])

    def impl(B, Lg, J, Kp, FRb, U, W, S, n, ct, rods, m, mass_only, sel):
        if mass_only:
            mp(B, Lg, J, Kp, FRb, U, W, sel[0], sel[1], m)
        else:
            w(B, Lg, J, Kp, FRb, U, W, sel[0], sel[1], m)
    return impl


# ---------------------------------------------------------------------- one block of points
#: words of one worker's scratch (:func:`_carve`), for any n up to NMAX
WORDS = (NMAX * NLG * BLK + 4 * NMAX * NMAX * BLK + NB * BLK + 2 * NMAX * BLK + (NVS + 3 * NMAX) * BLK
         + SROWS * BLK + NFR * BLK + NVAL * CHUNK + CHUNK)


@leaf
def _carve(buf, n):
    """One worker's scratch as views of its buffer (WORDS floats, zeros at
    first, then what earlier calls left: finite numbers, which the code that
    computes a whole block reads beyond m): legs (n, NLG BLK), four n x n
    matrices (J, J^-1 or R^-1, K, W), the rigid-body B (NB rows), the
    tridiagonal (2 n rows), vectors (NVS + 3 n rows), the dense routines' rows;
    then the frame block, the values and the codes of a chunk."""
    o = 0
    Lg = buf[o:o + n * NLG * BLK].reshape((n, NLG * BLK))
    o += n * NLG * BLK
    mats = buf[o:o + 4 * n * n * BLK].reshape((4, n * n * BLK))
    o += 4 * n * n * BLK
    B = buf[o:o + NB * BLK]
    o += NB * BLK
    T = buf[o:o + 2 * n * BLK]
    o += 2 * n * BLK
    V = buf[o:o + (NVS + 3 * n) * BLK]
    o += (NVS + 3 * n) * BLK
    S = buf[o:o + SROWS * BLK]
    o += SROWS * BLK
    FRb = buf[o:o + NFR * BLK]
    o += NFR * BLK
    vals = buf[o:o + NVAL * CHUNK]
    o += NVAL * CHUNK
    cbuf = buf[o:o + CHUNK]
    return (Lg, mats, B, T, V, S), FRb, vals, cbuf


@leaf
def _alloc(n):
    """A fresh scratch (:func:`_carve` of a zero buffer)."""
    return _carve(np.zeros(WORDS), n)


@njit(inline="always", **_JITABLE)
def _block(ptype, ct, kind, branch, L, F, d, FRb, m, want, flags, scratch, vb, cb, sel):
    """Values and reach codes of design d at the m points of the frame block
    FRb: value v of point j into vb[v CHUNK + j], its code (as a float) into cb[j]."""
    n = kind.shape[0]
    dyn_, rods, rot = flags[0], flags[4], flags[5]
    Lg, mats, B, T, V, S = scratch
    J = mats[0]
    U = mats[1]
    Kp = mats[2]
    Wm = mats[3]
    for j in range(m):
        V[VOK * BLK + j] = 1.0
    legs(L, F, d, ptype, kind, branch, FRb, m, Lg, V, dyn_, rot)
    pose_rows(Lg, GG, ct, FRb, m, J, n)
    tail_j(J, U, V, T, S, vb, cb, n, m, flags, sel)
    if dyn_:
        if rods:
            pose_rows(Lg, GK, ct, FRb, m, Kp, n)
        rigid(ptype, F, d, FRb, m, Lg, B, n, rot)
        dyn_sel(B, Lg, J, Kp, FRb, U, Wm, S, n, ct, rods, m, False, sel)
        tail_w(Wm, V, T, S, vb, n, m, sel)
    tail_codes(vb, cb, want, m)


@njit(inline="always", **_JITABLE)
def tail_j(J, U, V, T, S, vb, cb, n, m, flags, sel):
    """The engine's tail from the Jacobians J (a block of m points, rows of
    BLK) of the points whose V row VOK is nonzero: the column norms, J^-1 (or
    R^-1) into U, cond_F, |det J|, the reach codes into cb (0 where VOK is 0,
    2 where ill-conditioned) and the singular values the flags ask for."""
    sv_inv, sv_j, cols = flags[1], flags[2], flags[3]
    if cols:
        for c in range(n):
            for j in range(m):
                s = 0.0
                for i in range(n):
                    x = J[(i * n + c) * BLK + j]
                    s += x * x
                vb[(COL0 + c) * CHUNK + j] = s
    inverse_sel(J, U, V, S, n, m, sel)
    hard = HARD if n >= 4 else HARD_SMALL
    for j in range(m):
        s = 0.0
        for i in range(n * n):
            x = J[i * BLK + j]
            s += x * x
        cf = math.sqrt(s * V[VI2 * BLK + j])
        det = V[VDET * BLK + j]
        good = (V[VOK * BLK + j] != 0.0) & (det > 0.0) & (cf < hard)
        V[VMASK * BLK + j] = 1.0 if good else 0.0
        cb[j] = (1.0 if good else 2.0) if V[VOK * BLK + j] != 0.0 else 0.0
        vb[FRO * CHUNK + j] = cf
        vb[IFRO * CHUNK + j] = 1.0 / cf
        vb[DET * CHUNK + j] = det
    if sv_inv:
        lmax_sel(U, V[VLU * BLK:(VLU + 1) * BLK], T, V, S, n, m, ROWS, NEWTON, sel)
        for j in range(m):
            s2 = 1.0 / V[VLU * BLK + j]
            vb[SMIN2 * CHUNK + j] = s2
            vb[SMIN * CHUNK + j] = math.sqrt(s2)
        if sv_j:
            lmax_sel(J, V[VLJ * BLK:(VLJ + 1) * BLK], T, V, S, n, m, COLS, NEWTON, sel)
            for j in range(m):
                vb[TWO * CHUNK + j] = math.sqrt(V[VLJ * BLK + j] * V[VLU * BLK + j])


@njit(inline="always", **_JITABLE)
def tail_w(Wm, V, T, S, vb, n, m, sel):
    """The dynamic index sigma_max(W) from W = U^T M_p (rows of BLK)."""
    lmax_sel(Wm, V[VLW * BLK:(VLW + 1) * BLK], T, V, S, n, m, COLS, NEWTON_DYN, sel)
    for j in range(m):
        vb[DYN * CHUNK + j] = math.sqrt(V[VLW * BLK + j])


@njit(inline="always", **_JITABLE)
def tail_codes(vb, cb, want, m):
    """A reachable point with a wanted value not finite: left to the numpy path (code 2)."""
    for v in range(NVAL):
        if want[v]:
            for j in range(m):
                x = vb[v * CHUNK + j]
                cb[j] = 2.0 if (cb[j] == 1.0) & (not (x < np.inf and x > -np.inf)) else cb[j]


@leaf(fastmath=_JITABLE_RED["fastmath"])
def _chunk_stats(vals, cb, n_pts, want, out):
    """For each wanted value its sum, min, max and centred sum of squares over
    the points of code 1 (cb[j] == 1) into out (NVAL, 4); returns their count.
    Compiled with reassociation so that the sums vectorize: the order is still
    the compiled code's, the same for every thread count."""
    k = 0
    for j in range(n_pts):
        k += 1 if cb[j] == 1.0 else 0
    if k == 0:
        return 0
    for v in range(NVAL):
        if not want[v]:
            continue
        x = vals[v * CHUNK:v * CHUNK + n_pts]
        s = 0.0
        mn = np.inf
        mx = -np.inf
        for j in range(n_pts):
            r = cb[j] == 1.0
            xj = x[j]
            s += xj if r else 0.0
            lo = xj if r else np.inf
            hi = xj if r else -np.inf
            mn = lo if lo < mn else mn
            mx = hi if hi > mx else mx
        mu = s / k
        m2 = 0.0
        for j in range(n_pts):
            e = x[j] - mu
            m2 += e * e if cb[j] == 1.0 else 0.0
        out[v, 0] = s
        out[v, 1] = mn
        out[v, 2] = mx
        out[v, 3] = m2
    return k


@leaf
def _load_block(FRd, lo, m, FRb):
    """The frame data of points lo..lo+m-1 (rows of FRd (N, rows)) into the rows of the block FRb."""
    rows = FRd.shape[1]
    src = FRd[lo:lo + m]
    for k in range(rows):
        for j in range(m):
            FRb[_u(k * BLK + j)] = src[j, k]


@njit(nogil=True, **_NJIT)
def run_tasks(w, nw, ptype, ct, kind, branch, L, F, FR, N, want, flags, codes, part, cnt, keep, sel, buf):
    """Tasks w, w + nw, ... of the D ceil(N / CHUNK) tasks (CHUNK points of one
    design each): their reach codes into codes (D, N) (int8), each task's
    (sum, min, max, centred sum of squares) per wanted value into part (D,
    nch, NVAL, 4) and its count of code-1 points into cnt (D, nch); keep (D,
    NVAL, N) receives every point's wanted values too, or is empty (0, 0, 0).
    Releases the GIL: the caller's threads run disjoint sets of tasks.

    ct (n,): the pose-column kinds; kind, branch (n,); L (D, n, NL), F (D, NF);
    FR (1 or D, N, FR_ROWS[ptype]): the frame data of the N points; want
    (NVAL,) booleans; flags (6,) booleans: dynamic, sigma_min, sigma_max,
    column norms, rods, rotations; sel: None (the generic routines) or the
    selector of the shape's generated ones (see inverse_sel)."""
    n = kind.shape[0]
    D = L.shape[0]
    nch = (N + CHUNK - 1) // CHUNK
    ntask = D * nch
    if n < 1 or n > NMAX or w >= ntask:
        return
    scratch, FRb, vals, cbuf = _carve(buf[w], n)
    per_design = FR.shape[0] > 1
    for t in range(w, ntask, nw):
        d = t // nch
        c = t % nch
        lo = c * CHUNK
        n_pts = min(lo + CHUNK, N) - lo
        FRd = FR[d] if per_design else FR[0]
        for b in range(0, n_pts, BLK):
            m = min(BLK, n_pts - b)
            _load_block(FRd, lo + b, m, FRb)
            _block(ptype, ct, kind, branch, L, F, d, FRb, m, want, flags, scratch, vals[b:], cbuf[b:], sel)
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


@njit(nogil=True, **_NJIT)
def zoom(ptype, ct, kind, branch, L, F, base, axes, lo, width, disc, u, val, h, live, budget, done, bail, grid,
         stop, tol, vid, fac, want, flags, sel, buf):
    """The zoom search of optdesign.worstcase.search._zoom on a translation
    pose, every level in here: for each start m (design m of L, F; its pose
    base[m], free axes ``axes`` at lo + u width), while it is live and has
    levels left (budget[m]): the neighbours u + h grid[g] (clipped to the unit
    box, the first two axes onto the disc where ``disc``), the value vid
    (times fac) of each (inf where unreachable or not finite), the best if it
    gains (else h halves), live while val < stop and h >= tol; the same
    operations, in the same order, as the numpy search.  A start that meets a
    point the kernel leaves to the numpy path (code 2) stops before that
    level with bail[m] set (the caller goes on from its state); done[m]: its
    levels.  In place on u, val, h, live, done, bail."""
    n = kind.shape[0]
    G = grid.shape[0]
    f = grid.shape[1]
    M = u.shape[0]
    dof = base.shape[1]
    if n < 1 or n > NMAX or G > BLK:
        return
    scratch, FRb, vals, cbuf = _carve(buf[0], n)
    P = np.empty((G, f))
    v = np.empty(G)
    for mm in range(M):
        done[mm] = 0
        bail[mm] = False
        for it in range(budget[mm]):
            if not live[mm]:
                break
            for g in range(G):
                for a in range(f):
                    x = u[mm, a] + h[mm] * grid[g, a]
                    P[g, a] = 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)
                if disc:
                    d0 = P[g, 0] - 0.5
                    d1 = P[g, 1] - 0.5
                    nn = math.sqrt(d0 * d0 + d1 * d1)
                    sc = 0.5 / max(nn, 1e-300) if nn > 0.5 else 1.0
                    P[g, 0] = 0.5 + d0 * sc
                    P[g, 1] = 0.5 + d1 * sc
                for k in range(dof):
                    FRb[_u(k * BLK + g)] = base[mm, k]
                for a in range(f):
                    FRb[_u(axes[a] * BLK + g)] = lo[a] + P[g, a] * width[a]
            _block(ptype, ct, kind, branch, L, F, mm, FRb, G, want, flags, scratch, vals, cbuf, sel)
            stopped = False
            for g in range(G):
                if cbuf[g] == 2.0:
                    stopped = True
                    break
                x = vals[vid * CHUNK + g] * fac if fac != 1.0 else vals[vid * CHUNK + g]
                ok = cbuf[g] == 1.0 and (x < np.inf and x > -np.inf)
                v[g] = x if ok else np.inf
            if stopped:
                bail[mm] = True
                break
            j = 0
            best = v[0]
            for g in range(1, G):
                if v[g] > best:
                    best = v[g]
                    j = g
            if best > val[mm]:
                for a in range(f):
                    u[mm, a] = P[j, a]
                val[mm] = best
            else:
                h[mm] = 0.5 * h[mm]
            live[mm] = live[mm] and (val[mm] < stop) and (h[mm] >= tol)
            done[mm] = it + 1


@njit(**_NJIT)
def combine(part, cnt, want):
    """Per-design statistics (D, NVAL, 4: sum, min, max, centred sum of squares)
    over the points of code 1 and their counts (D,), from the tasks' parts in
    chunk order."""
    D, nch = cnt.shape
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
            s, mn, mx, m2 = chunk_moments(part, cnt, d, v, k, nch)
            stats[d, v, 0] = s
            stats[d, v, 1] = mn
            stats[d, v, 2] = mx
            stats[d, v, 3] = m2
    return stats, counts


@njit(**_NJIT)
def mass_blocks(ptype, ct, kind, branch, L, F, FRg, bd, sel):
    """The pose-space mass matrices M_p (blocks, n n BLK; row-major entries,
    rows of BLK) at the points of FRg (blocks BLK, rows), block b (its BLK
    points) of design bd[b]: for the points the kernel leaves to the numpy
    path, whose J that path computes itself (bitwise its own) while M_p enters
    the dynamic index through J^-T M_p, insensitive to its round-off."""
    n = kind.shape[0]
    nb = FRg.shape[0] // BLK
    out = np.zeros((nb, n * n * BLK))
    rods = False
    for i in range(n):
        rods = rods or kind[i] != 2
    (Lg, mats, B, T, V, S), FRb, _, _ = _alloc(n)
    J = mats[0]
    Kp = mats[2]
    for b in range(nb):
        d = bd[b]
        _load_block(FRg, b * BLK, BLK, FRb)
        for j in range(BLK):
            V[VOK * BLK + j] = 1.0
        legs(L, F, d, ptype, kind, branch, FRb, BLK, Lg, V, True, ptype != 0)
        pose_rows(Lg, GG, ct, FRb, BLK, J, n)
        if rods:
            pose_rows(Lg, GK, ct, FRb, BLK, Kp, n)
        rigid(ptype, F, d, FRb, BLK, Lg, B, n, ptype != 0)
        dyn_sel(B, Lg, J, Kp, FRb, mats[1], out[b], S, n, ct, rods, BLK, True, sel)
    return out


# ---------------------------------------------------------------------- the dense routines on stacks (tests)
@njit(**_NJIT)
def gram_lambda_max_stack(X, rows, sel):
    """lambda_max of X^T X (rows False) or of X X^T (rows True; X upper
    triangular for n >= 4, as the inverse leaves it) for each X of the stack
    (K, n, n), by the kernel's own routines."""
    K = X.shape[0]
    n = X.shape[1]
    out = np.empty(K)
    G = np.empty(n * n * BLK)
    T = np.empty(2 * n * BLK)
    V = np.empty((NVS + 3 * n) * BLK)
    S = np.zeros(SROWS * BLK)
    lam = np.empty(BLK)
    for b in range(0, K, BLK):
        m = min(BLK, K - b)
        for j in range(m):
            for r in range(n):
                for c in range(n):
                    G[(r * n + c) * BLK + j] = X[b + j, r, c]
            V[VMASK * BLK + j] = 1.0
        if rows:
            lmax_sel(G, lam, T, V, S, n, m, ROWS, NEWTON, sel)
        else:
            lmax_sel(G, lam, T, V, S, n, m, COLS, NEWTON, sel)
        for j in range(m):
            out[b + j] = lam[j]
    return out


@njit(**_NJIT)
def inverse_stack(A, sel):
    """(|det|, ||A^-1||_F^2, U) of each square matrix of the stack A (K, n, n)
    by the kernel's inverse (U = A^-1 for n <= 3, R^-1 of A = QR for n >= 4)."""
    K = A.shape[0]
    n = A.shape[1]
    det = np.empty(K)
    i2 = np.empty(K)
    Ui = np.empty((K, n, n))
    Rq = np.empty(n * n * BLK)
    U = np.zeros(n * n * BLK)
    V = np.empty((NVS + 3 * n) * BLK)
    S = np.zeros(SROWS * BLK)
    for b in range(0, K, BLK):
        m = min(BLK, K - b)
        for j in range(m):
            for r in range(n):
                for c in range(n):
                    Rq[(r * n + c) * BLK + j] = A[b + j, r, c]
        inverse_sel(Rq, U, V, S, n, m, sel)
        for j in range(m):
            det[b + j] = V[VDET * BLK + j]
            i2[b + j] = V[VI2 * BLK + j]
            for r in range(n):
                for c in range(n):
                    Ui[b + j, r, c] = U[(r * n + c) * BLK + j]
    return det, i2, Ui


@njit(**_NJIT)
def dyn_stack(B, Lg, J, Kp, FRb, U, ct, rods, mass_only, sel):
    """dyn on one block of BLK points (the arrays as the kernel holds them; for tests)."""
    n = ct.shape[0]
    W = np.zeros(n * n * BLK)
    S = np.zeros(SROWS * BLK)
    dyn_sel(B, Lg, J, Kp, FRb, U, W, S, n, ct, rods, BLK, mass_only, sel)
    return W
