"""Global indices of designs over a workspace: the one place that builds
mechanisms from a config (config -> mechanism -> workspace -> local indices ->
means over W), vectorized over a population.

* :func:`evaluate` — global statistics (mean, min, max, std) of the config's
  indices for D designs, and the error estimate of each mean against the
  integral of eq. 29 (the workspace's :class:`~optdesign.workspace.ErrorRule`);
  the mechanism's compiled path answers when it has one
  (``Mechanism.global_statistics``, or ``Mechanism.local_values`` for
  weighted rules), the numpy path otherwise;
* :func:`global_indices_error` — the error estimates of named or given designs
  as plain floats (for ``results.json``'s ``global_indices_error``);
* :class:`Evaluator` — what the optimizer calls: design vectors (D, n_var) ->
  index values, extra objectives and constraint quantities, all from one
  :func:`evaluate` pass per population; after construction it holds no config;
* :class:`DesignModel` — :func:`build` and :func:`evaluate` from plain pieces, no config;
* :func:`build` — one mechanism of a config, for a named design or a mapping.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from .config import Config, ConfigError
from .mechanisms import Mechanism, get
from .mechanisms.base import IndexRequest
from .statistics import adaptive_means, mean_errors, statistics
from .workspace import MAX_POINTS, Workspace, WorkspaceTooLarge, sample
from . import worstcase

__all__ = ["Evaluation", "Evaluator", "DesignModel", "evaluate", "evaluate_named", "workspace_of", "build",
           "mechanism_class", "index_requests", "check_size", "global_indices_error", "error_method",
           "SPECIALIZE_WORK", "run_kernel_work"]

#: the hidden requests for the worst conditioning over W when the config has no isotropy index, and for the
#: smallest constraint-singularity value when it has no constraint index
_COND, _CONSTRAINT = "__cond_2", "__constraint"


def mechanism_class(config: Config) -> type[Mechanism]:
    """The mechanism class of a config (a registered name or a described mechanism)."""
    cls = getattr(config, "mechanism_class", None)
    return cls if cls is not None else get(config.mechanism)


def workspace_of(config: Config) -> Workspace:
    try:
        return sample(config.workspace, mechanism_class(config).pose_names)
    except WorkspaceTooLarge as exc:       # a spec built in Python, past the loader's check
        raise ConfigError(config.source, "workspace", str(exc)) from None


def check_size(n_points: int, n_designs: int) -> None:
    """Raise WorkspaceTooLarge if one evaluation call of ``n_designs`` designs
    over ``n_points`` points would pass the limit (before anything is allocated)."""
    if n_points * n_designs > MAX_POINTS:
        raise WorkspaceTooLarge(f"{n_designs:,} designs x {n_points:,} workspace points = "
                                f"{n_points * n_designs:,} evaluations in one call; at most {MAX_POINTS:,} are allowed")


def build(config: Config, design: Mapping[str, float] | str) -> Mechanism:
    """The mechanism of a config for a named design or a parameter mapping (SI)."""
    if isinstance(design, str):
        design = config.design(design)
    return mechanism_class(config)(**{**config.parameters, **design})


def index_requests(config: Config, names=None) -> list[IndexRequest]:
    """The config's indices (or those named) as plain requests."""
    names = list(names) if names is not None else list(config.indices)
    out = []
    for n in names:
        spec = config.indices[n]
        out.append(IndexRequest(n, spec.kind, spec.convention, tuple(sorted((spec.options or {}).items()))))
    return out


@dataclass
class Evaluation:
    """Global (and optionally local) index values of D designs over N points.

    ``summary[index]`` maps ``mean``/``min``/``max``/``std``/``count`` to arrays
    (D,), ``reachable_fraction`` is (D,) (the weighted share of W the
    reachable points stand for), ``local[index]`` (D, N) if kept,
    ``error[index]`` (D,) the estimated error of the mean against the integral
    mean over W, in the index's units (``error_method`` says how; NaN where it
    cannot be estimated; None when not asked for).
    """

    summary: dict[str, dict[str, np.ndarray]]
    reachable: np.ndarray           # (D, N)
    reachable_fraction: np.ndarray  # (D,)
    local: dict[str, np.ndarray] | None
    workspace: Workspace
    error: dict[str, np.ndarray] | None = None
    error_method: str = ""
    #: ``sampling: adaptive``: the summary, errors and reachable fraction are the cubature's; ``reachable``
    #: and ``local`` are at the starting boxes' nodes (``workspace.X``); ``status`` is ``{index: (D,) str}``, ``converged``, ``not_converged``, ``unbounded``
    #: or ``unreachable`` (see :mod:`optdesign.cubature`); None for fixed rules
    status: dict[str, np.ndarray] | None = None


