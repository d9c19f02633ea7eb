"""The config's ``checks`` section: how hard a run checks the designs it
reports over the continuous workspace (docs/config.md, "checks").

``certificate_budget`` is the number of box evaluations of the interval
branch and bound per reported design for a W of at most 3 free axes (less is
given to higher dimensions and to Pareto points, see
:func:`optdesign.certify.reported.budget_for`); 0 skips the proofs, and every
reported design is then ``unknown`` with 0 % of W proved.
``integral_tolerance`` and ``integral_max_points`` are the relative tolerance
and the node budget (per design) of the adaptive integrals recorded beside the
config's quadrature; ``integral_tolerance: 0`` skips them.
"""
from __future__ import annotations

from typing import Any

from .keys import CHECKS, spec_class
from .reader import Reader

__all__ = ["CHECKS_KEYS", "ChecksSpec", "checks_section"]

CHECKS_KEYS = CHECKS.allowed()

#: the checks' settings, one field per key of :data:`.keys.CHECKS` (its defaults)
ChecksSpec = spec_class("ChecksSpec", CHECKS, "How hard a run checks the designs it reports (docs/config.md, checks).",
                        __name__)


def checks_section(r: Reader, raw: Any) -> ChecksSpec:
    if raw is None:
        return ChecksSpec()
    path = "checks"
    m = r.mapping(raw, path)
    r.only(m, path, CHECKS_KEYS)
    return ChecksSpec(**CHECKS.read(r, m, path))
