"""The 3-P(4S)'s compiled path: numba kernels with the numpy model as fallback.

* :func:`global_statistics` answers the mechanism seam (``P4S.global_statistics``):
  per design, inverse kinematics, Jacobian, mass matrix, the local dynamic,
  stiffness and isotropy indices and the reachable mask in one parallel pass
  (:mod:`.kernels`), reduced to mean, min, max and standard deviation over the
  reachable points (see ``docs/performance.md``);
* :func:`local_values` answers ``P4S.local_values`` (the per-point values of
  the same kernel, for weighted quadratures), :func:`local_values_at`
  ``P4S.local_values_at`` (each design at its own points: the worst-case
  search over W);
* :func:`inverse` and :func:`jacobian` (:mod:`.ik_kernels`) and
  :func:`forward` (:mod:`.fk_kernels`) back the public methods of
  :class:`~.model.P4S`.

Each kernel module loads lazily and independently; every function returns
``None`` (and the caller runs the numpy model) when the fast path is switched
off (``OPTDESIGN_FAST=0``, :func:`optdesign.fast.set_enabled`), numba cannot
be imported, a kernel fails to compile, or the request is outside what the
kernels compute (indices other than ``dynamic``, ``stiffness``
(``lambda_min_K``, ``sqrt_lambda_min_K``) and ``isotropy`` (``frobenius``,
``two_norm``), options other than a positive ``k``, designs not of shape
``()``, ``(D,)`` or ``(D, 1)``).

Results equal the numpy path's to 1e-12 relative (typically 1e-14: closed-form
eigenvalues against LAPACK; points with cond(J) >= 1000 are handed to the
numpy path), the reachable mask bitwise, and do not depend on the number of
threads.  Inverse kinematics and the Jacobian are bitwise the numpy model's
(the same operations in the same order).
"""
from __future__ import annotations

import math

import numpy as np

from ...fast import KernelModule, enabled
from ...fast.merge import add_points
from ...formulas import DYN, FRO, SMIN, SMIN2, TWO, VALUES, Operands, kernel_value, singular_values
from .dynamics import mass_coefficients, platform_mass, solve_T

__all__ = ["LOCAL", "FK", "IK", "VALUE_NAMES", "SUPPORTED", "design_constants", "p4s_local", "p4s_summary",
           "global_statistics", "local_values", "local_values_at", "p4s_pairs", "plan", "forward", "inverse", "jacobian"]

LOCAL = KernelModule("optdesign.mechanisms.p4s.kernels")
FK = KernelModule("optdesign.mechanisms.p4s.fk_kernels")
IK = KernelModule("optdesign.mechanisms.p4s.ik_kernels")

#: index kinds and conventions the fused kernel computes (None: the default convention)
SUPPORTED = {
    "dynamic": (None,),
    "stiffness": (None, "lambda_min_K", "sqrt_lambda_min_K"),
    "isotropy": (None, "frobenius", "two_norm"),
}
#: the ids of optdesign.formulas the fused kernel computes: its value rows 0..4
IDS = (DYN, SMIN2, SMIN, FRO, TWO)
assert IDS == tuple(range(len(IDS)))
#: their names (the keys of p4s_local's values)
VALUE_NAMES = tuple(next(v.name for v in VALUES.values() if v.id == i) for i in IDS)


# ---------------------------------------------------------------------- inputs
def _n_designs(mech) -> int | None:
    """D for design parameters of shape (), (D,) or (D, 1); None otherwise."""
    shape = mech.design_shape
    if len(shape) > 2 or (len(shape) == 2 and shape[1] != 1):
        return None
    return int(np.prod(shape)) if len(shape) else 1


