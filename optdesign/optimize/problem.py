"""The pymoo Problem: bounds, an evaluation callable and objective terms.

It knows design vectors and objective values, not configs or mechanisms: one
``_evaluate`` call hands the whole population to the evaluation callable
(usually an :class:`optdesign.evaluate.Evaluator`, which evaluates designs ×
workspace points in one pass).  Objectives are built from *objective terms*;
the Evaluator's constraints (``G <= 0`` feasible) are

* ``reach``: the fraction of workspace points the design cannot reach;
* ``singularity``: ``max_W cond(J) / threshold - 1`` (the largest local
  condition number of the Jacobian over W against the config's
  ``singularity_threshold``), so designs whose workspace meets or nears a
  singularity are infeasible rather than dominating the normalization;
* ``finite``: 1 where a global index is not finite (0 otherwise);
* ``stroke_low`` / ``stroke_high``: actuator values outside ``stroke_limits``
  anywhere in W (m), when the config sets them.

Every evaluation's values (indices and extra objectives) are kept in ``out``
(as pymoo "extra" arrays ``index_<name>``) so the history records them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from pymoo.core.problem import Problem

__all__ = ["Term", "DesignProblem", "index_term", "extra_term", "weighted_sum_term"]


@dataclass(frozen=True)
class Term:
    """One objective to minimize, as a function of the global index means.

    kind: ``index`` (``sign * sigma_name``), ``extra`` (a compactness
    objective), or ``weighted`` (the normalized weighted sum of eq. 38-40).
    """

    kind: str
    name: str
    sign: float = 1.0
    lo: dict | None = None        # per index: sigma_min over the bounds (weighted)
    hi: dict | None = None        # per index: sigma_max over the bounds (weighted)
    weights: dict | None = None
    senses: dict | None = None
    literal: bool = False          # the paper's literal eq. 38 (every term as if minimized)

    def label(self) -> str:
        if self.kind == "index":
            return f"{'-' if self.sign < 0 else ''}{self.name}"
        return self.name


def index_term(name: str, sense: str) -> Term:
    """Minimize ``sigma`` (sense min) or ``-sigma`` (sense max)."""
    return Term("index", name, 1.0 if sense == "min" else -1.0)


def extra_term(name: str, sense: str) -> Term:
    return Term("extra", name, 1.0 if sense == "min" else -1.0)


def weighted_sum_term(lo: dict, hi: dict, weights: dict, senses: dict, literal: bool = False) -> Term:
    return Term("weighted", "weighted_sum", 1.0, dict(lo), dict(hi), dict(weights), dict(senses), literal)


def normalized_terms(values: dict, lo: dict, hi: dict, senses: dict, literal: bool = False) -> dict:
    """f_i of eq. 38 for each index: (sigma - sigma_min)/(sigma_max - sigma_min).

    With ``literal=False`` an index to be maximized is flipped,
    (sigma_max - sigma)/(sigma_max - sigma_min), so that every term is 0 at the
    index's best value and 1 at its worst, and the sum is minimized.  With
    ``literal=True`` eq. 38 is applied as printed to every index, which
    rewards a *low* stiffness.
    """
    out = {}
    for k in lo:
        span = hi[k] - lo[k]
        v = np.asarray(values[k], dtype=float)
        f = (v - lo[k]) / span if span > 0 else np.zeros_like(v)
        if senses[k] == "max" and not literal:
            f = 1.0 - f
        out[k] = f
    return out


def weighted_sum(values: dict, term: Term) -> np.ndarray:
    f = normalized_terms(values, term.lo, term.hi, term.senses, term.literal)
    return sum(term.weights[k] * f[k] for k in f)


class DesignProblem(Problem):
    """pymoo Problem: design vectors -> objective terms and constraints.

    ``evaluate`` maps design vectors X (D, n_var) to ``{"values": {name: (D,)},
    "constraints": {name: (D,)}}`` (``G <= 0`` feasible): an
    :class:`optdesign.evaluate.Evaluator`, or any callable.  ``xl``, ``xu`` and
    ``constraint_names`` default to the callable's attributes of those names.
    An objective that is not finite becomes a violated ``finite`` constraint
    (if there is one) and a large finite number, so that pymoo can sort.
    """

    def __init__(self, evaluate: Callable[[np.ndarray], dict], terms: Sequence[Term], xl=None, xu=None,
                 constraint_names: Sequence[str] | None = None):
        self.evaluate_designs = evaluate
        self.terms = list(terms)
        xl = np.asarray(evaluate.xl if xl is None else xl, dtype=float)
        xu = np.asarray(evaluate.xu if xu is None else xu, dtype=float)
        names = getattr(evaluate, "constraint_names", ()) if constraint_names is None else constraint_names
        self.constraint_names = list(names)
        self.n_evaluations = 0
        super().__init__(n_var=len(xl), n_obj=len(self.terms), n_ieq_constr=len(self.constraint_names),
                         xl=xl, xu=xu, vtype=float)

    def objectives(self, values: dict) -> np.ndarray:
        cols = []
        for t in self.terms:
            if t.kind in ("index", "extra"):
                cols.append(t.sign * np.asarray(values[t.name], dtype=float))
            else:
                cols.append(weighted_sum(values, t))
        return np.stack(cols, axis=-1)

    # ------------------------------------------------------------------ pymoo
    def _evaluate(self, X, out, *args, **kwargs):
        res = self.evaluate_designs(X)
        F = self.objectives(res["values"])
        if self.constraint_names:
            G = np.stack([np.asarray(res["constraints"][k], dtype=float) for k in self.constraint_names], axis=-1)
        else:
            G = np.zeros((X.shape[0], 0))
        bad = ~np.all(np.isfinite(F), axis=-1)
        # an objective that is not finite is recorded as infeasible (constraint
        # 'finite'); pymoo needs finite numbers to sort, so such rows get a large
        # finite objective that never competes with a feasible design
        if "finite" in self.constraint_names:
            j = self.constraint_names.index("finite")
            G[bad, j] = np.maximum(G[bad, j], 1.0)
        F = np.where(np.isfinite(F), F, 1e300)
        self.n_evaluations += X.shape[0]
        out["F"] = F
        out["G"] = G
        for k, v in res["values"].items():
            out[f"index_{k}"] = np.asarray(v, dtype=float)