@dataclass(frozen=True)
class DesignModel:
    """How designs are built and evaluated, as plain pieces: the mechanism class, its fixed
    parameters, every design variable at its value (``defaults``, SI) and the index requests."""

    mechanism: type[Mechanism]
    fixed: Mapping[str, float]
    defaults: Mapping[str, float]
    requests: tuple[IndexRequest, ...]

    @classmethod
    def from_config(cls, config: Config, index_names=None) -> "DesignModel":
        return cls(mechanism_class(config), dict(config.parameters), {k: dv.value for k, dv in
                   config.design_variables.items()}, tuple(index_requests(config, index_names)))

    def build(self, design: Mapping[str, float]) -> Mechanism:
        return self.mechanism(**{**self.fixed, **design})

    def evaluate(self, designs, ws: Workspace, keep_local: bool = False, errors: bool = True) -> Evaluation:
        """:func:`evaluate` over ``ws`` (WorkspaceTooLarge past the limit of one call)."""
        full, requests = _stack_designs(self.defaults, designs), list(self.requests)
        check_size(ws.n, len(next(iter(full.values()))))
        mech, summary, reach, local = _evaluate(self.mechanism, self.fixed, full, ws, requests, keep_local)
        if ws.spec.sampling == "adaptive":
            frac, err, status = adaptive_means(mech, ws, requests, reach.shape[0], summary)
            return Evaluation(summary, reach, frac, local, ws, err if errors else None, error_method(ws), status)
        err = mean_errors(mech, ws, requests, reach.shape[0], summary) if errors else None
        return Evaluation(summary, reach, ws.fraction(reach), local, ws, err, error_method(ws))


def _stack_designs(defaults: Mapping[str, float], designs) -> dict[str, np.ndarray]:
    if isinstance(designs, Mapping):
        arr = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in designs.items()}
    else:  # a list of mappings
        if not designs:
            raise ValueError("no designs to evaluate")
        keys = list(designs[0])
        arr = {k: np.array([d[k] for d in designs], dtype=float) for k in keys}
    D = max(v.shape[0] for v in arr.values())
    full = {}
    for k, value in defaults.items():
        v = arr.get(k, np.array([value]))
        full[k] = np.broadcast_to(v, (D,)).astype(float)
    return full


def _evaluate(cls: type[Mechanism], fixed: Mapping[str, float], full: dict[str, np.ndarray], ws: Workspace,
              requests: list[IndexRequest], keep_local: bool = False):
    D = len(next(iter(full.values())))
    mech = cls(**{**fixed, **{k: v[:, None] for k, v in full.items()}})
    summary, reach, local = statistics(mech, ws.X, requests, D, keep_local, ws.weights)
    invalid = getattr(mech, "invalid_designs", None)
    if invalid is not None:   # an impossible mass, count, centre or gravity: no index value, infeasible
        bad = np.broadcast_to(np.asarray(invalid(), dtype=bool), (D,))
        if bad.any():
            summary = {k: {s: (np.where(bad, np.nan, v) if s in ("mean", "min", "max", "std") else v)
                           for s, v in rec.items()} for k, rec in summary.items()}
            if local is not None:
                local = {k: np.where(bad[:, None], np.nan, v) for k, v in local.items()}
    return mech, summary, reach, local


def evaluate(config: Config, designs, workspace: Workspace | None = None, keep_local: bool = False,
             index_names=None, errors: bool = True) -> Evaluation:
    """Evaluate a population: ``designs`` maps parameter names to arrays (D,)
    (missing ones take their config value) or is a list of mappings.  With
    ``errors`` (default) each mean also gets its error estimate (an extra
    pass over the points of the workspace's error rule)."""
    ws = workspace if workspace is not None else workspace_of(config)
    try:
        return DesignModel.from_config(config, index_names).evaluate(designs, ws, keep_local, errors)
    except WorkspaceTooLarge as exc:
        raise ConfigError(config.source, "workspace", str(exc)) from None


def error_method(workspace: Workspace) -> str:
    """One line saying how the workspace's global indices get their error estimate."""
    rule = workspace.error_rule
    return rule.description if rule is not None else "no error estimate"


