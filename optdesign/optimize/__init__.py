"""Optimization: the pymoo problem, the paper's GA operators, the normalized
weighted sum (eq. 38-40) and Pareto fronts."""
