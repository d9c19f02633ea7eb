"""YAML configuration: parsing and validation into typed objects.

Every user mistake raises :class:`ConfigError` whose message is one line naming
the file, the key path and what was expected, for example::

    configs/x.yaml: design_variables.r_a.bounds: lower 0.3 is above upper 0.2

Units: lengths in metres, masses in kg, inertias in kg m^2.  Angles are radians
unless the entry says ``unit: deg``; everything is converted to SI on load.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import yaml

__all__ = [
    "ConfigError",
    "Config",
    "DesignVariable",
    "WorkspaceSpec",
    "IndexSpec",
    "OptimizerSpec",
    "load_config",
    "parse_config",
]


class ConfigError(ValueError):
    """A mistake in a configuration file (reported without a traceback)."""

    def __init__(self, source: str, path: str, message: str):
        self.source = source
        self.path = path
        self.message = message
        where = f"{source}: {path}: " if path else f"{source}: "
        super().__init__(where + message)


_UNITS = {"m": 1.0, "mm": 1e-3, "rad": 1.0, "deg": math.pi / 180.0, None: 1.0}


# --------------------------------------------------------------------------- helpers
class _Reader:
    """Typed access to a nested mapping that reports the key path on error."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, path: str, message: str):
        raise ConfigError(self.source, path, message)

    def mapping(self, value: Any, path: str) -> Mapping:
        if not isinstance(value, Mapping):
            self.fail(path, f"expected a mapping, got {_tname(value)}")
        for k in value:
            if not isinstance(k, str):
                self.fail(path, f"expected string keys, got key {k!r} ({_tname(k)})")
        return value

    def only(self, value: Mapping, path: str, allowed) -> None:
        for k in value:
            if k not in allowed:
                self.fail(_join(path, k), f"unknown key; expected one of {', '.join(sorted(allowed))}")

    def require(self, value: Mapping, key: str, path: str) -> Any:
        if key not in value:
            self.fail(_join(path, key), "missing required key")
        return value[key]

    def number(self, value: Any, path: str, *, positive=False, nonneg=False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"expected a number, got {_tname(value)}")
        try:
            x = float(value)
        except OverflowError:  # an integer beyond the float range
            self.fail(path, f"expected a number of sensible size, got {_show(value)}")
        if not math.isfinite(x):
            self.fail(path, f"expected a finite number, got {value!r}")
        if abs(x) > 1e12:
            self.fail(path, f"expected a number of sensible size, got {_show(value)}")
        if positive and x <= 0:
            self.fail(path, f"expected a positive number, got {value!r}")
        if nonneg and x < 0:
            self.fail(path, f"expected a non-negative number, got {value!r}")
        return x

    def integer(self, value: Any, path: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(path, f"expected an integer, got {_tname(value)}")
        if minimum is not None and value < minimum:
            self.fail(path, f"expected an integer >= {minimum}, got {_show(value)}")
        if maximum is not None and value > maximum:
            self.fail(path, f"expected an integer <= {maximum}, got {_show(value)}")
        return int(value)

    def string(self, value: Any, path: str, choices=None) -> str:
        if not isinstance(value, str):
            self.fail(path, f"expected a string, got {_tname(value)}")
        if choices is not None and value not in choices:
            self.fail(path, f"expected one of {', '.join(sorted(choices))}, got {value!r}")
        return value

    def boolean(self, value: Any, path: str) -> bool:
        if not isinstance(value, bool):
            self.fail(path, f"expected true or false, got {_tname(value)}")
        return value

    def pair(self, value: Any, path: str, *, scale=1.0, positive=False) -> tuple[float, float]:
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            self.fail(path, f"expected a list [lower, upper], got {_tname(value)}")
        lo = self.number(value[0], _join(path, 0), positive=positive) * scale
        hi = self.number(value[1], _join(path, 1), positive=positive) * scale
        if lo > hi:
            self.fail(path, f"lower {value[0]} is above upper {value[1]}")
        return lo, hi

    def unit(self, value: Any, path: str, allowed=("m", "mm", "rad", "deg")) -> str | None:
        if value is None:
            return None
        return self.string(value, path, choices=set(allowed))


def _tname(v: Any) -> str:
    if v is None:
        return "nothing (null)"
    if isinstance(v, list):
        return f"a list of {len(v)} item{'s' if len(v) != 1 else ''}"
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string",
            list: "a list", dict: "a mapping"}.get(type(v), type(v).__name__)


