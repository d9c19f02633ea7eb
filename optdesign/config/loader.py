"""YAML configuration: reading and validation into typed objects.

Every user mistake raises :class:`ConfigError` whose message is one line naming
the file, the key path and what was expected, for example::

    configs/x.yaml: design_variables.r_a.bounds: lower 0.3 is above upper 0.2

Units: SI (m, kg, kg m^2, N/m, rad) unless an entry says ``unit:`` (mm for a
length, deg for an angle, as the mechanism's parameter table allows);
everything is converted to SI on load.  The mechanism's parameter table
(:mod:`optdesign.mechanisms.params`) gives the keys, units and valid ranges.
"""
from __future__ import annotations

import itertools
import os
from pathlib import Path
from typing import Any, Mapping

from ..names import name_problem, safe_default_name
from . import yamlsafe
from .checks import checks_section
from .keys import TOP
from .reader import SMALLEST, UNITS, ConfigError, Reader, join, show, suggest
from .schema import Config, DesignVariable, IndexSpec
from .sections import optimizer_section, workspace_section

__all__ = ["load_config", "parse_config", "from_mapping"]

TOP_KEYS = TOP.allowed()


def load_config(path: str | os.PathLike) -> Config:
    """Read and validate a YAML config file.  Raises ConfigError on any mistake.

    The file is read by :mod:`.yamlsafe` (a regular UTF-8 file of at most
    1 MB; no duplicate keys, bounded aliases, YAML 1.2 scalars); the
    Config's ``text`` is the text read, the one a run folder keeps."""
    source = str(path)
    text = yamlsafe.read_file(path, what="YAML config file")
    cfg = parse_config(text, source=source)
    cfg.text = text
    return cfg


def parse_config(text: str, source: str = "<string>", run_folder: bool = False) -> Config:
    """A validated Config from the text of a config file (see :func:`load_config`);
    ``run_folder``: the config.yaml of a run folder, whose keys removed since
    (``optimizer.normalization``, ``optimizer.min_transmission``) are ignored."""
    if len(text) > yamlsafe.MAX_BYTES:
        raise ConfigError(source, "", f"a config of {len(text):,} characters; expected at most {yamlsafe.MAX_BYTES:,}")
    data = yamlsafe.load(text, source)
    if data is None:
        raise ConfigError(source, "", "empty file; expected a mapping with at least 'mechanism', 'design_variables', 'workspace' and 'indices'")
    return from_mapping(data, source, run_folder=run_folder)


def _mechanism(r: Reader, value: Any, label: Any = None):
    """(name, class) of the config's ``mechanism``: a registered name, or a
    description (a mapping) from which the class is built
    (optdesign/mechanisms/described; ``label``: the config's name)."""
    from ..mechanisms import available, get

    if isinstance(value, Mapping):
        from ..mechanisms import DescriptionError, describe

        try:
            cls = describe(value, label=label if isinstance(label, str) else None)
        except DescriptionError as exc:
            r.fail(exc.path, exc.message)
        return cls.name, cls
    mech_name = r.string(value, "mechanism")
    if mech_name not in available():
        r.fail("mechanism", f"unknown mechanism {show(mech_name)}{suggest(mech_name, available())}; "
                            f"expected one of {', '.join(available())}")
    return mech_name, get(mech_name)


