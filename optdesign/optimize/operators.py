"""The paper's GA operators as pymoo operators (section 3.4).

The paper used MATLAB's ``ga`` with roulette-wheel selection, arithmetic
crossover (probability 0.8), an adaptive mutation and 2 elites.  pymoo has none
of roulette selection, arithmetic crossover or a generational survival with a
fixed number of elites, so they are written here against pymoo's extension
points; the loop itself stays pymoo's ``GA``.
"""
from __future__ import annotations

import numpy as np
from pymoo.core.callback import Callback
from pymoo.core.crossover import Crossover
from pymoo.core.mutation import Mutation
from pymoo.core.selection import Selection
from pymoo.core.survival import Survival

__all__ = ["RouletteSelection", "ArithmeticCrossover", "AdaptiveGaussianMutation",
           "ElitistGenerationalSurvival", "AdaptiveMutationCallback", "roulette_fitness"]


def roulette_fitness(F: np.ndarray, CV: np.ndarray, scaling: str = "linear") -> np.ndarray:
    """Non-negative fitness for roulette selection from objective values F (n,)
    to be minimized and constraint violations CV (n,).

    ``linear``: feasible individuals get ``F_worst - F + delta`` with delta 1%
    of the feasible range (so the worst feasible one keeps a small chance);
    ``rank``: ``1 / sqrt(rank)`` (MATLAB's rank scaling).  Infeasible
    individuals get a tenth of the smallest feasible fitness, less the more they
    violate, so they are chosen rarely and never before a feasible one in
    expectation.
    """
    F = np.asarray(F, dtype=float).ravel()
    CV = np.asarray(CV, dtype=float).ravel()
    feas = (CV <= 0) & np.isfinite(F)
    fit = np.zeros_like(F)
    if scaling == "rank":
        order = np.lexsort([F, ~feas])  # feasible first, then by F
        rank = np.empty(len(F))
        rank[order] = np.arange(1, len(F) + 1)
        fit = 1.0 / np.sqrt(rank)
        floor = fit[feas].min() if feas.any() else 1.0
    else:
        if feas.any():
            fmin, fmax = F[feas].min(), F[feas].max()
            span = fmax - fmin
            delta = 0.01 * span if span > 0 else 1.0
            fit[feas] = fmax - F[feas] + delta
            floor = fit[feas].min()
        else:
            floor = 1.0
    if (~feas).any():
        cv = np.where(np.isfinite(CV), CV, np.nanmax(np.where(np.isfinite(CV), CV, 0)) + 1)
        cvmax = cv[~feas].max()
        worst = cv[~feas] / cvmax if cvmax > 0 else np.ones((~feas).sum())
        fit[~feas] = 0.1 * floor * (1.0 - 0.5 * worst)
    return fit


class RouletteSelection(Selection):
    """Roulette-wheel (fitness-proportionate) selection for one objective."""

    def __init__(self, scaling: str = "linear", **kwargs):
        super().__init__(**kwargs)
        if scaling not in ("linear", "rank"):
            raise ValueError(f"scaling must be 'linear' or 'rank', got {scaling!r}")
        self.scaling = scaling

    def _do(self, problem, pop, n_select, n_parents, *args, random_state=None, **kwargs):
        F, CV = pop.get("F", "CV")
        fit = roulette_fitness(F[:, 0], CV[:, 0] if CV is not None else np.zeros(len(pop)), self.scaling)
        total = fit.sum()
        p = fit / total if total > 0 else np.full(len(fit), 1.0 / len(fit))
        cum = np.cumsum(p)
        cum[-1] = 1.0
        r = random_state.random(n_select * n_parents)
        idx = np.searchsorted(cum, r, side="right")
        return np.minimum(idx, len(fit) - 1).reshape(n_select, n_parents)


