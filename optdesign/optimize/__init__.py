"""Optimization: the optimizer knows design vectors and objective values.

``problem`` (the pymoo Problem: bounds, an evaluation callable, objective
terms; the normalized weighted sum of eq. 38-40), ``operators`` (the paper's
GA operators), ``algorithms`` (the GA, NSGA-II, NSGA-III a stage runs),
``stage`` (one stage in pymoo's loop with a Callback for history, progress,
checkpoints and stop requests), ``checkpoint`` (an algorithm's state as data),
``workers`` (stop requests, signals, stage worker processes), ``results``
(stage files, final results, Pareto placement), ``pipeline`` (the plan of
stages), ``spec`` (the plain pieces a run reads: the evaluator, the
optimizer's and the checks' settings, the units, what the results are
about; never a config), ``outputs`` (what the layers above hand a run: the
reports of :mod:`optdesign.report` and a study's note, as plain callables;
started and resumed with them by :mod:`optdesign.runner`).
"""
