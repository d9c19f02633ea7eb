"""Compiled (numba) kernels for the hot paths, with the numpy path as fallback.

The fused 3-P(4S) kernel computes, per design and workspace point, inverse
kinematics, Jacobian, mass matrix, the local dynamic, stiffness and isotropy
indices and the reachable mask, and reduces them to the per-design mean, min,
max and standard deviation over the reachable points, all in one parallel
pass (see ``docs/performance.md``).

:func:`optdesign.evaluate.evaluate` calls :func:`try_evaluate`; it returns
``None`` (and the caller keeps the numpy path) when

* the environment variable ``OPTDESIGN_FAST`` is ``0`` (or ``false``/``off``/``no``)
  or :func:`set_enabled` turned the fast path off,
* numba cannot be imported or the kernels cannot be compiled,
* the mechanism is not the 3-P(4S), or an index is not one of ``dynamic``,
  ``stiffness`` (``lambda_min_K``, ``sqrt_lambda_min_K``) and ``isotropy``
  (``frobenius``, ``two_norm``), or an index option other than a positive ``k``
  is set.

Results equal the numpy path's to 1e-12 relative (typically 1e-14: closed-form
eigenvalues against LAPACK; the kernel hands the points with cond(J) >= 1000 to
the numpy path), the reachable mask bitwise, and do not depend on the number
of threads.  ``forward_p4s`` is the compiled forward kinematics of one design
(its kernels are a module of their own, :func:`fk_kernels`, with its own numba
cache and the same fallback: :meth:`P4S.forward`).
"""
from __future__ import annotations

import math
import os
import warnings
from contextlib import contextmanager

import numpy as np

__all__ = ["ENV_VAR", "enabled", "set_enabled", "disabled", "available", "kernels", "import_error",
           "design_constants", "p4s_local", "p4s_summary", "fk_kernels", "forward_p4s", "try_evaluate",
           "SUPPORTED", "VALUE_NAMES"]

ENV_VAR = "OPTDESIGN_FAST"

#: index kinds and conventions the fused kernel computes (None: the default convention)
SUPPORTED = {
    "dynamic": (None,),
    "stiffness": (None, "lambda_min_K", "sqrt_lambda_min_K"),
    "isotropy": (None, "frobenius", "two_norm"),
}

_override: bool | None = None
_kernels = None
_import_error: BaseException | None = None
_fk_mod = None
_fk_error: BaseException | None = None


def enabled() -> bool:
    """Whether the fast path may be used (``set_enabled`` first, then ``OPTDESIGN_FAST``)."""
    if _override is not None:
        return _override
    return os.environ.get(ENV_VAR, "1").strip().lower() not in ("0", "false", "off", "no")


def set_enabled(value: bool | None) -> None:
    """Force the fast path on or off for this process; ``None`` returns to the environment variable."""
    global _override
    _override = value


@contextmanager
def disabled():
    """Context manager: the numpy path inside the block."""
    global _override
    old = _override
    _override = False
    try:
        yield
    finally:
        _override = old


def _passive_workers() -> None:
    # idle OpenMP workers must sleep, not spin: the optimizer alternates
    # kernel calls with numpy (OpenBLAS) work, and on a 2-core machine
    # spinning workers slow both down by two orders of magnitude
    # (docs/performance.md).  Read by libgomp when numba first loads it.
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def kernels():
    """The compiled kernel module, or None if numba is not usable here."""
    global _kernels, _import_error
    if _kernels is None and _import_error is None:
        _passive_workers()
        try:
            from . import _p4s_kernels as k
            _kernels = k
        except Exception as exc:  # numba missing or broken: numpy path
            _import_error = exc
    return _kernels


