"""What the layers above the optimizer add to a run, handed down as plain
callables: the optimizer knows design vectors and objective values, and
writes results.json, the stages' CSV files and its checkpoints; the reports
(:mod:`optdesign.report`) and any study's note on the results
(:mod:`optdesign.studies`) come from above (:mod:`optdesign.runner`, the
commands), each bound there to what it reads (the config's units, the
config a study looks at): the optimizer hands them the run folder and its
results, never a config.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

__all__ = ["RunOutputs", "NO_OUTPUTS"]


@dataclass(frozen=True)
class RunOutputs:
    #: ``reference_note() -> str | None``: a paragraph on the config's
    #: reference, kept as ``results.json["reference_note"]``
    reference_note: Callable | None = None
    #: ``write_report(folder, results, stages)``: written once results.json
    #: is, before the manifest says complete (results.md, its plots ...)
    write_report: Callable | None = None
    #: ``write_html(folder)``: written once the manifest says complete; it must
    #: not raise (a failed page never loses a finished run)
    write_html: Callable | None = None


#: a run that writes the optimizer's own files only
NO_OUTPUTS = RunOutputs()
