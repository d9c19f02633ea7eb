"""A commented starting config for a mechanism (``optdesign init``), written from
its parameter table and the example it declares (``Mechanism.example``: design
variables with bounds, a workspace and indices that suit it).  The text
validates and runs as it is; every value carries its unit and meaning."""
from __future__ import annotations

import json
from typing import Any, Mapping

__all__ = ["scaffold"]


def _flow(v: Any) -> str:
    """A YAML flow value (JSON is valid YAML flow syntax)."""
    if isinstance(v, float) and v == int(v) and abs(v) < 1e15:
        return str(int(v)) if abs(v) >= 1 or v == 0 else repr(v)
    if isinstance(v, (int, float)):
        return repr(v)
    return json.dumps(v)


def _entry(d: Mapping) -> str:
    return "{" + ", ".join(f"{k}: {_flow(v)}" for k, v in d.items()) + "}"


def _unit_note(p, unit: str | None) -> str:
    if p.kind == "switch":
        return "one of " + ", ".join(f"{k} ({v:g})" for k, v in p.choices.items())
    shown = unit or p.unit
    return shown if shown else "dimensionless"


def scaffold(cls, name: str | None = None) -> str:
    """The config text for mechanism class ``cls`` (a registered mechanism)."""
    ex = getattr(cls, "example", None) or {}
    name = name or f"{cls.name}_design"
    lines = [f"# A starting config for the mechanism {cls.name!r} (written by `optdesign init`).",
             "# Units: SI (m, kg, rad, N/m) unless an entry says `unit:` (mm for a length, deg for an angle).",
             "# Every number below is a starting point, not a recommendation: set the bounds, the",
             "# workspace and the masses to those of your design.  Reference: docs/config.md.",
             f"mechanism: {cls.name}",
             f"name: {name}",
             ""]
    fixed = [p for p in cls.parameters if not p.design]
    overrides = ex.get("parameters", {})
    if fixed:
        lines.append("parameters:                # fixed parameters (not optimized)")
        for p in fixed:
            v = overrides.get(p.name)
            if v is None:
                if p.kind == "switch":
                    val = next((k for k, x in p.choices.items() if float(x) == p.default_value), p.default_value)
                    text = str(val)
                else:
                    text = _flow(p.default_value)
                unit = None
            else:
                text = _entry(v) if isinstance(v, Mapping) else _flow(v)
                unit = v.get("unit") if isinstance(v, Mapping) else None
            lines.append(f"  {p.name}: {text}".ljust(40) + f"# {_unit_note(p, unit)}: {p.doc}")
        lines.append("")
    dv = ex.get("design_variables", {})
    lines.append("design_variables:           # `bounds` make a variable free in `optdesign run`; without: fixed")
    for p in cls.parameters:
        if not p.design:
            continue
        v = dv.get(p.name)
        if v is None:
            v = {"value": p.default_value}
        unit = v.get("unit")
        lines.append(f"  {p.name}: {_entry(v)}".ljust(60) + f"# {_unit_note(p, unit)}: {p.doc}")
    lines += ["", "designs:                   # named designs for `optdesign evaluate` (missing values: as above)",
              "  start: {}", ""]
    ws = ex.get("workspace")
    if ws is None:
        raise ValueError(f"mechanism {cls.name!r} declares no example workspace")
    lines.append("workspace:                 # the region W the global indices average over")
    for k, v in ws.items():
        lines.append(f"  {k}: {_entry(v) if isinstance(v, Mapping) else _flow(v)}")
    lines += ["", "indices:                   # global indices (kind, sense: min or max, see docs/config.md)"]
    for k, v in ex.get("indices", {}).items():
        lines.append(f"  {k}: {_entry(v)}")
    opt = ex.get("optimizer", {"population": 30, "generations": 30,
                               "pareto": {"algorithms": ["nsga2"], "population": 40, "generations": 40}})
    lines += ["", "optimizer:                 # a short search; raise population and generations for a real run"]
    for k, v in opt.items():
        lines.append(f"  {k}: {_entry(v) if isinstance(v, Mapping) else _flow(v)}")
    return "\n".join(lines) + "\n"