def evaluate_named(config: Config, names=None, workspace: Workspace | None = None) -> dict[str, dict]:
    """Global indices of named designs as plain floats (for tables and JSON);
    ``global_indices_error`` holds each mean's error estimate."""
    names = list(names) if names else list(config.designs)
    ev = evaluate(config, [config.design(n) for n in names], workspace)
    out = {}
    for i, n in enumerate(names):
        rec = {k: {s: float(v[s][i]) for s in ("mean", "min", "max", "std")} for k, v in ev.summary.items()}
        rec["reachable_fraction"] = float(ev.reachable_fraction[i])
        rec["global_indices_error"] = {k: float(v[i]) for k, v in ev.error.items()}
        if ev.status is not None:
            rec["global_indices_status"] = {k: str(v[i]) for k, v in ev.status.items()}
        out[n] = rec
    return out


def global_indices_error(config: Config, designs, workspace: Workspace | None = None) -> list[dict[str, float]]:
    """For each design (as :func:`evaluate` takes them) the error estimate of every global index
    ``{index: float}`` in its units: ``results.json``'s ``global_indices_error`` beside ``global_indices``.
    The workspace defaults to the config's; :func:`error_method` says how the estimate is made."""
    ev = evaluate(config, designs, workspace)
    return [{k: float(ev.error[k][i]) for k in config.indices} for i in range(ev.reachable.shape[0])]


#: a run's estimated kernel work (design-points, :func:`run_kernel_work`) from
#: which its mechanism's shape runs on the engine's specialized tier (compiled
#: once per machine and shape, about 30 s; twice the generic tier's speed for
#: n >= 4, a quarter more for n <= 3; the same results): about a minute of
#: kernel time on two cores, where compiling pays
SPECIALIZE_WORK = 3e8


def run_kernel_work(config: Config, points: int) -> float:
    """A rough count of a run's design-point evaluations: the workspace's
    points times a stage's population and generations times the stages (one
    per index and sense, two for the weighted sums)."""
    opt = config.optimizer
    return float(points) * opt.population * opt.generations * (2 * len(config.indices) + 2)


