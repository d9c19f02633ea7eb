"""Units of what a user sees: design variables in the config's units, pose
axes in the workspace's, indices and objectives in SI with the unit named.
Shared by results.md, the CSV files, the PNGs, the printed output and
report.html, so that they all name the same unit for the same quantity.

Index units follow from the mechanism's matrices: J maps pose rates to
actuator rates (actuator unit / pose unit), M maps pose accelerations to
actuator forces, K = J^T k J maps pose displacements to the generalized force
conjugate to the pose (N for a length, N m for an angle).  The mechanism
declares them: ``pose_units`` (axis -> unit; angular axes rad, others m by
default) and ``actuator_unit(params)`` (m unless the mechanism says otherwise),
as ``Mechanism.pose_unit`` and ``Mechanism.actuator_unit`` say.
"""
from __future__ import annotations

from .config import Config, DesignVariable
from .evaluate import mechanism_class

__all__ = ["DIMENSIONLESS", "MIXED", "variable_unit", "pose_unit", "pose_display", "index_unit", "objective_unit",
           "label", "index_label", "variable_label", "design_text", "index_text", "constraint_unit", "csv_column",
           "display_rows", "strip_unit", "actuator_unit", "actuator_units"]

#: shown for a dimensionless quantity
DIMENSIONLESS = "–"

#: design variables that are angles when the config gives no unit (radians)
_ANGLE_NAMES = ("phi", "theta", "psi", "delta", "alpha", "beta", "gamma")
_SUP = {2: "²", 3: "³", 4: "⁴", 5: "⁵", 6: "⁶"}


def _mech(cfg: Config):
    return mechanism_class(cfg)


def variable_unit(cfg: Config, name: str) -> str:
    """The unit a design variable is shown in: the config's (``unit: deg``,
    ``mm``...) or, without one, m for lengths and rad for angles."""
    dv: DesignVariable = cfg.design_variables[name]
    if dv.unit:
        return dv.unit
    mech = _mech(cfg)
    decl = mech.param(name) if hasattr(mech, "param") else None
    if decl is not None:
        return decl.unit or DIMENSIONLESS
    if name in getattr(mech, "angle_parameters", ()) or name in _ANGLE_NAMES:
        return "rad"
    return "m"


def pose_unit(cfg: Config, axis: str) -> str:
    """SI unit of a pose axis: m, rad or 1."""
    return _mech(cfg).pose_unit(axis)


def pose_display(cfg: Config, axis: str) -> tuple[str, float]:
    """(unit, factor) to show a pose coordinate as the workspace gives it:
    value_shown = value_SI * factor (deg or mm where the workspace says so)."""
    import math

    si = pose_unit(cfg, axis)
    wu = cfg.workspace.unit
    if si == "rad" and wu == "deg":
        return "deg", 180.0 / math.pi
    if si == "m" and wu == "mm":
        return "mm", 1e3
    return (DIMENSIONLESS if si == "1" else si), 1.0


def _actuator_unit(cfg: Config) -> str:
    mech = _mech(cfg)
    return mech.actuator_unit({**mech.fixed_parameters, **cfg.parameters})


def actuator_unit(cfg: Config) -> str:
    """SI unit of the actuator values (m for prismatic joints and struts, rad for cranks)."""
    return _actuator_unit(cfg)


def actuator_units(cfg: Config) -> list[str]:
    """SI unit of each actuator coordinate, in order (a described mechanism's
    legs may mix cranks, rad, and strokes, m)."""
    mech = _mech(cfg)
    params = {**mech.fixed_parameters, **cfg.parameters}
    per = getattr(mech, "actuator_units", None)
    return list(per(params)) if per is not None else [mech.actuator_unit(params)] * len(mech.actuator_names)


def _pose_common(cfg: Config, axes=None) -> str | None:
    names = axes if axes is not None else _mech(cfg).pose_names
    units = {pose_unit(cfg, a) for a in names}
    return units.pop() if len(units) == 1 else None


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


def index_unit(cfg: Config, name: str) -> str | None:
    """SI unit of a global index (the mean of its local values), or None where
    the mechanism's axes mix units and no single unit applies."""
    spec = cfg.indices[name]
    kind = spec.kind
    if kind in ("isotropy", "dexterity"):
        return DIMENSIONLESS
    act = _actuator_unit(cfg)
    if kind == "axis_stiffness":
        names = _mech(cfg).pose_names
        axis = names[int(spec.options.get("axis", 0))] if int(spec.options.get("axis", 0)) < len(names) else None
        pu = pose_unit(cfg, axis) if axis else None
    else:
        pu = _pose_common(cfg)
    if pu is None:
        return None
    if kind in ("stiffness", "axis_stiffness"):
        u = _ratio(_force(pu), pu)
        if spec.convention == "sqrt_lambda_min_K":
            return f"√({u})"
        return u
    if kind in ("manipulability", "driving"):
        n = len(_mech(cfg).pose_names)
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


