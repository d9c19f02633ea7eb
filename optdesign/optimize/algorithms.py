"""The algorithms a stage runs: pymoo's DE, the paper's GA, pymoo's GA, NSGA-II, NSGA-III.

:func:`build_algorithm` takes the optimizer settings (plain data) and returns
a fresh pymoo algorithm and the callbacks its operators need; a resumed stage
builds it the same way and then restores its state (:mod:`.checkpoint`).

Determinism: every random draw goes through the algorithm's own generator
(seeded per stage).  pymoo 0.6.2's NSGA-III tournament
(``nsga3.comp_by_cv_then_random``) breaks a tie between two infeasible
designs of equal constraint violation with ``compare(...)`` called without
the algorithm's generator, which then draws from a fresh, OS-seeded one: with
such ties (designs that reach no workspace point share one violation) the
front changed from run to run with the same seed.  NSGA-III here uses the
same tournament with the algorithm's generator passed on (:func:`cv_then_random`);
where there is no tie it draws exactly what pymoo's does.
"""
from __future__ import annotations

from math import comb

import numpy as np
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.algorithms.moo.nsga3 import NSGA3
from pymoo.algorithms.soo.nonconvex.de import DE
from pymoo.algorithms.soo.nonconvex.ga import GA
from pymoo.operators.sampling.rnd import FloatRandomSampling
from pymoo.operators.selection.tournament import TournamentSelection, compare
from pymoo.util.ref_dirs import get_reference_directions

from .operators import (AdaptiveGaussianMutation, AdaptiveMutationCallback, ArithmeticCrossover,
                        ElitistGenerationalSurvival, RouletteSelection)

__all__ = ["build_algorithm", "cv_then_random", "reference_directions", "ALGORITHMS", "SeededSampling", "seed_count"]

#: what ``which`` may name (None: the config's GA)
ALGORITHMS = ("nsga2", "nsga3")


def cv_then_random(pop, P, random_state=None, **kwargs):
    """NSGA-III's binary tournament (pymoo's ``comp_by_cv_then_random``): the
    smaller constraint violation wins, a tie or two feasible designs are
    decided at random, always with the algorithm's generator."""
    S = np.full(P.shape[0], np.nan)
    for i in range(P.shape[0]):
        a, b = P[i, 0], P[i, 1]
        if pop[a].CV > 0.0 or pop[b].CV > 0.0:
            S[i] = compare(a, pop[a].CV, b, pop[b].CV, method="smaller_is_better", return_random_if_equal=True,
                           random_state=random_state)
        else:
            S[i] = random_state.choice([a, b])
    return S[:, None].astype(int)


def reference_directions(n_obj: int, population: int = 100) -> np.ndarray:
    """Das-Dennis directions (deterministic) for NSGA-III: the fewest
    partitions whose directions are at least ``population`` (NSGA-III keeps
    about one design per direction, so fewer directions than designs would
    shrink its front)."""
    p = 1
    while comb(p + n_obj - 1, n_obj - 1) < max(int(population), 1):
        p += 1
    return get_reference_directions("das-dennis", n_obj, n_partitions=p)


class SeededSampling(FloatRandomSampling):
    """Uniform random designs in the bounds whose first rows are replaced by
    given seeds (the pre-scan's best designs): the generator draws what it
    draws without seeds, so seeded and unseeded runs share their random stream."""

    def __init__(self, seeds=None):
        super().__init__()
        self.seeds = np.zeros((0, 0)) if seeds is None else np.asarray(seeds, dtype=float)

    def _do(self, problem, n_samples, *args, random_state=None, **kwargs):
        X = super()._do(problem, n_samples, *args, random_state=random_state, **kwargs)
        k = min(len(self.seeds), n_samples)
        if k:
            X[:k] = np.clip(self.seeds[:k], problem.xl, problem.xu)
        return X


def seed_count(population: int) -> int:
    """How many seeds a single-objective population of this size starts with (a tenth, at least one)."""
    return max(1, population // 10)


def build_algorithm(opt, n_obj: int = 1, which: str | None = None, seeds=None):
    """``(algorithm, callback)``: the single-objective search of the optimizer
    settings ``opt`` (``de``, ``paper_ga`` or ``pymoo_ga``), or NSGA-II/III
    (``which``), and the callback its operators need after each generation
    (the paper GA's adaptive mutation) or None.  ``seeds`` (k, n): designs
    the initial population starts with (a single-objective search: the
    pre-scan's best for its objective; a Pareto run: the pre-scan's
    non-dominated designs, at most half its population)."""
    sampling = SeededSampling(seeds)
    if which == "nsga2":
        return NSGA2(pop_size=opt.pareto_population, sampling=sampling), None
    if which == "nsga3":
        ref = reference_directions(n_obj, opt.pareto_population)
        return NSGA3(ref_dirs=ref, pop_size=max(opt.pareto_population, len(ref)), sampling=sampling,
                     selection=TournamentSelection(func_comp=cv_then_random)), None
    if which is not None:
        raise ValueError(f"unknown algorithm {which!r}; expected one of {', '.join(ALGORITHMS)}")
    if opt.algorithm == "pymoo_ga":
        return GA(pop_size=opt.population, sampling=sampling, eliminate_duplicates=True), None
    if opt.algorithm == "de":
        return DE(pop_size=opt.population, sampling=sampling), None
    mutation = AdaptiveGaussianMutation(prob=opt.mutation_probability)
    alg = GA(pop_size=opt.population, sampling=sampling, selection=RouletteSelection(opt.fitness_scaling),
             crossover=ArithmeticCrossover(prob=opt.crossover_probability), mutation=mutation,
             survival=ElitistGenerationalSurvival(opt.elites), n_offsprings=opt.population - opt.elites,
             eliminate_duplicates=False)
    return alg, AdaptiveMutationCallback(mutation)
