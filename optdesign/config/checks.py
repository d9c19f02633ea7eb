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

from dataclasses import dataclass
from typing import Any

from .reader import Reader

__all__ = ["ChecksSpec", "checks_section", "CHECKS_KEYS"]

CHECKS_KEYS = {"certificate_budget", "integral_tolerance", "integral_max_points"}


@dataclass(frozen=True)
class ChecksSpec:
    certificate_budget: int = 300_000
    integral_tolerance: float = 1e-4
    integral_max_points: int = 200_000


def checks_section(r: Reader, raw: Any) -> ChecksSpec:
    if raw is None:
        return ChecksSpec()
    path = "checks"
    m = r.mapping(raw, path)
    r.only(m, path, CHECKS_KEYS)
    kw: dict[str, Any] = {}
    if "certificate_budget" in m:
        kw["certificate_budget"] = r.integer(m["certificate_budget"], f"{path}.certificate_budget", minimum=0,
                                             maximum=100_000_000)
    if "integral_tolerance" in m:
        t = r.number(m["integral_tolerance"], f"{path}.integral_tolerance", nonneg=True)
        if t != 0 and not 1e-10 <= t <= 0.5:
            r.fail(f"{path}.integral_tolerance", f"expected 0 (no integrals) or a relative tolerance in [1e-10, 0.5], got {t:g}")
        kw["integral_tolerance"] = t
    if "integral_max_points" in m:
        kw["integral_max_points"] = r.integer(m["integral_max_points"], f"{path}.integral_max_points", minimum=100,
                                              maximum=10_000_000)
    return ChecksSpec(**kw)