def _show(v: Any) -> str:
    """repr of a value for a message; integers too long to print are described."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10 ** 15:
        return f"an integer of about {int(abs(v).bit_length() * 0.30103) + 1} digits"
    return repr(v)


def _join(path: str, key) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


# --------------------------------------------------------------------------- schema
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
        return x / _UNITS[self.unit] if self.unit in ("deg", "mm") else x


@dataclass(frozen=True)
class WorkspaceSpec:
    """The region W of the task space over which global indices are averaged.

    ``type`` is ``box`` (every axis a range or a fixed value: a fixed axis makes
    a plane or a line) or ``cylinder`` (radius around ``center`` in the first
    two axes, a range or a value on the third).  ``sampling`` is ``grid``
    (``step`` or ``points_per_axis``) or ``sobol``/``halton``/``lhs``/``random``
    (``points``, ``seed``).  All values SI (radians for angular axes unless
    ``unit: deg``).
    """

    type: str
    axes: dict[str, tuple[float, float]]  # name -> (lo, hi); lo == hi fixes the axis
    sampling: str = "grid"
    step: float | None = None
    points_per_axis: int | None = None
    points: int | None = None
    seed: int = 0
    radius: float | None = None
    center: tuple[float, float] = (0.0, 0.0)
    unit: str | None = None


@dataclass(frozen=True)
class IndexSpec:
    """A performance index as the config names it."""

    name: str
    kind: str
    convention: str | None
    sense: str  # "min" or "max"
    options: dict = field(default_factory=dict)


@dataclass(frozen=True)
class OptimizerSpec:
    """Settings of the weighted-sum GA and of the Pareto runs (see optdesign.optimize)."""

    algorithm: str = "paper_ga"
    population: int = 50
    generations: int = 100
    crossover_probability: float = 0.8
    elites: int = 2
    mutation_probability: float = 0.2
    fitness_scaling: str = "rank"
    seed: int = 1
    weights: dict[str, float] = field(default_factory=dict)
    normalization: str = "sense"  # or "paper_literal"
    pareto_algorithms: tuple[str, ...] = ("nsga2", "nsga3")
    pareto_population: int = 100
    pareto_generations: int = 100
    extra_objectives: tuple[str, ...] = ()
    singularity_threshold: float = 1e3
    stroke_limits: tuple[float, float] | None = None
    min_transmission: float = 0.0
    checkpoint_interval: float = 1.0  # s between GA checkpoints; 0 = after every generation


@dataclass
class Config:
    """A validated configuration.  All values are SI."""

    source: str
    mechanism: str
    name: str
    parameters: dict[str, float]
    design_variables: dict[str, DesignVariable]
    designs: dict[str, dict[str, float]]
    workspace: WorkspaceSpec
    indices: dict[str, IndexSpec]
    optimizer: OptimizerSpec
    reference: dict[str, dict[str, float]]
    raw: dict

    @property
    def free_variables(self) -> list[DesignVariable]:
        return [v for v in self.design_variables.values() if v.free]

    def design(self, name: str) -> dict[str, float]:
        if name not in self.designs:
            raise ConfigError(self.source, "designs", f"no design named {name!r}; the config has {', '.join(self.designs) or 'none'}")
        return dict(self.designs[name])

    def initial_design(self) -> dict[str, float]:
        return {k: v.value for k, v in self.design_variables.items()}

    def mechanism_kwargs(self, design: Mapping[str, float]) -> dict[str, Any]:
        kw = dict(self.parameters)
        kw.update(design)
        return kw

    def build(self, design: Mapping[str, Any] | str):
        """The mechanism of this config for a named design or a parameter mapping."""
        from .mechanisms import get

        if isinstance(design, str):
            design = self.design(design)
        return get(self.mechanism)(**self.mechanism_kwargs(design))


# --------------------------------------------------------------------------- parsing
_TOP_KEYS = {"mechanism", "name", "description", "parameters", "design_variables", "designs",
             "workspace", "indices", "optimizer", "reference"}
_WS_KEYS = {"type", "axes", "sampling", "step", "points_per_axis", "points", "seed", "radius",
            "center", "unit"}
_SAMPLING = {"grid", "sobol", "halton", "lhs", "random"}
_OPT_KEYS = {"algorithm", "population", "generations", "crossover_probability", "elites", "fitness_scaling",
             "mutation_probability", "seed", "weights", "normalization", "pareto",
             "extra_objectives", "singularity_threshold", "stroke_limits", "min_transmission",
             "checkpoint_interval"}


def load_config(path: str | os.PathLike) -> Config:
    """Read and validate a YAML config file.  Raises ConfigError on any mistake."""
    source = str(path)
    p = Path(path)
    if not p.exists():
        raise ConfigError(source, "", "file not found")
    if p.is_dir():
        raise ConfigError(source, "", "is a directory, expected a YAML file")
    try:
        raw_bytes = p.read_bytes()
    except OSError as exc:
        raise ConfigError(source, "", f"cannot read file ({exc.strerror})") from None
    try:
        text = raw_bytes.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(source, "", "not a text file (expected UTF-8 YAML)") from None
    if "\x00" in text:
        raise ConfigError(source, "", "not a text file (contains NUL bytes)")
    return parse_config(text, source=source)


def parse_config(text: str, source: str = "<string>") -> Config:
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or "invalid YAML"
        raise ConfigError(source, "", f"YAML syntax error{where}: {problem}") from None
    except (RecursionError, ValueError, TypeError) as exc:  # hostile YAML
        raise ConfigError(source, "", f"YAML could not be read: {type(exc).__name__}") from None
    if data is None:
        raise ConfigError(source, "", "empty file; expected a mapping with at least 'mechanism', 'design_variables', 'workspace' and 'indices'")
    return _from_mapping(data, source)


def _from_mapping(data: Any, source: str) -> Config:
    from .indices import INDEX_KINDS
    from .mechanisms import available, get

    r = _Reader(source)
    data = r.mapping(data, "")
    if not isinstance(data, dict):
        data = dict(data)
    r.only(data, "", _TOP_KEYS)
    mech_name = r.require(data, "mechanism", "")
    described = isinstance(mech_name, Mapping)
    if described:  # a mechanism described as data (optdesign/mechanisms/described)
        mech_name = _register_described(r, mech_name, data.get("name"))
    mech_name = r.string(mech_name, "mechanism")
    if not described and mech_name not in available():
        r.fail("mechanism", f"unknown mechanism {mech_name!r}; expected one of {', '.join(available())}")
    mech_cls = get(mech_name)
    name = data.get("name", Path(source).stem if source != "<string>" else mech_name)
    name = r.string(name, "name")
    if data.get("description") is not None:
        r.string(data["description"], "description")

    # fixed parameters
    params: dict[str, float] = {}
    known_fixed = dict(mech_cls.fixed_parameters)
    if "parameters" in data and data["parameters"] is not None:
        pm = r.mapping(data["parameters"], "parameters")
        r.only(pm, "parameters", set(known_fixed))
        for k, v in pm.items():
            params[k] = _param_value(r, v, f"parameters.{k}", mech_cls, k)
        problem = getattr(mech_cls, "check_parameters", lambda p: None)(params)
        if problem:
            r.fail(f"parameters.{problem[0]}", problem[1])

    # design variables
    dv_raw = r.mapping(r.require(data, "design_variables", ""), "design_variables")
    allowed_dv = set(mech_cls.design_parameters)
    r.only(dv_raw, "design_variables", allowed_dv)
    dvs: dict[str, DesignVariable] = {}
    for k in mech_cls.design_parameters:
        path = f"design_variables.{k}"
        if k not in dv_raw:
            if k in mech_cls.design_defaults:
                dvs[k] = DesignVariable(k, float(mech_cls.design_defaults[k]), None)
                continue
            r.fail(path, "missing required design variable")
        dvs[k] = _design_variable(r, k, dv_raw[k], path, mech_cls)

    # named designs
    designs: dict[str, dict[str, float]] = {}
    if data.get("designs") is not None:
        ds = r.mapping(data["designs"], "designs")
        for dname, dval in ds.items():
            dpath = f"designs.{dname}"
            dm = r.mapping(dval, dpath)
            r.only(dm, dpath, allowed_dv)
            design = {k: v.value for k, v in dvs.items()}
            for k, v in dm.items():
                scale = _UNITS[dvs[k].unit]
                x = r.number(v, f"{dpath}.{k}") * scale
                design[k] = x
            _check_design(r, mech_cls, design, dpath)
            designs[dname] = design
    _check_design(r, mech_cls, {k: v.value for k, v in dvs.items()}, "design_variables")
    if "initial" not in designs:
        designs = {"initial": {k: v.value for k, v in dvs.items()}, **designs}
    if described:  # the description's expressions and legs with these parameters and designs
        problem = mech_cls.check_config(params, designs)
        if problem:
            r.fail(*problem)

    workspace = _workspace(r, r.require(data, "workspace", ""), mech_cls)

    # indices
    idx_raw = r.mapping(r.require(data, "indices", ""), "indices")
    if not idx_raw:
        r.fail("indices", "expected at least one index")
    indices: dict[str, IndexSpec] = {}
    for iname, ival in idx_raw.items():
        ipath = f"indices.{iname}"
        im = r.mapping(ival if ival is not None else {}, ipath)
        r.only(im, ipath, {"kind", "convention", "sense", "options"})
        kind = r.string(im.get("kind", iname), f"{ipath}.kind")
        if kind not in INDEX_KINDS:
            r.fail(f"{ipath}.kind", f"unknown index {kind!r}; expected one of {', '.join(sorted(INDEX_KINDS))}")
        spec = INDEX_KINDS[kind]
        conv = im.get("convention", spec.default_convention)
        if spec.conventions:
            conv = r.string(conv, f"{ipath}.convention", choices=set(spec.conventions))
        elif conv is not None:
            r.fail(f"{ipath}.convention", f"index {kind!r} has no conventions")
        if kind not in mech_cls.supported_indices:
            r.fail(f"{ipath}.kind", f"index {kind!r} is not available for mechanism {mech_name!r}; expected one of {', '.join(mech_cls.supported_indices)}")
        sense = r.string(im.get("sense", spec.sense), f"{ipath}.sense", choices={"min", "max"})
        opts = im.get("options", {}) or {}
        opts = dict(r.mapping(opts, f"{ipath}.options"))
        for ok, ov in opts.items():
            opts[ok] = r.number(ov, f"{ipath}.options.{ok}", positive=(ok == "k"))
        # the joint stiffness k of K = J^T k J: the mechanism's parameter unless the index sets its own
        if kind in ("stiffness", "axis_stiffness") and "k" not in opts and "k" in mech_cls.fixed_parameters:
            opts["k"] = float(params.get("k", mech_cls.fixed_parameters["k"]))
        indices[iname] = IndexSpec(iname, kind, conv, sense, opts)

    optimizer = _optimizer(r, data.get("optimizer"), dvs, indices)

    reference: dict[str, dict[str, float]] = {}
    if data.get("reference") is not None:
        ref = r.mapping(data["reference"], "reference")
        for dname, vals in ref.items():
            rpath = f"reference.{dname}"
            vm = r.mapping(vals, rpath)
            reference[dname] = {}
            for k, v in vm.items():
                if k not in indices and k != "objective":
                    r.fail(f"{rpath}.{k}", f"unknown index; expected one of {', '.join(indices)}")
                reference[dname][k] = r.number(v, f"{rpath}.{k}")

    return Config(source=source, mechanism=mech_name, name=name, parameters=params,
                  design_variables=dvs, designs=designs, workspace=workspace, indices=indices,
                  optimizer=optimizer, reference=reference, raw=dict(data))


def _register_described(r: _Reader, raw: Mapping, name: Any) -> str:
    """Validate a mechanism description and register its class; its registry name."""
    from .mechanisms.described import DescriptionError, register_description

    try:
        return register_description(raw, label=name if isinstance(name, str) else None)
    except DescriptionError as exc:
        r.fail(exc.path, exc.message)


def _param_value(r: _Reader, v: Any, path: str, mech_cls, key: str) -> float:
    if isinstance(v, Mapping):
        r.only(v, path, {"value", "unit"})
        unit = r.unit(v.get("unit"), f"{path}.unit")
        x = r.number(r.require(v, "value", path), f"{path}.value") * _UNITS[unit]
    else:
        x = r.number(v, path)
    if key in getattr(mech_cls, "positive_parameters", ()) and x <= 0:
        r.fail(path, f"expected a positive value, got {x:g}")
    if key in getattr(mech_cls, "nonnegative_parameters", ()) and x < 0:
        r.fail(path, f"expected a non-negative value, got {x:g}")
    return x


def _design_variable(r: _Reader, name: str, v: Any, path: str, mech_cls) -> DesignVariable:
    if not isinstance(v, Mapping):
        x = r.number(v, path)
        return DesignVariable(name, x, None)
    r.only(v, path, {"value", "bounds", "unit"})
    unit = r.unit(v.get("unit"), f"{path}.unit")
    scale = _UNITS[unit]
    value = r.number(r.require(v, "value", path), f"{path}.value") * scale
    bounds = None
    if v.get("bounds") is not None:
        bounds = r.pair(v["bounds"], f"{path}.bounds", scale=scale)
        if not (bounds[0] <= value <= bounds[1]):
            r.fail(f"{path}.value", f"value {v['value']} is outside the bounds {list(v['bounds'])}")
    if name in mech_cls.length_parameters:
        lo = bounds[0] if bounds else value
        if lo <= 0:
            r.fail(f"{path}.bounds" if bounds and value > 0 else f"{path}.value", f"expected a positive length, got {lo / scale:g}")
    return DesignVariable(name, value, bounds, unit)


def _check_design(r: _Reader, mech_cls, design: dict, path: str) -> None:
    for k in mech_cls.length_parameters:
        if k in design and design[k] <= 0:
            r.fail(f"{path}.{k}", f"expected a positive length, got {design[k]:g}")
    problem = mech_cls.check_design(design)
    if problem:
        key, msg = problem
        r.fail(f"{path}.{key}" if key else path, msg)


def _workspace(r: _Reader, ws: Any, mech_cls) -> WorkspaceSpec:
    path = "workspace"
    ws = r.mapping(ws, path)
    r.only(ws, path, _WS_KEYS)
    wtype = r.string(ws.get("type", "box"), f"{path}.type", choices={"box", "cylinder"})
    unit = r.unit(ws.get("unit"), f"{path}.unit")
    scale = _UNITS[unit]
    axes_raw = r.mapping(r.require(ws, "axes", path), f"{path}.axes")
    names = tuple(mech_cls.pose_names)
    r.only(axes_raw, f"{path}.axes", set(names))
    axes: dict[str, tuple[float, float]] = {}
    for a in names:
        apath = f"{path}.axes.{a}"
        if a not in axes_raw:
            if wtype == "cylinder" and a in names[:2]:
                continue
            r.fail(apath, "missing required axis (a value or a [lower, upper] range)")
        val = axes_raw[a]
        if isinstance(val, (list, tuple)):
            axes[a] = r.pair(val, apath, scale=scale)
        else:
            x = r.number(val, apath) * scale
            axes[a] = (x, x)
    radius = None
    center = (0.0, 0.0)
    if wtype == "cylinder":
        radius = r.number(r.require(ws, "radius", path), f"{path}.radius", positive=True) * scale
        if "center" in ws:
            c = ws["center"]
            if not isinstance(c, (list, tuple)) or len(c) != 2:
                r.fail(f"{path}.center", f"expected a list [x, y], got {_tname(c)}")
            center = (r.number(c[0], f"{path}.center[0]") * scale, r.number(c[1], f"{path}.center[1]") * scale)
        for a in names[:2]:
            if a in axes_raw:
                r.fail(f"{path}.axes.{a}", "a cylinder takes its first two axes from radius and center; remove this axis")
    sampling = r.string(ws.get("sampling", "grid"), f"{path}.sampling", choices=_SAMPLING)
    step = ppa = pts = None
    if sampling == "grid":
        if "step" in ws:
            step = r.number(ws["step"], f"{path}.step", positive=True) * scale
        elif "points_per_axis" in ws:
            ppa = r.integer(ws["points_per_axis"], f"{path}.points_per_axis", minimum=1, maximum=10_000)
        else:
            r.fail(f"{path}.step", "a grid needs 'step' or 'points_per_axis'")
        if step is not None:
            total = 1
            for lo, hi in axes.values():
                total *= int(math.floor((hi - lo) / step + 1e-9)) + 1
            if wtype == "cylinder":
                total *= int(2 * radius / step + 1) ** 2
            if total > 50_000_000:
                r.fail(f"{path}.step", f"step {ws['step']} gives {_show(total)} grid points; expected at most 50,000,000")
    else:
        pts = r.integer(r.require(ws, "points", path), f"{path}.points", minimum=1, maximum=50_000_000)
    seed = r.integer(ws.get("seed", 0), f"{path}.seed", minimum=0)
    return WorkspaceSpec(type=wtype, axes=axes, sampling=sampling, step=step, points_per_axis=ppa,
                         points=pts, seed=seed, radius=radius, center=center, unit=unit)


def _optimizer(r: _Reader, opt: Any, dvs: dict, indices: dict) -> OptimizerSpec:
    from .optimize.objectives import EXTRA_OBJECTIVES

    path = "optimizer"
    if opt is None:
        return OptimizerSpec(weights={k: 1.0 for k in indices})
    opt = r.mapping(opt, path)
    r.only(opt, path, _OPT_KEYS)
    kw: dict[str, Any] = {}
    if "algorithm" in opt:
        kw["algorithm"] = r.string(opt["algorithm"], f"{path}.algorithm", choices={"paper_ga", "pymoo_ga"})
    for key, lo in (("population", 4), ("generations", 1), ("elites", 0)):
        if key in opt:
            kw[key] = r.integer(opt[key], f"{path}.{key}", minimum=lo, maximum=100_000)
    if "elites" in kw and kw["elites"] >= kw.get("population", 50):
        r.fail(f"{path}.elites", f"expected fewer elites than the population ({kw.get('population', 50)}), got {kw['elites']}")
    for key in ("crossover_probability", "mutation_probability"):
        if key in opt:
            x = r.number(opt[key], f"{path}.{key}")
            if not 0 <= x <= 1:
                r.fail(f"{path}.{key}", f"expected a probability in [0, 1], got {x:g}")
            kw[key] = x
    if "seed" in opt:
        kw["seed"] = r.integer(opt["seed"], f"{path}.seed", minimum=0, maximum=2**32 - 1)
    if "fitness_scaling" in opt:
        kw["fitness_scaling"] = r.string(opt["fitness_scaling"], f"{path}.fitness_scaling", choices={"rank", "linear"})
    weights = {k: 1.0 for k in indices}
    if "weights" in opt:
        wm = r.mapping(opt["weights"], f"{path}.weights")
        for k, v in wm.items():
            if k not in indices:
                r.fail(f"{path}.weights.{k}", f"unknown index; expected one of {', '.join(indices)}")
            weights[k] = r.number(v, f"{path}.weights.{k}", nonneg=True)
        if sum(weights.values()) <= 0:
            r.fail(f"{path}.weights", "expected at least one positive weight")
    kw["weights"] = weights
    if "normalization" in opt:
        kw["normalization"] = r.string(opt["normalization"], f"{path}.normalization", choices={"sense", "paper_literal"})
    if "pareto" in opt and opt["pareto"] is not None:
        pm = r.mapping(opt["pareto"], f"{path}.pareto")
        r.only(pm, f"{path}.pareto", {"algorithms", "population", "generations"})
        if "algorithms" in pm:
            algs = pm["algorithms"]
            if not isinstance(algs, list):
                r.fail(f"{path}.pareto.algorithms", f"expected a list, got {_tname(algs)}")
            kw["pareto_algorithms"] = tuple(r.string(a, f"{path}.pareto.algorithms[{i}]", choices={"nsga2", "nsga3"}) for i, a in enumerate(algs))
        if "population" in pm:
            kw["pareto_population"] = r.integer(pm["population"], f"{path}.pareto.population", minimum=4, maximum=100_000)
        if "generations" in pm:
            kw["pareto_generations"] = r.integer(pm["generations"], f"{path}.pareto.generations", minimum=1, maximum=100_000)
    if "extra_objectives" in opt:
        eo = opt["extra_objectives"]
        if not isinstance(eo, list):
            r.fail(f"{path}.extra_objectives", f"expected a list, got {_tname(eo)}")
        kw["extra_objectives"] = tuple(r.string(x, f"{path}.extra_objectives[{i}]", choices=set(EXTRA_OBJECTIVES)) for i, x in enumerate(eo))
    if "singularity_threshold" in opt:
        kw["singularity_threshold"] = r.number(opt["singularity_threshold"], f"{path}.singularity_threshold", positive=True)
    if "stroke_limits" in opt:
        kw["stroke_limits"] = r.pair(opt["stroke_limits"], f"{path}.stroke_limits")
    if "min_transmission" in opt:
        x = r.number(opt["min_transmission"], f"{path}.min_transmission", nonneg=True)
        if x >= 1:
            r.fail(f"{path}.min_transmission", f"expected a value in [0, 1), got {x:g}")
        kw["min_transmission"] = x
    if "checkpoint_interval" in opt:
        kw["checkpoint_interval"] = r.number(opt["checkpoint_interval"], f"{path}.checkpoint_interval", nonneg=True)
    return OptimizerSpec(**kw)