class ArithmeticCrossover(Crossover):
    """Arithmetic crossover: children ``a p1 + (1 - a) p2`` and ``(1 - a) p1 + a p2``
    with one ``a ~ U(0, 1)`` per mating.  Children are convex combinations of
    their parents, so they stay inside the bounds."""

    def __init__(self, prob: float = 0.8, **kwargs):
        super().__init__(2, 2, prob=prob, **kwargs)

    def _do(self, problem, X, *args, random_state=None, **kwargs):
        _, n_matings, n_var = X.shape
        a = random_state.random((n_matings, 1))
        p1, p2 = X[0], X[1]
        c1 = a * p1 + (1.0 - a) * p2
        c2 = (1.0 - a) * p1 + a * p2
        return np.stack([c1, c2])


class AdaptiveGaussianMutation(Mutation):
    """Gaussian mutation whose step adapts to the search's success.

    Each mutated individual moves by ``N(0, (scale (xu - xl))^2)`` in every
    variable and is clipped to the bounds.  ``scale`` starts at ``initial_scale``
    and is updated once per generation by :class:`AdaptiveMutationCallback`:
    multiplied by ``grow`` when the best objective improved in that generation,
    by ``shrink`` otherwise (a success rule in the spirit of MATLAB's
    adaptive-feasible mutation), and kept within [min_scale, max_scale].
    """

    def __init__(self, prob: float = 0.2, initial_scale: float = 0.1, grow: float = 1.25, shrink: float = 0.8,
                 min_scale: float = 1e-4, max_scale: float = 0.5, **kwargs):
        super().__init__(prob=prob, **kwargs)
        self.scale = float(initial_scale)
        self.grow, self.shrink = float(grow), float(shrink)
        self.min_scale, self.max_scale = float(min_scale), float(max_scale)

    def adapt(self, improved: bool) -> None:
        self.scale *= self.grow if improved else self.shrink
        self.scale = float(min(max(self.scale, self.min_scale), self.max_scale))

    def _do(self, problem, X, *args, random_state=None, **kwargs):
        xl, xu = problem.bounds()
        step = self.scale * (xu - xl)
        Y = X + random_state.normal(size=X.shape) * step
        return np.clip(Y, xl, xu)


class AdaptiveMutationCallback(Callback):
    """Feeds the best objective of each generation back into the adaptive mutation."""

    def __init__(self, mutation: AdaptiveGaussianMutation):
        super().__init__()
        self.mutation = mutation
        self.best = np.inf

    def notify(self, algorithm):
        opt = algorithm.opt
        if opt is None or len(opt) == 0:
            return
        f = float(opt[0].F[0]) if opt[0].CV[0] <= 0 else np.inf
        improved = f < self.best - 1e-15 * max(1.0, abs(self.best) if np.isfinite(self.best) else 1.0)
        if algorithm.n_gen > 1:
            self.mutation.adapt(improved)
        self.best = min(self.best, f)


class ElitistGenerationalSurvival(Survival):
    """Generational replacement with a fixed number of elites.

    pymoo's GA hands survival the merged population (parents first, then the
    offspring).  The next population is the ``elites`` best parents (feasible
    first, then by objective) followed by the offspring, best first — so with
    ``n_offsprings = pop_size - elites`` every child survives, as in MATLAB's ``ga``.
    """

    def __init__(self, elites: int = 2):
        super().__init__(filter_infeasible=False)
        self.elites = int(elites)

    def _do(self, problem, pop, *args, n_survive=None, algorithm=None, **kwargs):
        n_parents = len(algorithm.pop) if algorithm is not None and algorithm.pop is not None else 0
        F, CV = pop.get("F", "CV")
        key = lambda idx: np.lexsort([F[idx, 0], CV[idx, 0]])  # noqa: E731
        if n_parents == 0 or n_parents >= len(pop):  # initial population: rank it
            order = key(np.arange(len(pop)))
            out = pop[order[:n_survive]]
        else:
            par = np.arange(n_parents)
            off = np.arange(n_parents, len(pop))
            elite = par[key(par)[: self.elites]]
            rest = off[key(off)]
            idx = np.concatenate([elite, rest])
            # best first overall so that pop[0] is the incumbent
            idx = idx[key(idx)][:n_survive]
            out = pop[idx]
        return out
