"""The interface every mechanism offers (batched over poses and designs).

Shapes: poses ``X`` are ``(..., N, dof)``, actuator values ``Q`` are
``(..., N, n_act)``, Jacobians ``(..., N, n_act, dof)`` with ``qdot = J @ xdot``.
Design parameters may be arrays that broadcast against ``X.shape[:-1]``: a
population of ``D`` designs is given as parameters of shape ``(D, 1)`` and
then ``inverse(X)`` with ``X`` of shape ``(N, dof)`` returns ``(D, N, n_act)``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, ClassVar, Mapping, Sequence

import numpy as np

from .params import Param, derived_tables
from .state import PoseState

__all__ = ["Mechanism", "IndexRequest", "ExtraObjective", "Param", "PoseState"]


@dataclass(frozen=True)
class IndexRequest:
    """A local index asked of a mechanism's compiled path: plain data, no config.

    ``name`` keys the answer; ``kind`` and ``convention`` are those of
    :mod:`optdesign.indices`; ``options`` are sorted ``(key, value)`` pairs
    (for example ``(("k", 1.0),)``)."""

    name: str
    kind: str
    convention: str | None = None
    options: tuple = ()

    def option_dict(self) -> dict:
        return dict(self.options)


@dataclass(frozen=True)
class ExtraObjective:
    """An objective beyond the performance indices (compactness, footprint,
    moving mass), declared by the mechanism that knows what it means.

    ``func`` maps the design parameters (a dict of arrays (D,), SI) to (D,);
    ``parameters`` names the design parameters it reads (its range over a
    design box is taken at the box's corners, so it must be monotone in each)."""

    func: Callable[[Mapping[str, np.ndarray]], np.ndarray]
    sense: str
    description: str
    unit: str
    parameters: tuple[str, ...]


class Mechanism:
    """Base class: geometry and physics of one parallel mechanism.

    A subclass declares its parameters once in ``parameters`` (a tuple of
    :class:`~optdesign.mechanisms.params.Param`); the per-purpose tables below
    are derived from it."""

    #: every parameter, declared once (kind, unit, range, default, named choices)
    parameters: ClassVar[tuple[Param, ...]] = ()
    #: objectives beyond the indices that ``optimizer.extra_objectives`` may name
    extra_objectives: ClassVar[Mapping[str, ExtraObjective]] = {}
    #: a starting config for ``optdesign init``: ``design_variables`` (value,
    #: bounds, unit as a config writes them), ``parameters`` (overrides of the
    #: defaults), ``workspace`` and ``indices`` that suit the mechanism
    example: ClassVar[Mapping] = {}
    #: module of an independent multibody (MuJoCo) check of the dynamics, if any
    #: (``optdesign validate-dynamics``)
    multibody_check: ClassVar[str | None] = None

    #: registry name used in configs
    name: ClassVar[str] = ""
    #: pose (task-space) coordinate names, in order
    pose_names: ClassVar[tuple[str, ...]] = ()
    #: actuator coordinate names, in order
    actuator_names: ClassVar[tuple[str, ...]] = ()
    # derived from ``parameters`` (see __init_subclass__)
    #: design parameters (optimizable dimensions), SI
    design_parameters: ClassVar[tuple[str, ...]] = ()
    #: defaults for design parameters that a config may omit
    design_defaults: ClassVar[Mapping[str, float]] = {}
    #: design parameters that are lengths (must be positive)
    length_parameters: ClassVar[tuple[str, ...]] = ()
    #: fixed (non-optimized) parameters and their defaults, SI
    fixed_parameters: ClassVar[Mapping[str, float]] = {}
    positive_parameters: ClassVar[tuple[str, ...]] = ()
    nonnegative_parameters: ClassVar[tuple[str, ...]] = ()
    #: index kinds (optdesign.indices) that make sense for this mechanism
    supported_indices: ClassVar[tuple[str, ...]] = ()
    #: which pose axes are angles (for unit display)
    angular_axes: ClassVar[tuple[str, ...]] = ()
    #: SI unit of pose coordinates that are neither lengths nor angles ("1" for a sine)
    pose_units: ClassVar[Mapping[str, str]] = {}

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        if "parameters" in cls.__dict__:
            for k, v in derived_tables(cls.parameters).items():
                setattr(cls, k, v)

    @classmethod
    def param(cls, name: str) -> Param | None:
        """The declaration of parameter ``name`` (None if it has none)."""
        for p in cls.parameters:
            if p.name == name:
                return p
        return None

    def __init__(self, **params: Any):
        for k, v in list(params.items()):  # a switch may be given by its name
            if isinstance(v, str):
                decl = type(self).param(k)
                if decl is not None and decl.kind == "switch":
                    x, problem = decl.choice(v)
                    if problem:
                        raise ValueError(f"{type(self).__name__}: {k}: {problem}")
                    params[k] = x
        unknown = set(params).difference(self.design_parameters, self.fixed_parameters)
        if unknown:
            raise TypeError(f"{type(self).__name__}: unknown parameter(s) {', '.join(sorted(unknown))}")
        values: dict[str, np.ndarray] = {}
        for k in self.design_parameters:
            if k in params:
                values[k] = np.asarray(params[k], dtype=float)
            elif k in self.design_defaults:
                values[k] = np.asarray(self.design_defaults[k], dtype=float)
            else:
                raise TypeError(f"{type(self).__name__}: missing design parameter {k!r}")
        for k, v in self.fixed_parameters.items():
            values[k] = np.asarray(params.get(k, v), dtype=float)
        self.params = values
        for k, v in values.items():
            setattr(self, k, v)

    # ------------------------------------------------------------------ config hooks
    @classmethod
    def pose_kind(cls, axis: str) -> str:
        """``angle``, ``number`` or ``length``: the kind of a pose axis (it decides
        the units a workspace may give it)."""
        return {"rad": "angle", "1": "number"}.get(cls.pose_unit(axis), "length")

    @classmethod
    def check_design(cls, design: Mapping[str, float]) -> tuple[str, str] | None:
        """Return (key, message) if a design is geometrically impossible, else None."""
        return None

    @classmethod
    def pose_unit(cls, axis: str) -> str:
        """SI unit of a pose coordinate: ``m``, ``rad`` or ``1``."""
        return cls.pose_units.get(axis, "rad" if axis in cls.angular_axes else "m")

    @classmethod
    def actuator_unit(cls, params: Mapping[str, float]) -> str:
        """SI unit of the actuator coordinates (``m`` for prismatic and struts,
        ``rad`` for revolute inputs) given the fixed parameters (switches)."""
        return "m"

    @property
    def dof(self) -> int:
        return len(self.pose_names)

    @property
    def n_act(self) -> int:
        return len(self.actuator_names)

    @property
    def design_shape(self) -> tuple[int, ...]:
        """Broadcast shape of the design parameters (``()`` for one design)."""
        return np.broadcast_shapes(*(np.shape(self.params[k]) for k in self.design_parameters))

    # ------------------------------------------------------------------ kinematics
    def inverse(self, X: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def reachable(self, X: np.ndarray) -> np.ndarray:
        """Boolean mask: the pose can be reached (inverse kinematics has a real solution)."""
        return np.all(np.isfinite(self.inverse(X)), axis=-1)

    def forward(self, Q: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def jacobian(self, X: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def mass_matrix(self, X: np.ndarray) -> np.ndarray:
        raise NotImplementedError(f"mechanism {self.name!r} has no dynamic model")

    # ------------------------------------------------------------------ drawing
    def drawing(self, X: np.ndarray) -> dict | None:
        """The drawable points of one design at poses X (N, dof), from the
        mechanism's own inverse kinematics: ``base`` (N, k, 3) the base's
        outline, ``platform`` (N, m, 3) the platform's outline (closed polygon),
        ``joints`` (N, j, 3), ``legs`` a list of (N, n_pts, 3) chains (base
        joint, intermediate joints, platform joint), ``rods`` (N, r, 2, 3) the
        rigid rods of fixed length ``rod_lengths`` (r,) (may be empty), all in
        m; NaN where a pose is not reachable.  None: this mechanism has no
        drawing."""
        return None

    # ------------------------------------------------------------------ certificates
    def enclosure(self):
        """The interval enclosure of one design's kinematics over boxes of poses
        (optdesign.certify): a callable ``(lo, hi) -> {"reach_lo", "J", "q"}``
        for boxes lo, hi (K, dof): ``reach_lo`` (K,) > 0 where every pose of a
        box is reachable, ``J`` rows of :class:`optdesign.intervals.interval.Interval`
        (K,) enclosing the Jacobian of the indices, ``q`` per actuator an
        enclosure of its value or None.  Raises NotImplementedError (its
        message says why) where the mechanism has none."""
        raise NotImplementedError(f"no interval enclosure of the {type(self).__name__} mechanism yet")

    # ------------------------------------------------------------------ indices
    def global_statistics(self, requests: Sequence[IndexRequest], X: np.ndarray):
        """The compiled path's answer for these requests over the points X (N, dof):
        ``(summary, reachable)`` with ``summary[request.name]`` mapping ``mean``,
        ``min``, ``max``, ``std`` and ``count`` to arrays (D,) (statistics over
        the reachable points) and ``reachable`` (D, N), or None when this
        mechanism has no compiled path here.  The summary may answer only some
        of the requests (those its kernels compute); the caller
        (:func:`optdesign.evaluate.evaluate`) runs the numpy path for the
        others, with this reachable mask, which must equal the numpy model's
        bitwise.  Every answer must equal the numpy path's to 1e-12 relative."""
        return None

    def kernel_source(self, title: str) -> str | None:
        """The generated code of this mechanism's compiled kernel as the source
        of a module (its header names ``title``), or None: the mechanism has no
        generated kernel (a hand-written one, or none)."""
        return None

    @classmethod
    def specialize_kernels(cls) -> None:
        """Ask the compiled path to run this mechanism's shape on its
        specialized routines from now on in this process (a long computation,
        such as a large optimization run, whose kernel time outweighs compiling
        them once per machine; the results are the same bits).  No compiled
        path: nothing to do."""

    def rows_of(self, population: "Mechanism", index: np.ndarray) -> None:
        """Note that this mechanism's designs are the designs ``index`` (M,)
        of ``population`` (the same class and fixed parameters; the worst-case
        search builds such a mechanism for the starts it evaluates), so that a
        class may take per-design data ``population`` computed instead of
        computing them again, with the same bits (the engine's packing: the
        described mechanisms and the 3-P(4S) read ``_rows_of``)."""
        self.__dict__["_rows_of"] = (population, index)

    def local_values(self, requests: Sequence[IndexRequest], X: np.ndarray):
        """The compiled path's local values for these requests at the points X
        (N, dof): ``(values, reachable)`` with ``values[request.name]`` (D, N)
        (NaN where not reachable) and ``reachable`` (D, N), or None when this
        mechanism has no compiled path for them (the caller then runs the
        numpy path).  Used for weighted quadratures of the global index; the
        values must equal the numpy path's to 1e-12 relative."""
        return None

    def local_values_at(self, requests: Sequence[IndexRequest], X: np.ndarray):
        """As :meth:`local_values`, but each of the D designs at its own K
        points X (D, K, dof): ``(values {name: (D, K)}, reachable (D, K))``,
        or None (the caller then runs the numpy path).  The worst-case search
        over W (:mod:`optdesign.worstcase`) evaluates its poses this way."""
        return None

    def zoom_cond(self, request: IndexRequest, base, reg, u, val, h, live, budget, grid, stop, tol):
        """The worst-case search's zoom of one local value (the condition
        number) in the compiled path, every design m of this mechanism from
        its own start, in place on the search's state: ``(levels done (D,),
        bail (D,))`` (a start that met a point the compiled path leaves to the
        numpy path stops there, for the caller to go on), or None: the caller
        runs the search level by level (:func:`optdesign.worstcase.search._zoom`)."""
        return None

    def index_matrices(self, X: np.ndarray, needs: set[str]) -> dict[str, np.ndarray]:
        """The matrices the local indices need, keyed ``J`` (Jacobian) and ``M``
        (actuator-space mass matrix of the dynamic index)."""
        return self.state(X).matrices(needs)

    # ------------------------------------------------------------------ state
    # One state per (design population, poses) (:mod:`.state`): the inverse
    # kinematics and what follows from it, computed once and shared by every
    # index, constraint and backend asking at these poses.  A mechanism with a
    # kinematic core (its per-leg inverse kinematics) overrides the ``*_of``
    # methods to compute each quantity from it; the defaults below call the
    # public methods.
    def state(self, X: np.ndarray) -> PoseState:
        """The state of this mechanism (design or population) at poses X (..., N, dof)."""
        return PoseState(self, X)

    def kinematic_core(self, X: np.ndarray):
        """The per-pose inverse kinematics and leg geometry every other quantity
        is computed from, or None (the default: no shared core)."""
        return None

    def inverse_of(self, st: PoseState) -> np.ndarray:
        return self.inverse(st.X)

    def reachable_of(self, st: PoseState) -> np.ndarray:
        if type(self).reachable is Mechanism.reachable:
            return np.all(np.isfinite(st.q), axis=-1)
        return self.reachable(st.X)

    def jacobian_of(self, st: PoseState) -> np.ndarray:
        return self.jacobian(st.X)

    def index_matrices_of(self, st: PoseState, needs: set[str]) -> dict[str, np.ndarray]:
        """``J`` and/or ``M`` at the state's poses (``needs``)."""
        out: dict[str, np.ndarray] = {}
        if "J" in needs:
            out["J"] = st.J
        if "M" in needs:
            out["M"] = self.mass_matrix(st.X)
        return out

    def __repr__(self) -> str:
        parts = []
        for k in self.design_parameters:
            v = self.params[k]
            parts.append(f"{k}={float(v):g}" if v.ndim == 0 else f"{k}=<{v.shape}>")
        return f"{type(self).__name__}({', '.join(parts)})"