def design_constants(mech) -> np.ndarray:
    """Per-design constants (D, 15) of a P4S whose parameters are scalars, (D,)
    or (D, 1): ``rho - r_b``, L, L^2, the mass-matrix coefficients c0, alpha,
    beta (:func:`.model.mass_coefficients`) and the nine components of the rail
    directions m_i (the numpy model's own expressions, so that inverse
    kinematics agrees bitwise)."""
    shape = mech.design_shape
    D = _n_designs(mech)
    if D is None:
        raise ValueError(f"design parameters of shape {shape}: expected (D,) or (D, 1)")
    rho = np.asarray(mech.rho, dtype=float)
    off = np.broadcast_to(rho - np.asarray(mech.r_b, dtype=float), shape).reshape(D)
    L = np.broadcast_to(np.asarray(mech.L, dtype=float), shape).reshape(D)
    m = np.broadcast_to(mech.rail_directions(), shape + (3, 3)).reshape(D, 9)
    c0, alpha, beta = (np.broadcast_to(c, shape).reshape(D) for c in mass_coefficients(mech))
    P = np.empty((D, 15))
    P[:, 0] = off
    P[:, 1] = L
    P[:, 2] = L ** 2
    P[:, 3] = c0
    P[:, 4] = alpha
    P[:, 5] = beta
    P[:, 6:15] = m
    return np.ascontiguousarray(P)


def _points(X) -> np.ndarray:
    """X as a C-contiguous float (N, 3) array (no copy when it already is one)."""
    X = np.ascontiguousarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"expected points (N, 3), got shape {X.shape}")
    return X


# ---------------------------------------------------------------------- local indices
def _lapack_values(mech, X, dd, jj, want) -> np.ndarray:
    """The numpy path's local values (5, K) at the pairs (design dd[i], point
    jj[i]): the ill-conditioned points the kernel leaves to LAPACK."""
    shape = mech.design_shape
    D = _n_designs(mech)
    params = {k: np.broadcast_to(np.asarray(v, dtype=float), shape).reshape(D)[dd] for k, v in mech.params.items()}
    m = type(mech)(**params)
    Xk = np.asarray(X, dtype=float)[jj]
    K = len(dd)
    out = np.full((5, K), np.nan)
    with np.errstate(all="ignore"):
        # the numpy model's own operations, with the branch state computed once
        # and one SVD call for the stack [J; M] (each matrix's singular values
        # do not depend on the stack it is in); the values: the rows of
        # optdesign.formulas.VALUES with c = 1 (k = 1)
        st = m.branch_state(Xk)
        J = st["n"] / st["s"][..., None]
        if want[DYN]:
            sv, good = singular_values(np.concatenate([J, solve_T(J, platform_mass(m, st))]))
            ops = Operands(J=J, svJ=(sv[:K], good[:K]), svM=(sv[K:], good[K:]))
        else:
            ops = Operands(J=J)
        for i in IDS:
            if want[i]:
                out[i] = VALUES[VALUE_NAMES[i]].value(ops, 1.0, 0)
    return out


