"""The config's keys, declared once: for each its type, default, unit, one-line
doc and constraint (in the spirit of scikit-learn's ``_parameter_constraints``).

This table drives

* the allowed keys of each section (an unknown key is refused with a "did you mean");
* the spec dataclasses: :class:`~optdesign.config.schema.OptimizerSpec` and
  :class:`~optdesign.config.checks.ChecksSpec` are built from it (:func:`spec_class`);
* the checks and their messages (:meth:`Key.read`, with the toolkit of
  :mod:`optdesign.checking`);
* the key tables of docs/config.md, between ``<!-- keys:SECTION -->`` and
  ``<!-- /keys:SECTION -->`` (:mod:`.keydocs`; regenerate with
  ``python -m optdesign.config.keydocs --write-docs docs/config.md``);
* the hostile test cases (:meth:`Key.invalid_values`, tests/test_config_keys.py).

A key marked ``custom`` is read by its section's own code (its value depends on
other keys or on the mechanism); the table still gives its docs, its default
and its place among the allowed keys.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from ..checking import Checker, Interval, Options, join, tname
from ..workspace import MAX_POINTS

__all__ = ["CHECKS", "OPTIMIZER", "REQUIRED", "SECTIONS", "TOP", "WORKSPACE", "Key", "Section", "spec_class"]


class _Required:
    def __repr__(self):
        return "REQUIRED"


#: the default of a key that must be given
REQUIRED = _Required()
_NOT_A_NUMBER = ("abc", True, None, [1.0], {"a": 1})
_ANNOTATIONS = {"integer": "int", "number": "float", "string": "str", "boolean": "bool",
                "pair": "tuple[float, float] | None", "list": "tuple[str, ...]", "mapping": "dict"}


@dataclass(frozen=True)
class Key:
    """One key of a section (``pareto.population``: a key of a sub-mapping)."""

    name: str
    type: str                       # integer, number, string, boolean, pair, list, mapping, name
    default: Any = None             # REQUIRED: must be given; a callable: a default_factory
    doc: str = ""
    check: Interval | Options | None = None   # a range, or the allowed strings (of a list's items)
    unit: str | None = None
    custom: bool = False            # read by the section's own code
    field: str | None = ""          # the spec's field ("": the name with '.' -> '_'; None: no field)
    annotation: str | None = None
    type_doc: str | None = None     # docs: the type column, when the constraint does not say it all
    default_doc: str | None = None  # docs: the default column
    where: dict = dataclasses.field(default_factory=dict)  # sibling values under which the key is read (None: absent)
    invalid: tuple = ()             # invalid values beyond those the type and constraint give
    example: Any = None             # a valid value (tests; None: the default)
    nullable: bool = False          # null is the same as leaving the key out

    @property
    def field_name(self) -> str | None:
        return self.name.replace(".", "_") if self.field == "" else self.field

    # ------------------------------------------------------------------ reading
    def read(self, r: Checker, value: Any, path: str, choices=None) -> Any:
        """The value checked against the type and the constraint (``choices``:
        the allowed strings when they depend on the mechanism)."""
        t, c = self.type, self.check
        if t in ("integer", "number"):
            if isinstance(c, Interval):
                return r.in_interval(value, path, c, integer=t == "integer")
            return r.integer(value, path) if t == "integer" else r.number(value, path)
        allowed = choices if choices is not None else (set(c.values) if isinstance(c, Options) else None)
        if t == "string":
            return r.string(value, path, choices=allowed)
        if t == "boolean":
            return r.boolean(value, path)
        if t == "pair":
            return r.pair(value, path)
        if t == "list":
            if not isinstance(value, list):
                r.fail(path, f"expected a list, got {tname(value)}")
            return tuple(r.string(x, join(path, i), choices=allowed) for i, x in enumerate(value))
        if t == "mapping":
            return r.mapping(value, path)
        raise TypeError(f"key {self.name}: a {t} is read by its section's code")

    def invalid_values(self) -> tuple:
        """Values that must be refused: the wrong types, the ends just
        outside the range, a choice that is not one, and ``invalid``."""
        t, c = self.type, self.check
        out: tuple = ()
        if t == "integer":
            out = ("abc", True, None, 2.5, [1])
        elif t == "number":
            out = _NOT_A_NUMBER + (float("nan"), float("inf"), 1e300)
        elif t in ("string", "name"):
            out = (3, True, None, [1])
        elif t == "boolean":
            out = ("yes", 1, None)
        elif t == "pair":
            out = ("abc", 1.0, [1.0], [0.3, 0.2], [float("nan"), 1.0])
        elif t == "list":
            out = ("abc", 3, {"a": 1})
        elif t == "mapping":
            out = ("abc", 3, [1, 2])
        if isinstance(c, Interval):
            out += c.outside(integer=t == "integer")
        if isinstance(c, Options):
            out += ([c.values[0] + "x"] if t == "list" else c.values[0] + "x",)
        if self.nullable:
            out = tuple(v for v in out if v is not None)
        return out + self.invalid

    # ------------------------------------------------------------------ docs
    def type_text(self) -> str:
        if self.type_doc is not None:
            text = self.type_doc
        else:
            t, c = self.type, self.check
            if isinstance(c, Options):
                words = [f"`{v}`" for v in c.values]
                choice = ", ".join(words[:-1]) + f" or {words[-1]}" if len(words) > 1 else words[0]
                text = f"list of {', '.join(words)}" if t == "list" else choice
            elif isinstance(c, Interval):
                text = f"{t} {_range_text(c, t == 'integer')}"
            else:
                text = {"boolean": "`true` or `false`", "pair": "`[lower, upper]`"}.get(t, t)
        return text + (f" ({self.unit})" if self.unit else "")

    def default_text(self) -> str:
        if self.default_doc is not None:
            return self.default_doc
        d = self.default
        if d is REQUIRED:
            return "required"
        if d is None:
            return "—"
        if isinstance(d, bool):
            return f"`{str(d).lower()}`"
        if isinstance(d, str):
            return f"`{d}`"
        if isinstance(d, tuple):
            return f"`[{', '.join(str(x) for x in d)}]`"
        return _num(d)


def _num(x) -> str:
    if isinstance(x, int):
        return f"{x:,}" if abs(x) >= 10_000 else str(x)
    return f"{x:g}"


def _range_text(c: Interval, integer: bool) -> str:
    if c.also is not None:
        return f"{_num(c.also[0])} or in {c.text()}"
    if integer and c.low is not None and c.high is not None and c.closed == "both":
        return f"{_num(c.low)}–{_num(c.high)}"
    if c.high is None:
        return f"{'≥' if c.closed in ('both', 'left') else '>'} {_num(c.low)}"
    return f"in {c.text()}"


@dataclass(frozen=True)
class Section:
    """The keys of one section of a config ("" for the top level)."""

    name: str
    keys: tuple[Key, ...]

    def __getitem__(self, name: str) -> Key:
        for k in self.keys:
            if k.name == name:
                return k
        raise KeyError(name)

    def allowed(self, level: str = "") -> set[str]:
        """The keys of the mapping ``level`` ("" the section itself, "pareto" its sub-mapping)."""
        pre = f"{level}." if level else ""
        return {k.name[len(pre):].split(".")[0] for k in self.keys if k.name.startswith(pre)}

    def read(self, r: Checker, m, path: str, level: str = "") -> dict:
        """{field: value} of every key of ``level`` that ``m`` holds and the
        table reads (not ``custom``), in the table's order."""
        pre = f"{level}." if level else ""
        out = {}
        for k in self.keys:
            if k.custom or not k.name.startswith(pre) or "." in k.name[len(pre):]:
                continue
            sub = k.name[len(pre):]
            if sub in m:
                out[k.field_name] = k.read(r, m[sub], join(path, sub))
        return out

    def defaults(self) -> dict:
        """{field: default} of every key with a field."""
        out = {}
        for k in self.keys:
            if k.field_name is not None:
                out[k.field_name] = k.default() if callable(k.default) else k.default
        return out