def fk_kernels():
    """The compiled forward-kinematics module (:mod:`._fk_kernels`), or None if
    numba is not usable here (independent of :func:`kernels`: either module may
    fail alone, e.g. at compile time)."""
    global _fk_mod, _fk_error
    if _fk_mod is None and _fk_error is None:
        _passive_workers()
        try:
            from . import _fk_kernels as k
            _fk_mod = k
        except Exception as exc:  # numba missing or broken: P4S.forward
            _fk_error = exc
    return _fk_mod


def available() -> bool:
    return kernels() is not None


def import_error() -> BaseException | None:
    """Why the kernels are not available (None if they are, or were not tried)."""
    return _import_error


# ---------------------------------------------------------------------- 3-P(4S)
def design_constants(mech) -> np.ndarray:
    """Per-design constants (D, 15) of a P4S whose parameters are scalars, (D,)
    or (D, 1): ``rho - r_b``, L, L^2, the mass-matrix coefficients c0, alpha,
    beta and the nine components of the rail directions m_i (computed with the
    numpy path's own expressions, so that inverse kinematics agrees bitwise)."""
    shape = mech.design_shape
    D = int(np.prod(shape)) if len(shape) else 1
    if len(shape) == 2 and shape[1] != 1:
        raise ValueError(f"design parameters of shape {shape}: expected (D,) or (D, 1)")
    rho = np.asarray(mech.rho, dtype=float)
    off = np.broadcast_to(rho - np.asarray(mech.r_b, dtype=float), shape).reshape(D)
    L = np.broadcast_to(np.asarray(mech.L, dtype=float), shape).reshape(D)
    m = np.broadcast_to(mech.rail_directions(), shape + (3, 3)).reshape(D, 9)

    def f(name):
        return np.broadcast_to(np.asarray(getattr(mech, name), dtype=float), shape).reshape(D)

    rods = f("rods_per_branch") * f("m_rod")
    irod = f("rods_per_branch") * f("rod_Ixx")
    mr4 = rods / 4.0
    il2 = irod / (L * L)
    P = np.empty((D, 15))
    P[:, 0] = off
    P[:, 1] = L
    P[:, 2] = L ** 2
    P[:, 3] = f("m_platform") + 3.0 * (mr4 + il2)
    P[:, 4] = f("m_slider") + mr4 + il2
    P[:, 5] = mr4 - il2
    P[:, 6:15] = m
    return np.ascontiguousarray(P)


def _points(X) -> np.ndarray:
    """X as a C-contiguous float (N, 3) array (no copy when it already is one:
    the kernels read it in chunks, no transposed copy per call)."""
    X = np.ascontiguousarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"expected points (N, 3), got shape {X.shape}")
    return X


VALUE_NAMES = ("dynamic", "sigma_min_sq", "sigma_min", "cond_fro", "cond_2")


def _lapack_values(mech, X, dd, jj, want) -> np.ndarray:
    """The numpy path's local values (5, K) at the pairs (design dd[i], point
    jj[i]): the ill-conditioned points the kernel leaves to LAPACK."""
    from ..indices import cond_2_of, cond_fro_of, sigma_max_of, sigma_min_of, singular_values
    from ..mechanisms.p4s import _platform_mass, _solve_T

    shape = mech.design_shape
    D = int(np.prod(shape)) if len(shape) else 1
    params = {k: np.broadcast_to(np.asarray(v, dtype=float), shape).reshape(D)[dd] for k, v in mech.params.items()}
    m = type(mech)(**params)
    Xk = np.asarray(X, dtype=float)[jj]
    K = len(dd)
    out = np.full((5, K), np.nan)
    with np.errstate(all="ignore"):
        # the numpy path's own operations (P4S.jacobian, P4S.mass_matrix and the
        # index functions), with the branch state computed once and one SVD
        # call for the stack [J; M] (each matrix's singular values do not
        # depend on the stack it is in)
        st = m.branch_state(Xk)
        J = st["n"] / st["s"][..., None]
        if want[0]:
            sv, good = singular_values(np.concatenate([J, _solve_T(J, _platform_mass(m, st))]))
            sJ, gJ, sM, gM = sv[:K], good[:K], sv[K:], good[K:]
            out[0] = sigma_max_of(sM, gM)
        else:
            sJ, gJ = singular_values(J)
        if want[1] or want[2]:
            out[2] = sigma_min_of(sJ, gJ)   # the numpy path's sqrt(k) s with k = 1 (exactly s)
            out[1] = out[2] * out[2]        # and its k * s * s
        if want[3]:
            out[3] = cond_fro_of(sJ, gJ, J.shape)
        if want[4]:
            out[4] = cond_2_of(sJ, gJ, J.shape)
    return out