def p4s_local(mech, X, two_norm: bool = True) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Local values at points X (N, 3) of the designs of ``mech`` with the fused
    kernel: ``({"dynamic", "sigma_min_sq", "sigma_min", "cond_fro", "cond_2"}: (D, N)),
    reachable (D, N))``, NaN where not reachable; ill-conditioned points come
    from the numpy path.  Raises RuntimeError if the kernels are not available."""
    k = LOCAL.require()
    vals, codes = k.p4s_local(design_constants(mech), _points(X), bool(two_norm))
    reach = codes != 0
    vals = np.where(reach[None], vals, np.nan)
    dd, jj = np.nonzero(codes == 2)
    if len(dd):
        vals[:, dd, jj] = _lapack_values(mech, X, dd, jj, (True, True, True, True, two_norm))
    out = {n: vals[i] for i, n in enumerate(VALUE_NAMES)}
    if not two_norm:
        del out["cond_2"]
    return out, reach


def _merge(stats, counts, extra, dd, want):
    """Add the values extra (5, K) of designs dd (K,) to the kernel's per-design
    (sum, min, max, centred sum of squares) (5, 4, D) and counts (D,)."""
    stats = stats.copy()
    for v in range(5):
        if want[v]:
            stats[v] = add_points(stats[v], counts, extra[v], dd)
    return stats, counts + np.bincount(dd, minlength=counts.shape[0])


def p4s_summary(mech, X, want=(True, True, True, True, True)):
    """Per-design statistics over the reachable points: (stats (5, 4, D) with
    mean/min/max/std of dynamic, sigma_min^2, sigma_min, cond_fro, cond_2 (NaN
    for values not wanted and for designs without a reachable point); counts
    (D,); reachable (D, N)).  Points the kernel flags as ill-conditioned are
    evaluated with the numpy path and merged in."""
    k = LOCAL.require()
    w = np.array([bool(v) for v in want], dtype=np.bool_)
    sums, counts, codes, nhard = k.p4s_summary(design_constants(mech), _points(X), w, bool(w[4]))
    if nhard.any():
        rows = np.flatnonzero(nhard)
        r, jj = np.nonzero(codes[rows] == 2)
        dd = rows[r]
        sums, counts = _merge(sums, counts, _lapack_values(mech, X, dd, jj, w), dd, w)
    out = np.full_like(sums, np.nan)
    ok = counts > 0
    with np.errstate(all="ignore"):
        mean = sums[:, 0] / counts
        out[:, 0] = np.where(ok, mean, np.nan)
        out[:, 1] = np.where(ok, sums[:, 1], np.nan)
        out[:, 2] = np.where(ok, sums[:, 2], np.nan)
        out[:, 3] = np.where(ok & np.isfinite(mean), np.sqrt(sums[:, 3] / counts), np.nan)
    out[~w] = np.nan
    return out, counts, codes != 0


def plan(requests):
    """[(name, kernel row, factor)] for the requested indices the kernel
    computes (the others are left out: the caller computes them with the numpy
    path): the ids and factors of optdesign.formulas.kernel_value."""
    out = []
    for req in requests:
        if req.kind not in SUPPORTED or req.convention not in SUPPORTED[req.kind]:
            continue
        kv = kernel_value(req.kind, req.convention, req.options, 3)
        if kv is not None and kv[0] in IDS:
            out.append((req.name,) + kv)
    return out


def global_statistics(mech, requests, X):
    """The seam's answer from the fused kernel (see ``Mechanism.global_statistics``),
    or None when it does not apply."""
    if not enabled():
        return None
    rows = plan(requests)
    if not rows or _n_designs(mech) is None:
        return None
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != 3 or LOCAL.get() is None:
        return None
    want = [False] * 5
    for _, row, _ in rows:
        want[row] = True
    res = LOCAL.guarded(p4s_summary, mech, X, want)
    if res is None:
        return None
    stats, counts, reach = res
    summary = {}
    for n, row, fac in rows:
        st = stats[row]
        if fac != 1.0:
            st = st * fac
        summary[n] = {"mean": st[0], "min": st[1], "max": st[2], "std": st[3], "count": counts}
    return summary, reach


def local_values(mech, requests, X):
    """The local-values seam's answer from the fused kernel (see
    ``Mechanism.local_values``), or None when it does not apply."""
    if not enabled():
        return None
    rows = plan(requests)
    if rows is None or _n_designs(mech) is None:
        return None
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != 3 or LOCAL.get() is None:
        return None
    res = LOCAL.guarded(p4s_local, mech, X, any(row == 4 for _, row, _ in rows))
    if res is None:
        return None
    vals, reach = res
    out = {}
    for n, row, fac in rows:
        v = vals[VALUE_NAMES[row]]
        out[n] = v * fac if fac != 1.0 else v
    return out, reach


def _once(mech, key, func):
    """``func(mech)``, kept on the mechanism (its parameters do not change):
    the worst-case search calls :func:`local_values_at` once per level."""
    memo = mech.__dict__.setdefault("_compiled_memo", {})
    if key not in memo:
        memo[key] = func(mech)
    return memo[key]


def p4s_pairs(mech, X, two_norm: bool = True) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Local values of each design d of ``mech`` at its own points X[d]
    (D, K, 3), as :func:`p4s_local` (dict of (D, K), reachable (D, K))."""
    k = LOCAL.require()
    X = np.ascontiguousarray(X, dtype=float)
    D, K = X.shape[:2]
    vals, codes = k.p4s_pairs(_once(mech, "constants", design_constants), X, bool(two_norm))
    reach = codes != 0
    vals = np.where(reach[None], vals, np.nan)
    dd, kk = np.nonzero(codes == 2)
    if len(dd):
        vals[:, dd, kk] = _lapack_values(mech, X.reshape(D * K, 3), dd, dd * K + kk,
                                         (True, True, True, True, two_norm))
    out = {n: vals[i] for i, n in enumerate(VALUE_NAMES)}
    if not two_norm:
        del out["cond_2"]
    return out, reach