def spec_class(name: str, section: Section, doc: str, module: str):
    """A frozen dataclass with one field per key of ``section`` (its default the table's)."""
    fields = []
    for k in section.keys:
        if k.field_name is None:
            continue
        ann = k.annotation or _ANNOTATIONS.get(k.type, "Any")
        dflt = dataclasses.field(default_factory=k.default) if callable(k.default) else dataclasses.field(default=k.default)
        fields.append((k.field_name, ann, dflt))
    cls = dataclasses.make_dataclass(name, fields, frozen=True)
    cls.__module__, cls.__doc__ = module, doc
    return cls


# --------------------------------------------------------------------------- the tables
_M = "a mapping"
TOP = Section("", (
    Key("mechanism", "string", REQUIRED, custom=True, type_doc="string, or a description (mapping)",
        doc="registry name of the mechanism (`p4s`, and the others `optdesign.mechanisms.available()` lists), "
            "or a mechanism description (docs/mechanisms-as-data.md)", invalid=("no_such_mechanism",)),
    Key("name", "name", None, custom=True, type_doc="name (see Names)",
        default_doc="file name without `.yaml`, made safe", invalid=("../up", "", "x" * 101),
        doc="used in output folder names (`runs/<name>-s<seed>-...`, `indices/<name>-<design>/`)"),
    Key("description", "string", None, nullable=True, example="a config", doc="free text, not interpreted"),
    Key("parameters", "mapping", None, custom=True, default_doc="mechanism defaults",
        doc="fixed (not optimized) parameters", invalid=({"no_such_parameter": 1},)),
    Key("design_variables", "mapping", REQUIRED, custom=True, doc="the design parameters: value and optional bounds"),
    Key("designs", "mapping", None, custom=True, doc="named designs (`before`, `after`, …)"),
    Key("workspace", "mapping", REQUIRED, custom=True, doc="the region W over which global indices are averaged"),
    Key("indices", "mapping", REQUIRED, custom=True, type_doc="mapping (≥ 1 entry)", invalid=({},),
        doc="the performance indices and their conventions"),
    Key("optimizer", "mapping", None, custom=True, default_doc="see below",
        doc="settings of the stages: pre-scan, single-objective searches, weighted sums, polish, Pareto runs"),
    Key("reference", "mapping", None, custom=True, doc="published values to print beside ours"),
    Key("checks", "mapping", None, custom=True, default_doc="see below",
        doc="how hard a run checks its reported designs over the continuous W"),
))