def from_mapping(data: Any, source: str, run_folder: bool = False) -> Config:
    """A validated Config from parsed YAML (a mapping, as ``yaml.safe_load`` gives)."""
    from ..indices import INDEX_KINDS

    r = Reader(source)
    data = r.mapping(data, "")
    if not isinstance(data, dict):
        data = dict(data)
    r.only(data, "", TOP_KEYS)
    label = _name(r, data["name"], "name") if "name" in data else None
    mech_name, mech_cls = _mechanism(r, r.require(data, "mechanism", ""), label)
    if label is not None:
        name = label
    else:    # the file's name, made safe as a folder name
        name = safe_default_name(Path(source).stem, mech_name) if source != "<string>" else mech_name
    if data.get("description") is not None:
        TOP["description"].read(r, data["description"], "description")

    # fixed parameters
    params: dict[str, float] = {}
    known_fixed = dict(mech_cls.fixed_parameters)
    if "parameters" in data and data["parameters"] is not None:
        pm = r.mapping(data["parameters"], "parameters")
        r.only(pm, "parameters", set(known_fixed))
        for k, v in pm.items():
            params[k] = _param_value(r, v, f"parameters.{k}", mech_cls.param(k))

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
        dvs[k] = _design_variable(r, k, dv_raw[k], path, mech_cls.param(k))

    # named designs
    designs: dict[str, dict[str, float]] = {}
    if data.get("designs") is not None:
        ds = r.mapping(data["designs"], "designs")
        for dname, dval in ds.items():
            dpath = join("designs", dname)
            _name(r, dname, dpath)
            dm = r.mapping(dval, dpath)
            r.only(dm, dpath, allowed_dv)
            design = {k: v.value for k, v in dvs.items()}
            for k, v in dm.items():
                scale = UNITS[dvs[k].unit]
                x = r.number(v, f"{dpath}.{k}") * scale
                design[k] = x
            _check_design(r, mech_cls, design, dpath)
            designs[dname] = design
    _check_design(r, mech_cls, {k: v.value for k, v in dvs.items()}, "design_variables")
    _check_corners(r, mech_cls, dvs)
    if "initial" not in designs:
        designs = {"initial": {k: v.value for k, v in dvs.items()}, **designs}
    check_physical = getattr(mech_cls, "check_physical", None)
    if check_physical is not None:  # a described mechanism: masses, counts, centres, gravity per design
        problem = check_physical(params, {**{f"design {k!r}": v for k, v in designs.items()},
                                          **_corners(dvs)})
        if problem:
            r.fail(*problem)
    check_config = getattr(mech_cls, "check_config", None)
    if check_config is not None:  # a described mechanism: its expressions and legs with these designs
        problem = check_config(params, designs)
        if problem:
            r.fail(*problem)

    workspace = workspace_section(r, r.require(data, "workspace", ""), mech_cls)

    # indices
    idx_raw = r.mapping(r.require(data, "indices", ""), "indices")
    if not idx_raw:
        r.fail("indices", "expected at least one index")
    indices: dict[str, IndexSpec] = {}
    for iname, ival in idx_raw.items():
        ipath = join("indices", iname)
        _name(r, iname, ipath)
        im = r.mapping(ival if ival is not None else {}, ipath)
        r.only(im, ipath, {"kind", "convention", "sense", "options"})
        kind = r.string(im.get("kind", iname), f"{ipath}.kind")
        if kind not in INDEX_KINDS:
            r.fail(f"{ipath}.kind", f"unknown index {show(kind)}{suggest(kind, INDEX_KINDS)}; "
                                    f"expected one of {', '.join(sorted(INDEX_KINDS))}")
        spec = INDEX_KINDS[kind]
        conv = im.get("convention", spec.default_convention)
        if spec.conventions:
            conv = r.string(conv, f"{ipath}.convention", choices=set(spec.conventions))
        elif conv is not None:
            r.fail(f"{ipath}.convention", f"index {kind!r} has no conventions")
        if kind == "constraint" and kind not in mech_cls.supported_indices:
            r.fail(f"{ipath}.kind", f"index 'constraint' reads the constraint-singularity value of chain legs "
                                    f"(docs/lower-mobility.md); mechanism {mech_name!r} has no chain legs")
        if kind not in mech_cls.supported_indices:
            r.fail(f"{ipath}.kind", f"index {kind!r} is not available for mechanism {mech_name!r}; expected one of {', '.join(mech_cls.supported_indices)}")
        sense = r.string(im.get("sense", spec.sense), f"{ipath}.sense", choices={"min", "max"})
        opts = im.get("options", {}) or {}
        opts = dict(r.mapping(opts, f"{ipath}.options"))
        if opts and not spec.options:
            r.fail(join(f"{ipath}.options", next(iter(opts))), f"index {kind!r} takes no options")
        r.only(opts, f"{ipath}.options", set(spec.options))
        for ok, ov in opts.items():
            if ok == "axis":
                opts[ok] = r.integer(ov, f"{ipath}.options.axis", minimum=0, maximum=len(mech_cls.pose_names) - 1)
            else:
                opts[ok] = r.number(ov, f"{ipath}.options.{ok}", positive=(ok == "k"))
        # the joint stiffness k of K = J^T k J: the mechanism's parameter unless the index sets its own
        if kind in ("stiffness", "axis_stiffness") and "k" not in opts and "k" in mech_cls.fixed_parameters:
            opts["k"] = float(params.get("k", mech_cls.fixed_parameters["k"]))
        indices[iname] = IndexSpec(iname, kind, conv, sense, opts)

    optimizer = optimizer_section(r, data.get("optimizer"), dvs, indices, mech_cls, run_folder=run_folder)

    reference: dict[str, dict[str, float]] = {}
    if data.get("reference") is not None:
        ref = r.mapping(data["reference"], "reference")
        for dname, vals in ref.items():
            rpath = join("reference", dname)
            vm = r.mapping(vals, rpath)
            reference[dname] = {}
            for k, v in vm.items():
                if k not in indices and k != "objective":
                    r.fail(join(rpath, k), f"unknown index{suggest(k, list(indices) + ['objective'])}; "
                                           f"expected one of {', '.join(indices)}")
                reference[dname][k] = r.number(v, f"{rpath}.{k}")

    return Config(mechanism_class=mech_cls, source=source, mechanism=mech_name, name=name, parameters=params,
                  design_variables=dvs, designs=designs, workspace=workspace, indices=indices,
                  optimizer=optimizer, reference=reference, raw=dict(data),
                  checks=checks_section(r, data.get("checks")))


def _units(r: Reader, v: Mapping, path: str, decl) -> float:
    """The factor to SI of the entry's ``unit`` (the units its kind allows)."""
    allowed = tuple(decl.units) if decl is not None else ("m", "mm", "rad", "deg")
    if v.get("unit") is not None and not allowed:
        r.fail(f"{path}.unit", f"{decl.name} is {'a ' + decl.kind if decl.kind != 'number' else 'a plain number'}: it takes no unit")
    return UNITS[r.unit(v.get("unit"), f"{path}.unit", allowed=allowed)]