def local_values_at(mech, requests, X):
    """The seam ``Mechanism.local_values_at`` from the fused kernel: each
    design at its own points X (D, K, 3), or None when it does not apply."""
    if not enabled():
        return None
    rows = plan(requests)
    D = _once(mech, "count", _n_designs)
    X = np.asarray(X, dtype=float)
    if not rows or D is None or X.ndim != 3 or X.shape[0] != D or X.shape[2] != 3 or LOCAL.get() is None:
        return None
    res = LOCAL.guarded(p4s_pairs, mech, X, any(row == 4 for _, row, _ in rows))
    if res is None:
        return None
    vals, reach = res
    return {n: vals[VALUE_NAMES[row]] * fac if fac != 1.0 else vals[VALUE_NAMES[row]] for n, row, fac in rows}, reach


# ---------------------------------------------------------------------- kinematics
def forward(mech, Q, out=None):
    """Forward kinematics of one design (scalar parameters) for strokes Q (N, 3)
    with the compiled kernel (the numpy model's assembly mode), or None when the
    kernel does not apply.  ``out``: an optional C-contiguous float (N, 3) array
    to write into (and return)."""
    Q = np.asarray(Q, dtype=float)
    if not enabled() or mech.design_shape != () or Q.ndim != 2 or Q.shape[1] != 3 or FK.get() is None:
        return None
    c, s = math.cos(float(mech.phi)), math.sin(float(mech.phi))
    F = np.array([float(mech.r_b - mech.rho), c, s, float(mech.L) ** 2, float(mech.L)])
    Q = np.ascontiguousarray(Q)
    if out is None:
        out = np.empty(Q.shape)
    elif (out.shape != Q.shape or out.dtype != np.float64 or not out.flags.c_contiguous
          or not out.flags.writeable):
        raise ValueError(f"out must be a writeable C-contiguous float64 array of shape {Q.shape}")
    return FK.guarded(FK.get().p4s_forward, F, Q, out)


def _ik_inputs(mech, X):
    X = np.asarray(X, dtype=float)
    shape = mech.design_shape
    if not enabled() or not (shape == () or (len(shape) == 2 and shape[1] == 1)):
        return None
    if X.ndim != 2 or X.shape[1] != 3 or IK.get() is None:
        return None
    D = _n_designs(mech)
    m = np.broadcast_to(mech.rail_directions(), shape + (3, 3)).reshape(D, 9)
    off = np.broadcast_to(np.asarray(mech.rho, float) - np.asarray(mech.r_b, float), shape).reshape(D)
    L = np.broadcast_to(np.asarray(mech.L, float), shape).reshape(D)
    P = np.ascontiguousarray(np.concatenate([off[:, None], L[:, None], m], axis=1))
    return P, np.ascontiguousarray(X)


def _shaped(mech, A):
    """Kernel output (D, N, ...) to the numpy model's shape: (N, ...) for one design."""
    return A[0] if mech.design_shape == () else A


def inverse(mech, X):
    """Strokes (N, 3) or (D, N, 3) from the compiled kernel, bitwise the numpy
    model's; None when the kernel does not apply."""
    inp = _ik_inputs(mech, X)
    if inp is None:
        return None
    res = IK.guarded(IK.get().p4s_inverse, *inp)
    return None if res is None else _shaped(mech, res)


def jacobian(mech, X):
    """J (N, 3, 3) or (D, N, 3, 3) from the compiled kernel, bitwise the numpy
    model's; None when the kernel does not apply."""
    inp = _ik_inputs(mech, X)
    if inp is None:
        return None
    res = IK.guarded(IK.get().p4s_jacobian, *inp)
    return None if res is None else _shaped(mech, res)


def bare_kernel(mech, X):
    """(a call of the fused kernel alone for the indices dynamic, stiffness and
    Frobenius isotropy, the share of points it leaves to LAPACK): for
    ``optdesign bench``."""
    k = LOCAL.require()
    P = design_constants(mech)
    Xc = _points(X)
    want = np.array([True, True, False, True, False])
    codes = k.p4s_summary(P, Xc, want, False)[2]
    return (lambda: k.p4s_summary(P, Xc, want, False)), float(np.mean(codes == 2))
