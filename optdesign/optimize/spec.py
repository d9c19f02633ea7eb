"""What a run reads, as plain pieces: the optimizer is handed these, never a
config (the runner, :mod:`optdesign.runner`, makes them of one).

* :class:`RunSubject` — what the results are about: the config's name, the
  mechanism's, the named designs and the reference values given for them
  (results.json's ``config``, ``mechanism``, ``designs`` and ``reference``);
* :class:`RunSpec` — the pieces of one run: the evaluation callable
  (:class:`optdesign.evaluate.Evaluator`: design vectors -> index values and
  constraints, with its workspace, indices and bounds), the optimizer's
  settings (the config's ``optimizer`` section), the checks' settings (its
  ``checks`` section), the units the CSV files and progress lines show
  (:class:`optdesign.units.Units`) and the subject.  The pipeline hands each
  part of the run only the pieces it reads (a stage in a worker process:
  the evaluator, the optimizer's settings and the units).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from ..evaluate import Evaluator
from ..units import Units

__all__ = ["RunSpec", "RunSubject"]


@dataclass(frozen=True)
class RunSubject:
    """What a run's results name and compare against (all values SI)."""

    name: str                                       #: the config's name
    mechanism: str                                  #: the mechanism's name
    designs: Mapping[str, Mapping[str, float]]      #: the named designs: every design parameter
    reference: Mapping[str, Mapping[str, float]]    #: reference values of named designs (index -> value)


@dataclass(frozen=True)
class RunSpec:
    """The plain pieces of one run (see the module docstring)."""

    evaluator: Evaluator
    optimizer: Any     #: the stages' settings (the config's OptimizerSpec, plain data)
    checks: Any        #: how hard the reported designs are checked (the config's ChecksSpec)
    units: Units
    subject: RunSubject
