"""Declared parameters of a mechanism: one table gives the config's keys, their
units, their valid ranges and the loader's messages.

Each mechanism lists its parameters once, as :class:`Param` entries::

    parameters = (
        Param("r_a", "length", design=True, low=0.0, low_open=True, doc="platform circumradius"),
        Param("phi", "angle", design=True, low=0.0, high=math.pi / 2, low_open=True, high_open=True),
        Param("m_platform", "mass", 4.16, low=0.0),
        Param("input_type", "switch", "rotary", choices={"rotary": 0.0, "linear": 1.0}),
    )

``design=True`` marks an optimizable dimension (a key of the config's
``design_variables``), the others are fixed parameters (keys of
``parameters``).  A ``default`` of None makes the entry required.  Values are
SI (m, rad, kg, kg m^2, N/m, m/s^2); a config may write a length in mm and an
angle in deg where the entry says ``unit:``, and nothing else.  A switch takes
one of its named choices or the number it stands for.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

__all__ = ["Param", "KINDS", "UNIT_SCALES", "derived_tables"]

#: kind -> (SI unit, {unit a config may write: factor to SI})
KINDS: dict[str, tuple[str, dict[str, float]]] = {
    "length": ("m", {"m": 1.0, "mm": 1e-3}),
    "angle": ("rad", {"rad": 1.0, "deg": math.pi / 180.0}),
    "mass": ("kg", {"kg": 1.0}),
    "inertia": ("kg m^2", {"kg m^2": 1.0}),
    "stiffness": ("N/m", {"N/m": 1.0}),
    "acceleration": ("m/s^2", {"m/s^2": 1.0}),
    "count": ("", {}),
    "switch": ("", {}),
    "number": ("", {}),
}

#: every unit a config may name, and its factor to SI
UNIT_SCALES: dict[str, float] = {u: f for _, (_, units) in KINDS.items() for u, f in units.items()}


@dataclass(frozen=True)
class Param:
    """One parameter of a mechanism (see the module docstring)."""

    name: str
    kind: str
    default: Any = None
    design: bool = False
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: Mapping[str, float] | None = field(default=None, hash=False)
    doc: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"parameter {self.name!r}: unknown kind {self.kind!r}")
        if (self.kind == "switch") != (self.choices is not None):
            raise ValueError(f"parameter {self.name!r}: a switch and only a switch has choices")

    # ------------------------------------------------------------------ units
    @property
    def unit(self) -> str:
        """The SI unit of the value ('' for counts, switches and plain numbers)."""
        return KINDS[self.kind][0]

    @property
    def units(self) -> dict[str, float]:
        """Units a config may write for this parameter, with their factor to SI."""
        return KINDS[self.kind][1]

    @property
    def default_value(self) -> float | None:
        """The default as an SI number (a switch's default choice resolved)."""
        if self.default is None:
            return None
        if self.kind == "switch" and isinstance(self.default, str):
            return float(self.choices[self.default])
        return float(self.default)

    # ------------------------------------------------------------------ checks
    def choice(self, value: Any) -> tuple[float | None, str | None]:
        """A switch's value from a name or the number it stands for:
        ``(number, None)`` or ``(None, message)``."""
        names = ", ".join(f"{k} ({v:g})" for k, v in self.choices.items())
        if isinstance(value, str):
            if value in self.choices:
                return float(self.choices[value]), None
            return None, f"expected one of {names}, got {value[:40]!r}"
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return None, f"expected one of {names}"
        for v in self.choices.values():
            if float(value) == float(v):
                return float(v), None
        return None, f"expected one of {names}, got {float(value):g}"

    def problem(self, x: float) -> str | None:
        """Why the SI value ``x`` is not valid, or None."""
        if self.kind == "count" and x != math.floor(x):
            return f"expected a whole number, got {x:g}"
        if self.kind == "switch":
            return None if x in [float(v) for v in self.choices.values()] else self.choice(x)[1]
        if self.low is not None and (x < self.low or (self.low_open and x == self.low)):
            return f"expected {self.range_text()}, got {self._show(x)}"
        if self.high is not None and (x > self.high or (self.high_open and x == self.high)):
            return f"expected {self.range_text()}, got {self._show(x)}"
        return None

    def range_text(self) -> str:
        """The valid range in words (angles in degrees)."""
        if self.low == 0.0 and self.high is None:
            if self.low_open:
                return {"length": "a positive length", "stiffness": "a positive stiffness"}.get(self.kind, "a positive value")
            return "a non-negative value"
        if self.low is not None and self.high is not None:
            ends = {(True, True): " (both excluded)", (False, False): "", (True, False): f" ({self._show(self.low)} excluded)",
                    (False, True): f" ({self._show(self.high)} excluded)"}[(self.low_open, self.high_open)]
            unit = " deg" if self.kind == "angle" else (f" {self.unit}" if self.unit else "")
            lo = f"{math.degrees(self.low):g}" if self.kind == "angle" else f"{self.low:g}"
            hi = f"{math.degrees(self.high):g}" if self.kind == "angle" else f"{self.high:g}"
            return f"a value between {lo} and {hi}{unit}{ends}"
        if self.low is not None:
            return f"a value {'above' if self.low_open else 'of at least'} {self._show(self.low)}"
        return f"a value {'below' if self.high_open else 'of at most'} {self._show(self.high)}"

    def _show(self, x: float) -> str:
        if self.kind == "angle":
            return f"{math.degrees(x):g} deg"
        return f"{x:g}{(' ' + self.unit) if self.unit else ''}"


def derived_tables(params: tuple[Param, ...]) -> dict[str, Any]:
    """The older per-purpose class attributes, derived from the table (for code
    that reads them): design_parameters, design_defaults, length_parameters,
    fixed_parameters, positive_parameters, nonnegative_parameters."""
    design = tuple(p.name for p in params if p.design)
    defaults = {p.name: p.default_value for p in params if p.design and p.default is not None}
    lengths = tuple(p.name for p in params if p.design and p.kind == "length" and p.low == 0.0 and p.low_open)
    fixed = {p.name: p.default_value for p in params if not p.design}
    positive = tuple(p.name for p in params if not p.design and p.low == 0.0 and p.low_open)
    nonneg = tuple(p.name for p in params if not p.design and p.low == 0.0 and not p.low_open)
    return {"design_parameters": design, "design_defaults": defaults, "length_parameters": lengths,
            "fixed_parameters": fixed, "positive_parameters": positive, "nonnegative_parameters": nonneg}
