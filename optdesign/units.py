"""Units of what a user sees: design variables in the config's units, pose
axes in the workspace's, indices and objectives in SI with the unit named.
Shared by results.md, the CSV files, the PNGs, the printed output and
report.html, so that they all name the same unit for the same quantity.

* :class:`DesignVariable` — one row of the design-variable table: its value,
  its bounds (SI) and the unit the config wrote it in;
* :class:`Units` — the table of what a user sees of one config's quantities
  (made by :meth:`optdesign.config.Config.units`, or :meth:`Units.of` from
  plain pieces): the design-variable table, the unit each variable, pose
  axis, index, extra objective and actuator is shown in, and each index's
  sense.  Plain data: the layers below the commands receive it, never the
  config;
* the functions below (``variable_unit(units, name)``, ``index_text(units,
  name, value)``, ``display_rows(units, rows)`` ...) read it.

Index units follow from the mechanism's matrices: J maps pose rates to
actuator rates (actuator unit / pose unit), M maps pose accelerations to
actuator forces, K = J^T k J maps pose displacements to the generalized force
conjugate to the pose (N for a length, N m for an angle).  The mechanism
declares them: ``pose_units`` (axis -> unit; angular axes rad, others m by
default) and ``actuator_unit(params)`` (m unless the mechanism says otherwise),
as ``Mechanism.pose_unit`` and ``Mechanism.actuator_unit`` say.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

from .mechanisms.params import UNIT_SCALES

__all__ = ["DIMENSIONLESS", "MIXED", "DesignVariable", "Units", "variable_unit", "pose_unit", "pose_display",
           "index_unit", "objective_unit", "label", "index_label", "variable_label", "design_text", "index_text",
           "constraint_unit", "csv_column", "display_rows", "strip_unit", "actuator_unit", "actuator_units"]

#: shown for a dimensionless quantity
DIMENSIONLESS = "–"

#: design variables that are angles when the config gives no unit (radians)
_ANGLE_NAMES = ("phi", "theta", "psi", "delta", "alpha", "beta", "gamma")
_SUP = {2: "²", 3: "³", 4: "⁴", 5: "⁵", 6: "⁶"}


@dataclass(frozen=True)
class DesignVariable:
    """A design parameter: its initial value and, if it is optimized, its bounds (SI)."""

    name: str
    value: float
    bounds: tuple[float, float] | None
    unit: str | None = None  # the unit the config wrote it in (for display)

    @property
    def free(self) -> bool:
        return self.bounds is not None and self.bounds[1] > self.bounds[0]

    def display(self, x: float) -> float:
        """SI value -> the unit of the config (degrees stay degrees in tables)."""
        return x / UNIT_SCALES[self.unit] if self.unit in ("deg", "mm") else x


@dataclass(frozen=True)
class Units:
    """What a user sees of a config's quantities (see the module docstring).

    ``variables`` is the design-variable table in the config's order;
    ``indices`` maps each index, in the config's order, to ``(unit, sense)``
    (unit None where the mechanism's axes mix units); ``extras`` maps each
    extra objective the mechanism declares to ``(unit, factor, sense)``
    (value shown = SI value * factor); ``poses`` maps each pose axis to ``(SI
    unit, unit shown, factor)`` (deg or mm where the workspace says so)."""

    variables: Mapping[str, DesignVariable]
    variable_units: Mapping[str, str]
    poses: Mapping[str, tuple[str, str, float]]
    indices: Mapping[str, tuple[str | None, str]]
    extras: Mapping[str, tuple[str | None, float, str]]
    actuator: str
    actuators: tuple[str, ...]

    @classmethod
    def of(cls, mechanism: type, parameters: Mapping[str, float], variables: Mapping[str, DesignVariable],
           indices: Mapping[str, Any], workspace_unit: str | None) -> "Units":
        """The table of a mechanism class with the fixed ``parameters`` (SI),
        the design-variable table, the indices (name -> its spec: ``kind``,
        ``convention``, ``options``, ``sense``, as a config's) and the
        workspace's unit (``deg``, ``mm`` or None)."""
        params = {**mechanism.fixed_parameters, **parameters}
        act = mechanism.actuator_unit(params)
        per = getattr(mechanism, "actuator_units", None)
        actuators = tuple(per(params)) if per is not None else (act,) * len(mechanism.actuator_names)
        poses = {a: _pose(mechanism.pose_unit(a), workspace_unit) for a in mechanism.pose_names}
        vunits = {k: _variable_unit(mechanism, dv) for k, dv in variables.items()}
        idx = {k: (_index_unit(mechanism, poses, act, spec), spec.sense) for k, spec in indices.items()}
        extras = {}
        for k, e in mechanism.extra_objectives.items():
            units = {vunits[p] for p in e.parameters if p in variables}
            if len(units) == 1 and e.parameters[0] in variables:
                extras[k] = (units.pop(), variables[e.parameters[0]].display(1.0), e.sense)
            else:
                extras[k] = ("m", 1.0, e.sense)
        return cls(dict(variables), vunits, poses, idx, extras, act, actuators)


def _variable_unit(mech, dv: DesignVariable) -> str:
    """The unit a design variable is shown in: the config's (``unit: deg``,
    ``mm``...) or, without one, its declaration's (m for lengths, rad for angles)."""
    if dv.unit:
        return dv.unit
    decl = mech.param(dv.name) if hasattr(mech, "param") else None
    if decl is not None:
        return decl.unit or DIMENSIONLESS
    if dv.name in getattr(mech, "angle_parameters", ()) or dv.name in _ANGLE_NAMES:
        return "rad"
    return "m"


def _pose(si: str, workspace_unit: str | None) -> tuple[str, str, float]:
    """(SI unit, unit shown, factor) of a pose axis: value_shown = value_SI * factor."""
    if si == "rad" and workspace_unit == "deg":
        return si, "deg", 180.0 / math.pi
    if si == "m" and workspace_unit == "mm":
        return si, "mm", 1e3
    return si, (DIMENSIONLESS if si == "1" else si), 1.0


def _force(u: str) -> str:
    """The generalized force conjugate to a coordinate in unit ``u``."""
    return "N m" if u == "rad" else "N"


def _ratio(num: str, den: str) -> str:
    if num == den:
        return DIMENSIONLESS
    if den == "1":
        return num
    if num == "1":
        return f"1/{den}"
    return f"{num}/{den}"


def _index_unit(mech, poses: Mapping[str, tuple], act: str, spec) -> str | None:
    """SI unit of a global index (the mean of its local values), or None where
    the mechanism's axes mix units and no single unit applies."""
    kind = spec.kind
    if kind in ("isotropy", "dexterity", "constraint"):
        return DIMENSIONLESS
    names = list(poses)
    if kind == "axis_stiffness":
        axis = names[int(spec.options.get("axis", 0))] if int(spec.options.get("axis", 0)) < len(names) else None
        pu = poses[axis][0] if axis else None
    else:
        common = {poses[a][0] for a in names}
        pu = common.pop() if len(common) == 1 else None
    if pu is None:
        return None
    if kind in ("stiffness", "axis_stiffness"):
        u = _ratio(_force(pu), pu)
        if spec.convention == "sqrt_lambda_min_K":
            return f"√({u})"
        return u
    if kind in ("manipulability", "driving"):
        n = len(names)
        r = _ratio(act, pu)
        if r == DIMENSIONLESS:
            return r
        sup = _SUP.get(n, f"^{n}")
        return f"{r}{sup}" if "/" not in r else f"({r}){sup}"
    if kind == "dynamic":
        f = _force(act)
        if f == "N" and pu == "m":
            return "kg"
        return f"{f} s²/{pu}"
    return None


def variable_unit(units: Units, name: str) -> str:
    """The unit a design variable is shown in: the config's (``unit: deg``,
    ``mm``...) or, without one, m for lengths and rad for angles."""
    return units.variable_units[name]


def pose_unit(units: Units, axis: str) -> str:
    """SI unit of a pose axis: m, rad or 1."""
    return units.poses[axis][0]


def pose_display(units: Units, axis: str) -> tuple[str, float]:
    """(unit, factor) to show a pose coordinate as the workspace gives it:
    value_shown = value_SI * factor (deg or mm where the workspace says so)."""
    return units.poses[axis][1:]


def actuator_unit(units: Units) -> str:
    """SI unit of the actuator values (m for prismatic joints and struts, rad for cranks)."""
    return units.actuator


def actuator_units(units: Units) -> list[str]:
    """SI unit of each actuator coordinate, in order (a described mechanism's
    legs may mix cranks, rad, and strokes, m)."""
    return list(units.actuators)


def index_unit(units: Units, name: str) -> str | None:
    """SI unit of a global index (the mean of its local values), or None where
    the mechanism's axes mix units and no single unit applies."""
    return units.indices[name][0]


def objective_unit(units: Units, term: str) -> tuple[str | None, float]:
    """(unit, factor) of an objective term (without a leading '-'): an index in
    SI, an extra objective (a function of design variables) in the unit of the
    variables it is made of when they share one."""
    k = term.lstrip("-")
    if k in units.indices:
        return index_unit(units, k), 1.0
    if k in units.extras:
        return units.extras[k][:2]
    return None, 1.0


def label(name: str, unit: str | None) -> str:
    """``name [unit]``; a dimensionless quantity says so with [–]."""
    return f"{name} [{unit}]" if unit else name


def index_label(units: Units, name: str, with_sense: bool = False) -> str:
    s = label(name, index_unit(units, name) if name in units.indices else objective_unit(units, name)[0])
    if with_sense:
        sense = units.indices[name][1] if name in units.indices else _extra_sense(units, name)
        s += " (max)" if sense == "max" else " (min)"
    return s


def _extra_sense(units: Units, name: str) -> str:
    e = units.extras.get(name)
    return e[2] if e is not None else "min"


# --------------------------------------------------------------------------- text and CSV columns
#: the unit named for an index whose pose axes mix units (each entry in its own SI unit)
MIXED = "SI, mixed"


def variable_label(units: Units, name: str) -> str:
    """``phi [deg]``: a design variable with the unit it is shown in."""
    return label(name, variable_unit(units, name))


def _num(x: float, digits: int = 6) -> str:
    return f"{float(x):.{digits}g}"


def design_text(units: Units, design: dict, free_only: bool = True, digits: int = 6) -> str:
    """``r_a = 0.2 m, phi = 35 deg``: SI parameters in the config's units."""
    parts = []
    for k, dv in units.variables.items():
        if k in design and (dv.free or not free_only):
            u = variable_unit(units, k)
            parts.append(f"{k} = {_num(dv.display(design[k]), digits)}" + ("" if u == DIMENSIONLESS else f" {u}"))
    return ", ".join(parts)


def index_text(units: Units, name: str, value: float, digits: int = 5) -> str:
    """``stiffness = 1.2e+06 N/m`` (an index's mean over W, SI)."""
    u = index_unit(units, name) if name in units.indices else objective_unit(units, name)[0]
    return f"{name} = {_num(value, digits)}" + ("" if not u or u == DIMENSIONLESS else f" {u}")


def constraint_unit(units: Units, name: str) -> str:
    """Unit of a constraint value g (``g <= 0`` feasible): the stroke limits in
    the actuators' unit, the others dimensionless."""
    return units.actuator if name.startswith("stroke") else DIMENSIONLESS


def _bracket(u: str | None) -> str:
    return f"[{u if u else MIXED}]"


def csv_column(units: Units, key: str, row_keys=()) -> tuple[str, float] | None:
    """The column a run's CSV file shows for an internal row key, and the
    factor from the internal (SI, minimized) value to the shown one; None to
    leave the column out (an index objective duplicates the index's own column).

    Design variables in the config's units, indices in SI with their unit,
    objectives in their own sense (a maximized index as itself), the constraint
    values g with their unit.  Other keys (generation, counts) are kept as they
    are."""
    extras = units.extras
    for prefix in ("best_", "mean_", ""):
        if prefix and not key.startswith(prefix):
            continue
        k = key[len(prefix):]
        if k in units.variables:
            dv = units.variables[k]
            return f"{prefix}{k} {_bracket(variable_unit(units, k))}", dv.display(1.0)
        if k in units.indices:
            return f"{prefix}{k} {_bracket(index_unit(units, k))}", 1.0
        if k.startswith("-") and (k[1:] in units.indices or k[1:] in extras):
            u, f = objective_unit(units, k[1:])
            return f"{prefix}{k[1:]} {_bracket(u)}", -f
        if k in extras:
            u, f = objective_unit(units, k)
            return f"{prefix}{k} {_bracket(u)}", f
    if key.startswith("objective_"):
        t = key[len("objective_"):]
        name = t.lstrip("-")
        if name in units.indices and name in row_keys:
            return None
        if name == "weighted_sum":
            return f"weighted_sum {_bracket(DIMENSIONLESS)}", 1.0
        return csv_column(units, t)
    if key.startswith("g_"):
        return f"{key} {_bracket(constraint_unit(units, key[2:]))}", 1.0
    if key in ("best_objective", "mean_objective"):
        return f"{key} {_bracket(DIMENSIONLESS)}", 1.0
    if key == "cv":
        return "cv [sum of g > 0]", 1.0
    return key, 1.0


def display_rows(units: Units, rows: list[dict], single: tuple[str, str] | None = None) -> list[dict]:
    """Rows with internal keys (SI, minimized objectives) as a CSV file shows
    them (see :func:`csv_column`).  ``single``: (index, sense) of a
    single-objective stage, whose objective is the index itself: its best is
    the ``best_<index>`` column and its population mean is shown as
    ``mean_<index>`` in the index's own sense."""
    if not rows:
        return []
    keys = list(rows[0])
    for r in rows[1:]:
        keys.extend(k for k in r if k not in keys)
    plan = []
    for k in keys:
        if single is not None and k == "best_objective":
            continue
        if single is not None and k == "mean_objective":
            col = csv_column(units, f"mean_{single[0]}")
            plan.append((k, col[0], -1.0 if single[1] == "max" else 1.0))
            continue
        col = csv_column(units, k, keys)
        if col is not None:
            plan.append((k, *col))
    out = []
    for r in rows:
        d = {}
        for k, head, f in plan:
            v = r.get(k)
            d[head] = v * f if isinstance(v, float) and f != 1.0 else v
        out.append(d)
    return out


def strip_unit(header: str) -> str:
    """The quantity's name of a CSV header (``phi [deg]`` -> ``phi``)."""
    h = header.strip()
    if h.endswith("]") and " [" in h:
        return h[:h.rindex(" [")]
    return h
