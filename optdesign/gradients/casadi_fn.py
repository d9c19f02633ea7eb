"""The CasADi function of the AD route (:mod:`optdesign.gradients`): the
closure's Jacobian, its design derivatives and the mass matrix's, built once
per mechanism and free variables (compiled to machine code where the machine
has a C compiler, :mod:`.casadi_c`), and evaluated over many poses as one
mapped call."""
from __future__ import annotations

import numpy as np

from .casadi_c import compiled

__all__ = ["ad_function", "symbolic_function", "arguments", "mapped", "columns", "vec_columns"]

_FUNCTIONS: dict = {}


def ad_function(name: str, builder, free: tuple[str, ...]):
    """The CasADi function (x, q, p) -> J, dJ/dp, dq/dp[, M_p, dM_p/dp] of a
    mechanism for the free parameters ``free`` and its model (cached per
    process; machine code where the machine has a C compiler, the same bits:
    :mod:`.casadi_c`), or None when the model does not read every free
    parameter."""
    key = (name, free)
    if key not in _FUNCTIONS:
        got = symbolic_function(name, builder, free)
        _FUNCTIONS[key] = None if got is None else (compiled(got[0]), got[1])
    return _FUNCTIONS[key]


def symbolic_function(name: str, builder, free: tuple[str, ...]):
    """(the SX function of :func:`ad_function`, the model), built anew and
    evaluated by CasADi's virtual machine, or None."""
    import casadi as ca

    model = builder()
    if not set(free) <= set(model.param_names):
        return None
    x, q = ca.SX.sym("x", model.dof), ca.SX.sym("q", model.n_act)
    syms = {k: ca.SX.sym(k) for k in model.param_names}
    P = ca.vertcat(*[syms[k] for k in model.param_names])
    Pf = ca.vertcat(*[syms[k] for k in free])
    f = model.closure_fn(x, q, syms)
    fq = ca.jacobian(f, q)
    J = -ca.solve(fq, ca.jacobian(f, x))
    dq = -ca.solve(fq, ca.jacobian(f, Pf))

    def total(A):
        v = ca.vec(A)
        return ca.jacobian(v, Pf) + ca.mtimes(ca.jacobian(v, q), dq)

    outs = [J, total(J), dq]
    if model.kinetic_fn is not None:
        xd = ca.SX.sym("xd", model.dof)
        T = model.kinetic_fn(x, q, xd, ca.mtimes(J, xd), syms)
        Mp = ca.substitute(ca.jacobian(ca.gradient(T, xd), xd), xd, ca.DM.zeros(model.dof))
        outs += [Mp, total(Mp)]
    # cse: common subexpressions evaluated once (8 % of the evaluation; the same operations, the same bits)
    return ca.Function(f"design_derivatives_{name}", [x, q, P], outs, {"cse": True}), model


def arguments(X: np.ndarray, Q: np.ndarray, params: dict, names) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The mapped call's inputs (x, q, p), each (rows, D N): the N poses X (N,
    dof) of each of D designs, their actuator coordinates Q (D, N, n_act) (NaN,
    out of reach: 0) and the parameters ``names`` of ``params`` (scalars or
    (D, 1))."""
    D, N = Q.shape[:2]
    n = D * N
    p = np.stack([np.broadcast_to(np.asarray(params[k], dtype=float).reshape(-1, 1), (D, N)).ravel() for k in names])
    x = np.broadcast_to(X, (D, N, X.shape[1])).reshape(n, -1)
    return x.T, np.nan_to_num(Q.reshape(n, -1)).T, p


_MAPS: dict = {}


def mapped(fn, n: int):
    """``fn.map(n)``, built once per function and n (a polish asks for the
    same n, its W's points, thousands of times; building the map cost about
    a tenth of the call).  The last 32 are kept."""
    key = (id(fn), n)
    got = _MAPS.get(key)
    if got is None:
        if len(_MAPS) >= 32:
            _MAPS.pop(next(iter(_MAPS)))
        got = _MAPS[key] = (fn, fn.map(n))      # fn kept: its id stays its own
    return got[1]


def columns(out, rows: int, n: int, cols: int) -> np.ndarray:
    """A mapped CasADi output (rows, n * cols) -> (n, rows, cols)."""
    return np.asarray(out, dtype=float).reshape(rows, n, cols).transpose(1, 0, 2)


def vec_columns(out, rows: int, cols: int, n: int, nf: int) -> np.ndarray:
    """A mapped derivative of vec(A) (A rows x cols): (rows * cols, n * nf) -> (n, rows, cols, nf)."""
    a = np.asarray(out, dtype=float).reshape(rows * cols, n, nf).transpose(1, 0, 2)
    return a.reshape(n, cols, rows, nf).transpose(0, 2, 1, 3)
