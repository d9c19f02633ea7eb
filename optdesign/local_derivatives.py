"""The derivative of a local index from its matrix and the matrix's
derivative, vectorized over poses and designs: the ``derivative`` entries of
the table :data:`optdesign.formulas.VALUES` (simple singular values, cond_F
through the inverse, the Gram determinant), beside the values they
differentiate; matrices that are non-finite or exactly singular give NaN,
never a LinAlgError.  Plain numpy: the bottom of the flow, used by
:mod:`optdesign.gradients`."""
from __future__ import annotations

from .formulas import select, solve

__all__ = ["local_derivative", "solve"]


def local_derivative(kind: str, convention: str | None, options: dict, J, dJ, M=None, dM=None):
    """(value, derivative) of a local index from its matrix and the matrix's
    derivative: J (..., n_act, dof), dJ (..., n_act, dof, n_free), likewise M
    and dM for the dynamic index.  Closed forms (simple singular values):
    d sigma_k = u_k^T dA v_k; cond_F from the Frobenius norms of A and A^-1;
    d sqrt(det G) = sqrt(det G) <G^-1 J, dJ> for G = J J^T (and J H^-1 for
    H = J^T J)."""
    row, c, a = select(kind, convention, options or {}, None if J is None else J.shape[-1])
    return row.derivative(M, dM, c, a) if row.needs == "M" else row.derivative(J, dJ, c, a)