def p4s_local(mech, X, two_norm: bool = True) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Local values at points X (N, 3) of the designs of ``mech`` with the fused
    kernel: ``({"dynamic", "sigma_min_sq", "sigma_min", "cond_fro", "cond_2"}: (D, N)),
    reachable (D, N))``, NaN where not reachable; ill-conditioned points come
    from the numpy path.  Raises RuntimeError if the kernels are not available."""
    k = kernels()
    if k is None:
        raise RuntimeError(f"compiled kernels not available: {_import_error}")
    P = design_constants(mech)
    vals, codes = k.p4s_local(P, _points(X), bool(two_norm))
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
    D = counts.shape[0]
    nb = np.bincount(dd, minlength=D)
    n = counts + nb
    has_a, has_b = counts > 0, nb > 0
    stats = stats.copy()
    with np.errstate(all="ignore"):
        for v in range(5):
            if not want[v]:
                continue
            x = extra[v]
            sb = np.bincount(dd, weights=x, minlength=D)
            mb = sb / nb
            m2b = np.bincount(dd, weights=(x - mb[dd]) ** 2, minlength=D)
            lob = np.full(D, np.inf)
            np.minimum.at(lob, dd, x)
            hib = np.full(D, -np.inf)
            np.maximum.at(hib, dd, x)
            sa, loa, hia, m2a = stats[v]
            delta = mb - sa / counts
            both = has_a & has_b
            stats[v, 0] = np.where(both, sa + sb, np.where(has_b, sb, sa))
            stats[v, 1] = np.where(both, np.minimum(loa, lob), np.where(has_b, lob, loa))
            stats[v, 2] = np.where(both, np.maximum(hia, hib), np.where(has_b, hib, hia))
            stats[v, 3] = np.where(both, m2a + m2b + delta * delta * counts * nb / n, np.where(has_b, m2b, m2a))
    return stats, n


def p4s_summary(mech, X, want=(True, True, True, True, True)):
    """Per-design statistics over the reachable points: (stats (5, 4, D) with
    mean/min/max/std of dynamic, sigma_min^2, sigma_min, cond_fro, cond_2 (NaN
    for values not wanted and for designs without a reachable point); counts
    (D,); reachable (D, N)).  Points the kernel flags as ill-conditioned are
    evaluated with the numpy path and merged in."""
    k = kernels()
    if k is None:
        raise RuntimeError(f"compiled kernels not available: {_import_error}")
    P = design_constants(mech)
    w = np.array([bool(v) for v in want], dtype=np.bool_)
    sums, counts, codes, nhard = k.p4s_summary(P, _points(X), w, bool(w[4]))
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


def _plan(config, names):
    """[(index name, kernel row, factor)] for the requested indices, or None if
    one of them is not supported by the kernel."""
    plan = []
    for n in names:
        spec = config.indices[n]
        conv = spec.convention
        if spec.kind not in SUPPORTED or conv not in SUPPORTED[spec.kind]:
            return None
        opts = dict(spec.options or {})
        kval = opts.pop("k", 1.0)
        if opts:
            return None
        try:
            kval = float(kval)
        except (TypeError, ValueError):
            return None
        if not (math.isfinite(kval) and kval > 0.0):
            return None
        if spec.kind == "dynamic":
            plan.append((n, 0, 1.0))
        elif spec.kind == "stiffness":
            if conv in (None, "lambda_min_K"):
                plan.append((n, 1, kval))
            else:
                plan.append((n, 2, math.sqrt(kval)))
        else:
            plan.append((n, 3 if conv in (None, "frobenius") else 4, 1.0))
    return plan


def try_evaluate(config, mech, X, names):
    """The global summaries ``{name: {mean, min, max, std, count}}`` and the
    reachable mask (D, N) from the fused kernel, or None when the fast path does
    not apply (the caller then uses the numpy path)."""
    if not enabled() or getattr(mech, "name", None) != "p4s" or config.mechanism != "p4s":
        return None
    from ..mechanisms.p4s import P4S

    if type(mech) is not P4S:
        return None
    plan = _plan(config, names)
    if plan is None:
        return None
    if kernels() is None:
        return None
    shape = mech.design_shape
    if len(shape) > 2 or (len(shape) == 2 and shape[1] != 1):
        return None
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] != 3:
        return None
    want = [False] * 5
    for _, row, _ in plan:
        want[row] = True
    try:
        stats, counts, reach = p4s_summary(mech, X, want)
    except Exception as exc:  # a compile failure at first call: numpy path from now on
        cause = exc.__cause__ or exc.__context__
        if isinstance(cause, BaseException) and not isinstance(cause, Exception):
            raise cause from None  # Ctrl-C or a signal inside the kernel is not a compile failure
        global _kernels, _import_error
        _kernels, _import_error = None, exc
        warnings.warn(f"optdesign.fast: compiled kernel failed ({exc}); using the numpy path", RuntimeWarning)
        return None
    summary = {}
    for n, row, fac in plan:
        st = stats[row]
        if fac != 1.0:
            st = st * fac
        summary[n] = {"mean": st[0], "min": st[1], "max": st[2], "std": st[3], "count": counts}
    return summary, reach


def forward_p4s(mech, Q, out=None) -> np.ndarray:
    """Forward kinematics of one design (scalar parameters) for strokes Q (N, 3)
    with the compiled kernel: platform positions (N, 3), NaN where the spheres do
    not meet; same solution (assembly mode above the sphere centres) as
    :meth:`P4S.forward`.  ``out``: an optional C-contiguous float (N, 3) array
    to write into (and return), e.g. reused over calls.  Falls back to
    ``mech.forward`` if numba is unavailable or the kernel fails to compile, the
    design is not a single one, or the fast path is disabled."""
    global _fk_mod, _fk_error
    Q = np.asarray(Q, dtype=float)
    k = fk_kernels() if enabled() else None
    if k is not None and mech.design_shape == () and Q.ndim == 2 and Q.shape[1] == 3:
        c, s = math.cos(float(mech.phi)), math.sin(float(mech.phi))
        F = np.array([float(mech.r_b - mech.rho), c, s, float(mech.L) ** 2, float(mech.L)])
        Q = np.ascontiguousarray(Q)
        if out is None:
            out = np.empty(Q.shape)
        elif (out.shape != Q.shape or out.dtype != np.float64 or not out.flags.c_contiguous
              or not out.flags.writeable):
            raise ValueError(f"out must be a writeable C-contiguous float64 array of shape {Q.shape}")
        try:
            return k.p4s_forward(F, Q, out)
        except Exception as exc:  # a compile failure at first call: P4S.forward from now on
            cause = exc.__cause__ or exc.__context__
            if isinstance(cause, BaseException) and not isinstance(cause, Exception):
                raise cause from None  # Ctrl-C or a signal inside the kernel
            _fk_mod, _fk_error = None, exc
            warnings.warn(f"optdesign.fast: compiled forward kinematics failed ({exc}); using P4S.forward",
                          RuntimeWarning)
    P = mech.forward(Q)
    if out is not None:
        out[...] = P
        return out
    return P