class Evaluator:
    """Design vectors -> everything the optimizer needs, in one pass per population.

    ``__call__(X)`` with X (D, n_var) (the free design variables in order,
    SI) returns ``{"values": {index or extra objective: (D,)}, "constraints":
    {name: (D,)}, "reachable_fraction": (D,), "cond_max": (D,)}`` (``cond_max``:
    the maximum over W that ``singularity`` is made of, inf where not finite,
    0 where no point is reachable).  Constraints (``<= 0`` feasible):

    * ``reach``: the fraction of workspace points the design cannot reach;
    * ``singularity``: ``max_W cond(J) / (threshold (1 - margin)) - 1`` (the
      largest local condition number over W: the config's first isotropy
      index, else cond_2(J)), 1 where it is not finite;
    * ``finite``: 1 where a global index is not finite;
    * ``stroke_low`` / ``stroke_high``: actuator values outside
      ``stroke_limits`` (narrowed by ``margin`` times their span on each
      side) anywhere in W (m), when the config sets them;
    * ``constraint_singularity`` (with ``constraint_limit``): ``1 - min_W c / (limit (1 + margin))``, c a chain
      mechanism's constraint-singularity value at the samples (1 where no point is reachable).

    With ``worst_case`` the maxima over W are those of the continuous search
    of :mod:`optdesign.worstcase` (from the worst samples, for every design
    that the samples find feasible; an unreachable pose it meets makes
    ``singularity`` 1; kept per design vector, so a design seen before is not
    searched again), else the samples' maxima.  ``threshold`` stays the
    limit itself (the certificates' limit); ``limit`` is the tightened one.
    """

    CONSTRAINTS = ("reach", "singularity", "finite", "stroke_low", "stroke_high", "constraint_singularity")
    #: most design vectors whose worst case over W is kept (see :meth:`_worst_over_w`)
    MEMO = 50_000

    def __init__(self, mechanism: type[Mechanism], fixed: Mapping[str, float], defaults: Mapping[str, float],
                 free: list[str], xl: np.ndarray, xu: np.ndarray, workspace: Workspace,
                 requests: list[IndexRequest], senses: Mapping[str, str], threshold: float,
                 stroke_limits: tuple[float, float] | None, extra: tuple[str, ...] = (),
                 worst_case: bool = False, margin: float = 0.0, constraint_limit: float | None = None):
        self.mechanism = mechanism
        self.fixed = dict(fixed)
        self.defaults = dict(defaults)
        self.free = list(free)
        self.xl, self.xu = np.asarray(xl, float), np.asarray(xu, float)
        self.workspace = workspace
        self.requests = list(requests)
        self.index_names = [r.name for r in requests]
        self.senses = dict(senses)
        self.threshold = float(threshold)
        self.stroke_limits = stroke_limits
        self.worst_case = bool(worst_case)
        self.worst_case_method = "auto"         # or "ascent" (the earlier search, for benchmarks)
        self.margin = float(margin)
        self.limit = self.threshold * (1.0 - self.margin)
        self.extra = {k: mechanism.extra_objectives[k] for k in extra}
        iso = [r.name for r in requests if r.kind == "isotropy"]
        self._cond = iso[0] if iso else None
        self.requests_all = self.requests + ([] if iso else [IndexRequest(_COND, "isotropy", "two_norm")])
        self.constraint_limit = None if constraint_limit is None else float(constraint_limit) * (1.0 + self.margin)
        con = [r.name for r in requests if r.kind == "constraint"]
        self._constraint = con[0] if con else _CONSTRAINT
        if constraint_limit is not None and not con:
            self.requests_all = self.requests_all + [IndexRequest(_CONSTRAINT, "constraint", None)]
        self.constraint_names = list(self.CONSTRAINTS[:3]) + (list(self.CONSTRAINTS[3:5]) if stroke_limits else []) \
            + (["constraint_singularity"] if constraint_limit is not None else [])
        self.n_evaluations = 0
        self._memo: dict = {}

    @classmethod
    def from_config(cls, config: Config, workspace: Workspace | None = None) -> "Evaluator":
        free = [v.name for v in config.free_variables]
        if not free:
            raise ConfigError(config.source, "design_variables", "no free design variable: give at least one 'bounds'")
        opt = config.optimizer
        mech = mechanism_class(config)
        ws = workspace if workspace is not None else workspace_of(config)
        if run_kernel_work(config, ws.n) >= SPECIALIZE_WORK:
            mech.specialize_kernels()
        return cls(mech, config.parameters,
                   {k: dv.value for k, dv in config.design_variables.items()}, free,
                   np.array([config.design_variables[k].bounds[0] for k in free]),
                   np.array([config.design_variables[k].bounds[1] for k in free]),
                   ws, index_requests(config), {k: s.sense for k, s in config.indices.items()},
                   opt.singularity_threshold, opt.stroke_limits, tuple(opt.extra_objectives),
                   opt.worst_case, opt.constraint_margin, opt.constraint_singularity)

    # ------------------------------------------------------------------ vectors
    def designs(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """Design vectors (D, n_var) -> parameter arrays (D,), SI, the others at their values."""
        X = np.atleast_2d(X)
        out = {}
        for k, v in self.defaults.items():
            out[k] = X[:, self.free.index(k)] if k in self.free else np.full(X.shape[0], v)
        return out

    def vector(self, design: Mapping[str, float]) -> np.ndarray:
        return np.array([design[k] for k in self.free], dtype=float)

    @property
    def model(self) -> DesignModel:
        """Its mechanism and indices without the box and the constraints (full evaluations of designs)."""
        return DesignModel(self.mechanism, self.fixed, self.defaults, tuple(self.requests))

    def extra_values(self, designs: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {k: np.asarray(e.func(designs), dtype=float) for k, e in self.extra.items()}

    def extra_range(self, name: str, bounds: Mapping[str, tuple[float, float]]) -> tuple[float, float]:
        """(min, max) of an extra objective over the corners of the box its
        parameters span (``bounds``: parameter -> (lo, hi); a fixed one lo == hi)."""
        e = self.extra[name]
        corners = {p: np.asarray(bounds[p], dtype=float) for p in e.parameters}
        vals = np.asarray(e.func(corners), dtype=float)
        return float(vals.min()), float(vals.max())

    # ------------------------------------------------------------------ evaluation
    def _worst_over_w(self, X, designs, cmax, frac, Q):
        """:func:`optdesign.worstcase.worst_over_w` for the rows of X not seen
        before (a GA's elites and repeated designs come back every
        generation; a quarter of the reproduction's evaluations): the search's
        maxima are kept per design vector (and search setting), at most
        ``MEMO`` of them.  Returns ``(max cond (D,), (min q, max q) or None)``."""
        setting = (self.worst_case_method, self.limit, self.margin, self.stroke_limits)
        keys = [(setting, row.tobytes()) for row in np.ascontiguousarray(X, float)]
        new = np.flatnonzero([k not in self._memo for k in keys])
        if new.size:
            req = next(r for r in self.requests_all if r.name == (self._cond or _COND))
            c, q, where = worstcase.worst_over_w(self.mechanism, self.fixed,
                                                 {k: v[new] for k, v in designs.items()}, self.workspace, req,
                                                 self.limit, np.asarray(cmax)[new], frac[new],
                                                 None if Q is None else np.asarray(Q)[new], self.stroke_limits,
                                                 self.margin, self.worst_case_method, poses=True)
            if len(self._memo) + new.size > self.MEMO:
                self._memo.clear()
            for j, i in enumerate(new):
                self._memo[keys[i]] = ((c[j],) + ((q[0][j], q[1][j]) if q is not None else ()),
                                       {k: v[j] for k, v in where.items()})
        found = np.array([self._memo[k][0] for k in keys], float).reshape(len(keys), -1)
        return found[:, 0], ((found[:, 1], found[:, 2]) if Q is not None else None)

    def worst_poses(self, X: np.ndarray) -> dict[str, np.ndarray] | None:
        """The poses (D, dof) SI of the maxima over W that the last calls found
        for the design vectors X (D, n_var): ``cond``, and with strokes
        ``q_max`` and ``q_min`` (NaN rows where the search did not run: a
        design the samples find infeasible), or None when a design of X was
        not searched by this Evaluator (``worst_case`` off, or not evaluated)."""
        setting = (self.worst_case_method, self.limit, self.margin, self.stroke_limits)
        keys = [(setting, row.tobytes()) for row in np.ascontiguousarray(np.atleast_2d(X), float)]
        if not self.worst_case or any(k not in self._memo for k in keys):
            return None
        got = [self._memo[k][1] for k in keys]
        return {name: np.stack([g[name] for g in got]) for name in got[0]}

    def __getstate__(self):
        return {**self.__dict__, "_memo": {}}    # a copy for another process starts empty

    def __call__(self, X: np.ndarray, worst_case: bool | None = None) -> dict:
        """The values, constraints and reachable fractions of the design
        vectors X (D, n_var); ``worst_case``: this call's choice of the
        continuous search (None: the Evaluator's own)."""
        check_size(self.workspace.n, np.atleast_2d(X).shape[0])
        designs = self.designs(X)
        mech, summary, reach, _ = _evaluate(self.mechanism, self.fixed, designs, self.workspace, self.requests_all)
        if self.workspace.spec.sampling == "adaptive":   # the integrals to the tolerance; an unbounded one is inf
            frac = adaptive_means(mech, self.workspace, self.requests_all, reach.shape[0], summary)[0]
        else:
            frac = self.workspace.fraction(reach)
        vals = {k: summary[k]["mean"] for k in self.index_names}
        if self._cond is not None:
            cmax = summary[self._cond]["max"]
        else:  # the largest cond_2 over the reachable points, 0 where there is none
            s = summary[_COND]
            cmax = np.where(s["count"] > 0, s["max"], 0.0)
        Q = None
        if self.stroke_limits is not None:
            with np.errstate(all="ignore"):
                Q = mech.inverse(self.workspace.X)
        if self.worst_case if worst_case is None else worst_case:
            cmax, Q = self._worst_over_w(np.atleast_2d(X), designs, cmax, frac, Q)
        cons = {
            "reach": 1.0 - frac,
            "singularity": np.where(np.isfinite(cmax), cmax / self.limit - 1.0, 1.0),
            "finite": np.where(np.all([np.isfinite(v) for v in vals.values()], axis=0), 0.0, 1.0),
        }
        if self.stroke_limits is not None:
            lo, hi = self.stroke_limits
            pad = self.margin * (hi - lo)
            qmin, qmax = Q if isinstance(Q, tuple) else worstcase.q_range(Q)
            cons["stroke_low"] = np.where(np.isfinite(qmin), lo + pad - qmin, 1.0)
            cons["stroke_high"] = np.where(np.isfinite(qmax), qmax - (hi - pad), 1.0)
        if self.constraint_limit is not None:
            s = summary[self._constraint]
            cons["constraint_singularity"] = np.where((s["count"] > 0) & np.isfinite(s["min"]),
                                                      1.0 - s["min"] / self.constraint_limit, 1.0)
        vals.update(self.extra_values(designs))
        self.n_evaluations += X.shape[0]
        return {"values": vals, "constraints": cons, "reachable_fraction": frac, "cond_max": np.asarray(cmax, float)}
