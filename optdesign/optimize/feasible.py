"""The Evaluator's verdict on the designs a local step proposes: their
objective values and feasibility (:func:`check`), and the feasible end of a
step that left the feasible set (:func:`feasible_end`)."""
from __future__ import annotations

import numpy as np

__all__ = ["check", "feasible_end", "LEVELS"]


def check(problem, X):
    """The Evaluator's objective values (D,) and feasibility (D,) of designs X."""
    out = {}
    problem._evaluate(np.atleast_2d(X), out)
    return out["F"][:, 0], np.all(out["G"] <= 0, axis=1), out


#: bisection steps of :func:`feasible_end` checked in one call of the Evaluator:
#: the 2^LEVELS - 1 midpoints those steps may visit (a call's fixed cost is most of
#: a one-design check: 3-P(4S) paper config 0.89 ms for one design, 1.18 ms for 7)
LEVELS = 3


def _midpoints(a: float, b: float, levels: int) -> list[float]:
    """Every midpoint the next ``levels`` bisection steps of [a, b] may visit,
    each computed as the bisection computes it (``0.5 * (a + b)`` of its interval)."""
    m = 0.5 * (a + b)
    if levels <= 1:
        return [m]
    return [m] + _midpoints(a, m, levels - 1) + _midpoints(m, b, levels - 1)


def feasible_end(problem, x0, x1, steps: int = 30):
    """(x, its objective value): x1 if the Evaluator finds it feasible, else
    the feasible point nearest x1 on the segment from the feasible x0
    (bisection, ``steps`` steps).  The value is the Evaluator's, from the
    check that found x feasible (x0's own when no point of the segment was).
    The steps are checked :data:`LEVELS` at a time: one call for every
    midpoint they may visit, then the steps taken as one at a time would
    take them (the Evaluator's answer for a design does not depend on the
    others of its call), so the end is the same to the bit."""
    f, ok, _ = check(problem, x1)
    if ok[0]:
        return x1, float(f[0])
    a, b = 0.0, 1.0     # x0 + a (x1 - x0) feasible, + b not
    fa = None           # the value at x0 + a (x1 - x0), once a point of the segment was feasible
    left = steps
    while left > 0:
        k = min(LEVELS, left)
        ms = _midpoints(a, b, k)
        f, ok, _ = check(problem, np.stack([x0 + m * (x1 - x0) for m in ms]))
        got = {m: (bool(o), float(v)) for m, o, v in zip(ms, ok, f)}
        for _ in range(k):
            m = 0.5 * (a + b)
            feasible, value = got[m]
            if feasible:
                a, fa = m, value
            else:
                b = m
        left -= k
    x = x0 + a * (x1 - x0)
    return x, (fa if fa is not None else float(check(problem, x)[0][0]))