_SEED = Interval(0, 2 ** 32 - 1)
_GRID_OFF = {"step": None}
_CYLINDER = {"type": "cylinder", "axes": {"z": 0.57}}
WORKSPACE = Section("workspace", (
    Key("type", "string", "box", check=Options(("box", "cylinder")), doc="region shape"),
    Key("axes", "mapping", REQUIRED, custom=True,
        doc="per pose axis (`x`, `y`, `z` for `p4s`): a number (the axis is fixed) or `[lower, upper]`"),
    Key("radius", "number", None, check=Interval(0, None, "neither"), custom=True, unit="the block's `unit`",
        where=_CYLINDER, example=0.04,
        default_doc="required for `cylinder`", doc="disc radius in the first two axes"),
    Key("center", "point", (0.0, 0.0), custom=True, type_doc="`[x, y]`", default_doc="`[0, 0]`",
        where={**_CYLINDER, "radius": 0.04}, example=[0.0, 0.01], invalid=("abc", 1.0, [1.0], [float("nan"), 0.0]),
        doc="disc centre (`cylinder`)"),
    Key("sampling", "string", "grid",
        check=Options(("grid", "gauss", "rqmc", "sobol", "halton", "lhs", "random", "adaptive")),
        doc="how points are placed (each is a quadrature of the integral mean over W, below); "
            "`adaptive`: each global index integrated to a `tolerance`"),
    Key("step", "number", None, check=Interval(0, None, "neither"), custom=True, invalid=(1e-9,), example=0.05,
        doc="grid spacing (a grid needs `step` or `points_per_axis`, not both)"),
    Key("points_per_axis", "integer", None, check=Interval(1, MAX_POINTS), custom=True, where=_GRID_OFF, example=3,
        type_doc="integer 1–10,000,000 (`gauss`: from 2)",
        doc="grid points per free axis (`linspace`); Gauss–Legendre nodes per free axis"),
    Key("points", "integer", None, check=Interval(1, MAX_POINTS), custom=True,
        where={"step": None, "sampling": "sobol"}, example=16,
        default_doc="required for non-grid sampling (and only there)",
        doc="number of samples; for `rqmc` the points of each scrambling, a power of 2"),
    Key("scramblings", "integer", 8, check=Interval(2, 1024), custom=True,
        where={"step": None, "sampling": "rqmc", "points": 16},
        doc="`rqmc` only: independent scramblings of the Sobol set"),
    Key("tolerance", "number", 1e-3, check=Interval(1e-10, 0.5, what="a relative tolerance"), custom=True,
        where={"step": None, "sampling": "adaptive"}, type_doc="number 1e-10 – 0.5",
        doc="`adaptive` only: the relative tolerance of every global index (its error estimate ≤ tolerance × \\|mean\\|)"),
    Key("max_points", "integer", 200_000, check=Interval(1000, MAX_POINTS), custom=True,
        where={"step": None, "sampling": "adaptive"},
        doc="`adaptive` only: the most nodes evaluated per evaluation call (for a population: the union of the "
            "designs' nodes)"),
    Key("seed", "integer", 0, check=_SEED, type_doc="integer 0 – 2³²−1",
        doc="seed of the quasi-random/random sampler (reproducible); not taken by `gauss`"),
    Key("unit", "string", None, check=Options(("m", "mm", "rad", "deg")), custom=True, default_doc="SI",
        invalid=("deg",), nullable=True, example="mm", where={"step": 50, "axes": {"x": [-50, 50], "y": [-50, 50], "z": 570}},
        doc="unit of every axis value, `radius` and `center` in this block; it must suit every axis it applies to "
            "(lengths: `m`/`mm`, angles: `rad`/`deg`; the UPS+UPR+S's sines take none)"),
))