def _check_value(r: Reader, decl, x: float, path: str) -> None:
    problem = decl.problem(x) if decl is not None else None
    if problem is None and decl is not None and decl.low == 0.0 and decl.low_open and 0 < x < SMALLEST:
        problem = f"expected {decl.range_text()} of sensible size (at least {SMALLEST:g} in SI), got {x:g}"
    if problem:
        r.fail(path, problem)


def _param_value(r: Reader, v: Any, path: str, decl) -> float:
    if decl is not None and decl.kind == "switch" and not isinstance(v, Mapping):
        x, problem = decl.choice(v)
        if problem:
            r.fail(path, problem)
        return x
    if isinstance(v, Mapping):
        r.only(v, path, {"value", "unit"})
        scale = _units(r, v, path, decl)
        vpath = f"{path}.value"
        x = r.number(r.require(v, "value", path), vpath) * scale
    else:
        vpath = path
        x = r.number(v, path)
    _check_value(r, decl, x, vpath)
    return x


def _design_variable(r: Reader, name: str, v: Any, path: str, decl) -> DesignVariable:
    if not isinstance(v, Mapping):
        x = r.number(v, path)
        _check_value(r, decl, x, path)
        return DesignVariable(name, x, None)
    r.only(v, path, {"value", "bounds", "unit"})
    scale = _units(r, v, path, decl)
    unit = v.get("unit")
    value = r.number(r.require(v, "value", path), f"{path}.value") * scale
    _check_value(r, decl, value, f"{path}.value")
    bounds = None
    if v.get("bounds") is not None:
        bounds = r.pair(v["bounds"], f"{path}.bounds", scale=scale)
        if not (bounds[0] <= value <= bounds[1]):
            r.fail(f"{path}.value", f"value {show(v['value'])} is outside the bounds {show(list(v['bounds']))}")
        for end in bounds:
            _check_value(r, decl, end, f"{path}.bounds")
    return DesignVariable(name, value, bounds, unit)


def _check_design(r: Reader, mech_cls, design: dict, path: str) -> None:
    for k, x in design.items():
        _check_value(r, mech_cls.param(k), x, f"{path}.{k}")
    problem = mech_cls.check_design(design)
    if problem:
        key, msg = problem
        r.fail(f"{path}.{key}" if key else path, msg)


def _name(r: Reader, value: Any, path: str) -> str:
    """A name that becomes part of a file or folder name (see optdesign.names)."""
    r.string(value, path)
    problem = name_problem(value)
    if problem:
        r.fail(path, f"{problem}, got {show(value)}")
    return value


#: free variables beyond which the corners of the bounds are not all checked (2^12 designs)
_MAX_CORNER_VARS = 12


def _corners(dvs: dict) -> dict[str, dict[str, float]]:
    """{"at the corner r_a = .., ..": design}: every corner of the bounds' box
    (the other variables at their values; none beyond 12 free variables)."""
    free = [v for v in dvs.values() if v.bounds is not None and v.bounds[1] > v.bounds[0]]
    if not free or len(free) > _MAX_CORNER_VARS:
        return {}
    base = {k: v.value for k, v in dvs.items()}
    out = {}
    for corner in itertools.product(*(v.bounds for v in free)):
        at = ", ".join(f"{v.name} = {_display(v, x)}" for v, x in zip(free, corner))
        out[f"at the corner {at} of the bounds"] = {**base, **{v.name: x for v, x in zip(free, corner)}}
    return out


def _check_corners(r: Reader, mech_cls, dvs: dict) -> None:
    """The mechanism's geometry check at every corner of the box the bounds
    span (the other variables at their values): bounds that contain
    impossible designs are a mistake.  The checks the mechanisms declare are
    linear in each variable (d < 2 r_a, h_o > -h_B), so their corners decide."""
    free = [v for v in dvs.values() if v.bounds is not None and v.bounds[1] > v.bounds[0]]
    if not free or len(free) > _MAX_CORNER_VARS:
        return
    base = {k: v.value for k, v in dvs.items()}
    for corner in itertools.product(*(v.bounds for v in free)):
        design = {**base, **{v.name: x for v, x in zip(free, corner)}}
        problem = mech_cls.check_design(design)
        if problem:
            key, msg = problem
            blamed = next((v for v in free if v.name == key), None)
            if blamed is None:   # the hook names a fixed variable: blame the first free one it involves
                blamed = next((v for v in free if v.name in msg), free[0])
            at = ", ".join(f"{v.name} = {_display(v, x)}" for v, x in zip(free, corner))
            r.fail(f"design_variables.{blamed.name}.bounds",
                   f"the bounds hold impossible designs: at the corner {at}: {msg}")


def _display(v: DesignVariable, x: float) -> str:
    return f"{v.display(x):g}" + (f" {v.unit}" if v.unit else "")