def objective_unit(cfg: Config, term: str) -> tuple[str | None, float]:
    """(unit, factor) of an objective term (without a leading '-'): an index in
    SI, an extra objective (a function of design variables) in the unit of the
    variables it is made of when they share one."""
    k = term.lstrip("-")
    if k in cfg.indices:
        return index_unit(cfg, k), 1.0
    extras = _mech(cfg).extra_objectives
    if k in extras:
        params = extras[k].parameters
        units = {variable_unit(cfg, p) for p in params if p in cfg.design_variables}
        if len(units) == 1:
            u = units.pop()
            dv = cfg.design_variables[params[0]]
            return u, dv.display(1.0)
        return "m", 1.0
    return None, 1.0


def label(name: str, unit: str | None) -> str:
    """``name [unit]``; a dimensionless quantity says so with [–]."""
    return f"{name} [{unit}]" if unit else name


def index_label(cfg: Config, name: str, with_sense: bool = False) -> str:
    s = label(name, index_unit(cfg, name) if name in cfg.indices else objective_unit(cfg, name)[0])
    if with_sense:
        sense = cfg.indices[name].sense if name in cfg.indices else _extra_sense(cfg, name)
        s += " (max)" if sense == "max" else " (min)"
    return s


def _extra_sense(cfg: Config, name: str) -> str:
    e = _mech(cfg).extra_objectives.get(name)
    return e.sense if e is not None else "min"


# --------------------------------------------------------------------------- text and CSV columns
#: the unit named for an index whose pose axes mix units (each entry in its own SI unit)
MIXED = "SI, mixed"


def variable_label(cfg: Config, name: str) -> str:
    """``phi [deg]``: a design variable with the unit it is shown in."""
    return label(name, variable_unit(cfg, name))


def _num(x: float, digits: int = 6) -> str:
    return f"{float(x):.{digits}g}"


def design_text(cfg: Config, design: dict, free_only: bool = True, digits: int = 6) -> str:
    """``r_a = 0.2 m, phi = 35 deg``: SI parameters in the config's units."""
    parts = []
    for k, dv in cfg.design_variables.items():
        if k in design and (dv.free or not free_only):
            u = variable_unit(cfg, k)
            parts.append(f"{k} = {_num(dv.display(design[k]), digits)}" + ("" if u == DIMENSIONLESS else f" {u}"))
    return ", ".join(parts)


def index_text(cfg: Config, name: str, value: float, digits: int = 5) -> str:
    """``stiffness = 1.2e+06 N/m`` (an index's mean over W, SI)."""
    u = index_unit(cfg, name) if name in cfg.indices else objective_unit(cfg, name)[0]
    return f"{name} = {_num(value, digits)}" + ("" if not u or u == DIMENSIONLESS else f" {u}")


def constraint_unit(cfg: Config, name: str) -> str:
    """Unit of a constraint value g (``g <= 0`` feasible): the stroke limits in
    the actuators' unit, the others dimensionless."""
    return _actuator_unit(cfg) if name.startswith("stroke") else DIMENSIONLESS


def _bracket(u: str | None) -> str:
    return f"[{u if u else MIXED}]"


def csv_column(cfg: Config, key: str, row_keys=()) -> tuple[str, float] | None:
    """The column a run's CSV file shows for an internal row key, and the
    factor from the internal (SI, minimized) value to the shown one; None to
    leave the column out (an index objective duplicates the index's own column).

    Design variables in the config's units, indices in SI with their unit,
    objectives in their own sense (a maximized index as itself), the constraint
    values g with their unit.  Other keys (generation, counts) are kept as they
    are."""
    extras = _mech(cfg).extra_objectives
    for prefix in ("best_", "mean_", ""):
        if prefix and not key.startswith(prefix):
            continue
        k = key[len(prefix):]
        if k in cfg.design_variables:
            dv = cfg.design_variables[k]
            return f"{prefix}{k} {_bracket(variable_unit(cfg, k))}", dv.display(1.0)
        if k in cfg.indices:
            return f"{prefix}{k} {_bracket(index_unit(cfg, k))}", 1.0
        if k.startswith("-") and (k[1:] in cfg.indices or k[1:] in extras):
            u, f = objective_unit(cfg, k[1:])
            return f"{prefix}{k[1:]} {_bracket(u)}", -f
        if k in extras:
            u, f = objective_unit(cfg, k)
            return f"{prefix}{k} {_bracket(u)}", f
    if key.startswith("objective_"):
        t = key[len("objective_"):]
        name = t.lstrip("-")
        if name in cfg.indices and name in row_keys:
            return None
        if name == "weighted_sum":
            return f"weighted_sum {_bracket(DIMENSIONLESS)}", 1.0
        return csv_column(cfg, t)
    if key.startswith("g_"):
        return f"{key} {_bracket(constraint_unit(cfg, key[2:]))}", 1.0
    if key in ("best_objective", "mean_objective"):
        return f"{key} {_bracket(DIMENSIONLESS)}", 1.0
    if key == "cv":
        return "cv [sum of g > 0]", 1.0
    return key, 1.0


def display_rows(cfg: Config, rows: list[dict], single: tuple[str, str] | None = None) -> list[dict]:
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
            col = csv_column(cfg, f"mean_{single[0]}")
            plan.append((k, col[0], -1.0 if single[1] == "max" else 1.0))
            continue
        col = csv_column(cfg, k, keys)
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