_PROBABILITY = Interval(0, 1, what="a probability")
_POP = Interval(4, 100_000)
OPTIMIZER = Section("optimizer", (
    Key("algorithm", "string", "de", check=Options(("de", "paper_ga", "pymoo_ga")),
        doc="the search of the single-objective stages and the weighted sums: pymoo's differential evolution "
            "(DE/best/1/bin, its defaults), the paper's GA (roulette, arithmetic crossover, adaptive mutation, "
            "elites) or pymoo's GA; see \"Which search\" below"),
    Key("population", "integer", 50, check=_POP, doc="population size"),
    Key("generations", "integer", 100, check=Interval(1, 100_000), doc="generations"),
    Key("crossover_probability", "number", 0.8, check=_PROBABILITY, doc="`paper_ga` only"),
    Key("mutation_probability", "number", 0.2, check=_PROBABILITY,
        doc="`paper_ga` only: share of children mutated (MATLAB's 1 − crossover fraction)"),
    Key("elites", "integer", 2, check=Interval(0, 100_000), type_doc="integer ≥ 0, < population", invalid=(50,),
        doc="`paper_ga` only: elites kept each generation"),
    Key("fitness_scaling", "string", "rank", check=Options(("rank", "linear")),
        doc="`paper_ga` only: the roulette's fitness"),
    Key("prescan", "integer", None, check=Interval(0, 1_000_000), annotation="int | None", example=64,
        default_doc="the smaller of 2048 and `population` × `generations`",
        doc="designs of the quasi-random pre-scan of the box (scrambled Sobol, rounded up to a power of two; the "
            "box's corners and centre are added when there are at most an eighth as many); its best feasible "
            "designs seed the single-objective stages and their polish. 0: no pre-scan"),
    Key("polish", "integer", 3, check=Interval(0, 100),
        doc="starts of the gradient polish that ends every single-objective stage and weighted sum (SLSQP from "
            "the stage's best distinct designs and its seeds); every Pareto point is polished too. 0: no polish"),
    Key("extremes.starts", "integer", 4, check=Interval(0, 100),
        doc="polished starts per normalization extreme of the seed-free multi-start (the `extremes` stage, see "
            "below); 0: no multi-start. The multi-start is part of the polish: with `polish: 0` it does not run "
            "either (a run then has the weaker extremes of its seeded searches alone, which tests use to build "
            "that case)"),
    Key("extremes.scan", "integer", 4096, check=Interval(1, 1_000_000),
        doc="designs of the multi-start's fixed scan of the box (Sobol scrambled with the fixed seed 0, rounded "
            "up to a power of two; the corners and centre are added when there are at most a quarter as many)"),
    Key("extremes.walk", "integer", 300, check=Interval(0, 100_000),
        doc="most steps of the walk along the singularity wall that finishes an extreme where SLSQP stops short "
            "of a first-order point (optdesign/optimize/wall.py; each step one derivative and a few evaluations "
            "of four trial designs); 0: no walk"),
    Key("seed", "integer", 1, check=_SEED, type_doc="integer 0 – 2³²−1", doc="random seed"),
    Key("weights", "mapping", dict, custom=True, annotation="dict[str, float]", type_doc="`{INDEX: number ≥ 0}`",
        default_doc="1 for every index", invalid=({"dynamic": -1},), example={"dynamic": 1, "stiffness": 0},
        doc="weights of the normalized sum (eq. 40); when given, every index needs one (give 0 to leave an index "
            "out; a missing index is an error); at least one positive"),
    Key("pareto.algorithms", "list", ("nsga2", "nsga3"), check=Options(("nsga2", "nsga3")), doc="Pareto runs"),
    Key("pareto.population", "integer", 100, check=_POP,
        doc="NSGA-III gets the fewest Das–Dennis reference directions that are at least this many, and a "
            "population of that count"),
    Key("pareto.generations", "integer", 100, check=Interval(1, 100_000), doc="generations of each Pareto run"),
    Key("extra_objectives", "list", (), custom=True, type_doc="list of the mechanism's (`base_radius`, "
        "`overall_radius` for `p4s`)", invalid=(["no_such_objective"],),
        example=["base_radius"],
        doc="compactness objectives added to the Pareto runs (r_b; max(r_a, r_b))"),
    Key("singularity_threshold", "number", 1e3, check=Interval(0, None, "neither"),
        doc="designs whose largest local cond(J) over W exceeds this are infeasible (the cond of the config's "
            "first isotropy index, in its convention; cond_2 where the config has none)"),
    Key("constraint_singularity", "number", None, check=Interval(0, 1, "neither"), custom=True,
        annotation="float | None", default_doc="none",
        doc="chain mechanisms only (docs/lower-mobility.md): designs whose smallest constraint-singularity value "
            "over the samples of W (the `constraint` index's local value, 0 at a constraint singularity) is below "
            "this are infeasible; the optimizer works against it raised by `constraint_margin` (value ≥ limit × "
            "(1 + margin)); the continuous worst-case search does not cover it"),
    Key("stroke_limits", "pair", None, unit="m", default_doc="none", example=[-10.0, 10.0],
        doc="actuator values outside this range anywhere in W make a design infeasible"),
    Key("worst_case", "boolean", True,
        doc="`true`: the local constraints (cond ≤ limit, reach, strokes) must hold at every pose of the "
            "continuous W: the optimizer's constraint value is the maximum over W found by a continuous search "
            "from the worst samples (see \"The worst case over W\" below); `false`: at the samples of W only (a "
            "design can then be singular between them)"),
    Key("constraint_margin", "number", 1e-3, check=Interval(0, 0.5, "left", what="a fraction"),
        doc="the optimizer works against the limits tightened by this fraction: cond ≤ `singularity_threshold` × "
            "(1 − margin), the strokes inside `stroke_limits` narrowed by margin × (upper − lower) on each side; "
            "the certificates (docs/certificates.md) prove the limits themselves, so a design on the optimizer's "
            "boundary can be certified"),
    Key("checkpoint_interval", "number", 1.0, check=Interval(0, None), unit="s",
        doc="a GA run saves its checkpoint at the first generation boundary this long after the last one (0: "
            "after every generation), and always when asked to stop; a SIGKILL loses at most this much work. "
            "Results do not depend on it."),
))

CHECKS = Section("checks", (
    Key("certificate_budget", "integer", 300_000, check=Interval(0, 100_000_000),
        doc="box evaluations of the branch and bound per reported design, for a W of at most 3 free axes; a "
            "third of it above 3 axes, and a twentieth of that for each Pareto point. `0` skips the proofs: every "
            "reported design is then `unknown` with 0 % of W proved, and the reports say so"),
    Key("integral_tolerance", "number", 1e-4,
        check=Interval(1e-10, 0.5, what="a relative tolerance", also=(0, "no integrals")),
        doc="relative tolerance of the recorded integrals (`results.json[\"integrals\"]`); `0` records none"),
    Key("integral_max_points", "integer", 200_000, check=Interval(100, 10_000_000),
        doc="node budget per design of those integrals"),
))

SECTIONS = {"top": TOP, "workspace": WORKSPACE, "optimizer": OPTIMIZER, "checks": CHECKS}
