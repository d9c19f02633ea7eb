"""The Mechanism class built from a description (a class factory).

:func:`make_class` turns a validated :class:`~.schema.Description` into a
subclass of :class:`DescribedMechanism` whose parameters, pose names and
actuator names come from the description; instances hold the parameter values
(scalars for one design, ``(D, 1)`` arrays for a population) like every
hand-written mechanism, and derive everything from the per-design constants
(:mod:`.constants`) with the per-kind formulas of :mod:`.legs`,
:mod:`.dynamics` and :mod:`.kinematics`.

Jacobian conventions: ``jacobian_rates`` is ``dq/dx`` in the pose
coordinates (``qdot = J xdot``), ``jacobian_twist`` the rows ``G`` on the
platform's own velocity components (linear velocity of the platform origin and
angular velocity in the base frame: for the 3-SPS-S, eq. 10's ``(b_i x q_i)^T``).
``jacobian`` is the one the description's ``pose.jacobian`` names
(``rates``, the default, or ``angular_velocity``); for translational and
planar poses they coincide.  ``mass_matrix`` is ``J^-T M_p`` in the same
convention, so that the dynamic index matches ``P4S.mass_matrix``.
"""
from __future__ import annotations

from typing import Any, ClassVar, Mapping

import numpy as np

from ..base import Mechanism
from ..params import Param
from . import kinematics as _kin
from .constants import Constants, constants
from .dynamics import _solve_T, actuator_forces_of, potential_energy, twist_dynamics
from .legs import leg_state
from .memo import CONSTANTS, params_key
from .poses import rate_bias, rate_map, twist_columns
from .schema import Description

__all__ = ["DescribedMechanism", "make_class", "KINEMATIC_INDICES"]

KINEMATIC_INDICES = ("stiffness", "isotropy", "dexterity", "manipulability", "driving", "axis_stiffness")


class DescribedMeta(type):
    """The metaclass of described mechanisms: their classes pickle as their
    description (see optdesign.mechanisms.described)."""


class DescribedMechanism(Mechanism, metaclass=DescribedMeta):
    """A mechanism whose legs, joints and dimensions are data (see
    docs/mechanisms-as-data.md).  Subclasses are made by :func:`make_class`."""

    description: ClassVar[Description]
    parameters: ClassVar[tuple] = ()
    described: ClassVar[bool] = True
    #: (raw description, label, key path) it was built from (pickling)
    raw_description: ClassVar[tuple] = ()

    @classmethod
    def actuator_units(cls, params=None) -> tuple[str, ...]:
        """SI unit of each actuator coordinate: rad for a revolute leg's crank
        angle, m for a prismatic leg's stroke and a strut's length."""
        return tuple("rad" if leg.kind == "revolute" else "m" for leg in cls.description.legs)

    @classmethod
    def actuator_unit(cls, params) -> str:
        units = set(cls.actuator_units(params))
        return units.pop() if len(units) == 1 else "m"

    # ------------------------------------------------------------------ constants
    @property
    def constants(self) -> Constants:
        c = self.__dict__.get("_constants")
        if c is None:
            key = params_key(self)
            c = CONSTANTS.get(key)
            if c is None:
                c = constants(self.description, self.params)
                CONSTANTS.put(key, c)
            self.__dict__["_constants"] = c
        return c

    @property
    def pose_spec(self):
        return self.description.pose

    def leg_state(self, X: np.ndarray) -> dict:
        """Inverse kinematics and per-leg geometry (:func:`.legs.leg_state`)."""
        return leg_state(self.constants, self.pose_spec, X)

    # ------------------------------------------------------------------ kinematics
    def inverse(self, X: np.ndarray) -> np.ndarray:
        """Actuator values (..., N, n_act) (m for prismatic and strut legs, rad for
        revolute ones); NaN where the pose is not reachable."""
        return self.state(X).q

    def reachable(self, X: np.ndarray) -> np.ndarray:
        return self.state(X).reachable

    # the state at poses (:mod:`optdesign.mechanisms.state`): the legs' inverse kinematics once
    def kinematic_core(self, X: np.ndarray) -> dict:
        return self.leg_state(X)

    def inverse_of(self, st) -> np.ndarray:
        return st.core["q"]

    def reachable_of(self, st) -> np.ndarray:
        return st.core["reachable"]

    def jacobian_of(self, st) -> np.ndarray:
        return self._jac(st.core, self.pose_spec.jacobian)

    def _jac(self, st: dict, convention: str) -> np.ndarray:
        G = st["G"]
        spec = self.pose_spec
        if convention == "angular_velocity" or spec.type in ("translation", "planar"):
            return G[..., list(twist_columns(spec))]
        S = rate_map(spec, st["frames"])
        return np.einsum("...ik,...kj->...ij", G, S)

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """J (..., N, n_act, dof) in the description's convention (``pose.jacobian``)."""
        return self.state(X).J

    def jacobian_rates(self, X: np.ndarray) -> np.ndarray:
        """dq/dx (..., N, n_act, dof): qdot = J xdot for the pose-coordinate rates."""
        return self._jac(self.leg_state(X), "rates")

    def jacobian_twist(self, X: np.ndarray) -> np.ndarray:
        """The rows G on the platform's velocity components (..., N, n_act, dof):
        linear velocity of the platform origin (x, y, z coordinates) and angular
        velocity in the base frame (for the angles)."""
        return self._jac(self.leg_state(X), "angular_velocity")

    def enclosure(self):
        """The interval enclosure of this design's kinematics (:mod:`.enclosure`)."""
        from .enclosure import DescribedEnclosure, supports

        why = supports(self)
        if why is not None:
            raise NotImplementedError(f"no interval enclosure: {why}")
        return DescribedEnclosure(self).evaluate

    def drawing(self, X: np.ndarray) -> dict:
        """The drawable points of one design at poses X (N, dof) (see
        :meth:`Mechanism.drawing`): each leg from its base point A through the
        actuated point (slider or crank tip; a strut goes straight) to its
        platform point b; the rods (of length ``l``) from the actuated point to b."""
        from .drawing import drawing

        return drawing(self, X)

    def forward(self, Q: np.ndarray, X0: np.ndarray | None = None) -> np.ndarray:
        """Forward kinematics (..., N, dof): the pose with these actuator values
        nearest the start X0 (default: the description's home pose) in the
        assembly mode of the description's branches; NaN where none is found.
        Translational 3-leg mechanisms: closed form (sphere intersection);
        others: Newton on the closures from X0 (then from perturbed starts)."""
        return _kin.forward(self, Q, X0)

    def forward_all(self, Q: np.ndarray, **kw) -> list[np.ndarray]:
        """Every pose found for each row of Q (N, n_act), as a list of (k, dof)
        arrays (see :func:`.kinematics.forward_all`)."""
        return _kin.forward_all(self, Q, **kw)

    # ------------------------------------------------------------------ dynamics
    def _require_dynamics(self):
        if not self.description.has_dynamics:
            raise NotImplementedError(f"described mechanism {self.description.label!r} has no masses (give platform.mass)")

    def _pose_dyn(self, st: dict, Xd=None, convention: str = "rates") -> dict:
        """M, c, g in pose coordinates (rates) or on the twist components."""
        spec = self.pose_spec
        xi = None
        S = None
        cols = list(twist_columns(spec))
        if convention == "angular_velocity" or spec.type in ("translation", "planar"):
            if Xd is not None:
                Xd = np.asarray(Xd, dtype=float)
                xi = np.zeros(np.broadcast_shapes(st["G"].shape[:-2], Xd.shape[:-1]) + (6,))
                xi[..., cols] = Xd
            sigma = None
        else:
            S = rate_map(spec, st["frames"])
            if Xd is not None:
                xi = np.einsum("...ij,...j->...i", S, np.asarray(Xd, dtype=float))
                sigma = rate_bias(spec, st["frames"], Xd)
        dyn = twist_dynamics(self.constants, st, xi)
        M, g = dyn["M"], dyn["g"]
        if S is None:
            out = {"M": M[..., cols, :][..., :, cols], "g": g[..., cols]}
            if xi is not None:
                out["c"] = dyn["c"][..., cols]
        else:
            out = {"M": np.einsum("...ki,...kl,...lj->...ij", S, M, S), "g": np.einsum("...ki,...k->...i", S, g)}
            if xi is not None:
                out["c"] = np.einsum("...ki,...k->...i", S, np.einsum("...ij,...j->...i", M, sigma) + dyn["c"])
        if xi is not None:
            out["qddot_bias"] = dyn["qddot_bias"]
            out["xi"] = xi
            out["sigma"] = sigma
        out["J"] = self._jac(st, convention)
        return out

    def platform_mass_matrix(self, X: np.ndarray, convention: str | None = None) -> np.ndarray:
        """M_p (..., N, dof, dof), kinetic energy T = xdot^T M_p xdot / 2 (in the
        ``jacobian`` convention's velocity coordinates unless given)."""
        self._require_dynamics()
        return self._pose_dyn(self.leg_state(X), None, convention or self.pose_spec.jacobian)["M"]

    def mass_matrix(self, X: np.ndarray) -> np.ndarray:
        """M = J^-T M_p (..., N, n_act, dof): actuator forces per unit pose
        acceleration (eq. 23 of the 3-P(4S) paper), the matrix of the dynamic index."""
        self._require_dynamics()
        return self.state(X).matrices({"M"})["M"]

    def _forces(self, X, V, A=None, parts=("M", "c", "g")):
        self._require_dynamics()
        return actuator_forces_of(self._pose_dyn(self.leg_state(X), V, "rates"), A, parts, self.dof)

    def actuator_forces(self, X: np.ndarray, V: np.ndarray, A: np.ndarray) -> np.ndarray:
        """Actuator forces/torques (..., N, n_act) for poses X, pose-coordinate rates
        V and accelerations A: tau = J^-T (M_p a + c(x, v) + g(x))."""
        return self._forces(X, V, A)

    def velocity_term(self, X: np.ndarray, V: np.ndarray) -> np.ndarray:
        """J^-T c(x, v) (..., N, n_act)."""
        return self._forces(X, V, None, ("c",))

    def gravity_term(self, X: np.ndarray) -> np.ndarray:
        """J^-T g(x) (..., N, n_act): the forces that hold the mechanism still."""
        X = np.asarray(X, dtype=float)
        return self._forces(X, np.zeros(X.shape), None, ("g",))

    def accelerations(self, X: np.ndarray, V: np.ndarray, A: np.ndarray) -> np.ndarray:
        """Actuator accelerations qddot = J a + (velocity products) (..., N, n_act), rates."""
        st = self.leg_state(X)
        d = self._pose_dyn(st, V, "rates") if self.description.has_dynamics else None
        if d is None:
            spec = self.pose_spec
            xi = np.zeros(np.broadcast_shapes(st["G"].shape[:-2], np.shape(V)[:-1]) + (6,))
            S = rate_map(spec, st["frames"])
            if S is None:
                xi[..., list(twist_columns(spec))] = V
                sig = np.zeros(xi.shape)
            else:
                xi = np.einsum("...ij,...j->...i", S, np.asarray(V, float))
                sig = rate_bias(spec, st["frames"], V)
            qb = twist_dynamics(self.constants, st, xi)["qddot_bias"]
            J = self._jac(st, "rates")
        else:
            qb, sig, J = d["qddot_bias"], d["sigma"], d["J"]
        out = np.einsum("...ij,...j->...i", J, np.asarray(A, dtype=float)) + qb
        if sig is not None:
            out = out + np.einsum("...ij,...j->...i", st["G"], sig)
        return out

    def energies(self, X: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Kinetic and potential energy (..., N) at poses X with rates V."""
        self._require_dynamics()
        st = self.leg_state(X)
        M = self._pose_dyn(st, None, "rates")["M"]
        V = np.asarray(V, dtype=float)
        T = 0.5 * np.einsum("...i,...ij,...j->...", V, M, V)
        return T, potential_energy(self.constants, st)

    # ------------------------------------------------------------------ indices
    def index_matrices_of(self, state, needs: set[str]) -> dict[str, np.ndarray]:
        st = state.core
        out: dict[str, np.ndarray] = {}
        conv = self.pose_spec.jacobian
        if "M" in needs:
            self._require_dynamics()
            d = self._pose_dyn(st, None, conv)
            out["M"] = _solve_T(d["J"], d["M"])
            if "J" in needs:
                out["J"] = d["J"]
        elif "J" in needs:
            out["J"] = self._jac(st, conv)
        return out

    def global_statistics(self, requests, X, want_max_cond: bool = False):
        """Global statistics from the compiled path (:mod:`.compiled`) for the
        requests it computes, or None (then the numpy path runs)."""
        from .compiled import global_statistics

        return global_statistics(self, requests, X, want_max_cond)

    def local_values(self, requests, X):
        """The compiled path's local values of the designs at shared points X
        (N, dof) (:func:`.compiled.local_values`: weighted quadratures and the
        adaptive cubature), or None."""
        from .compiled import local_values

        return local_values(self, requests, X)

    def local_values_at(self, requests, X):
        """The compiled path's local values, each design at its own points X
        (D, K, dof) (:func:`.compiled.local_values_at`), or None."""
        from .compiled import local_values_at

        return local_values_at(self, requests, X)

    def zoom_cond(self, request, base, reg, u, val, h, live, budget, grid, stop, tol):
        """The zoom in the engine (:func:`.compiled.zoom_cond`), or None."""
        from .compiled import zoom_cond

        return zoom_cond(self, request, base, reg, u, val, h, live, budget, grid, stop, tol)

    @classmethod
    def specialize_kernels(cls) -> None:
        """This shape on the engine's specialized tier (see ``Mechanism.specialize_kernels``)."""
        from ... import engine
        from .packing import description_codes, kernel_spec

        try:
            engine.specialize(kernel_spec(description_codes(cls.description)))
        except ValueError:          # a shape the engine does not pack (chain legs): nothing to specialize
            pass

    def kernel_source(self, title: str) -> str:
        """The generated routines of the engine's specialized tier for this shape (:mod:`optdesign.engine.codegen`)."""
        from .compiled import kernel_source

        return kernel_source(self, title)

    def invalid_designs(self) -> np.ndarray:
        """(D,) or (): designs whose physical quantities are impossible (a
        negative mass or inertia, a rod count that is not a whole number from
        1 to 100, a centre outside [0, 1], gravity outside [0, 1000] m/s^2;
        :mod:`.physical`): an evaluation makes them infeasible."""
        from .physical import invalid

        C = self.constants
        return invalid(self.description, C).reshape(C.shape[:1]) if C.shape else invalid(self.description, C)

    # ------------------------------------------------------------------ config checks
    @classmethod
    def check_physical(cls, parameters: Mapping[str, float], designs: Mapping[str, Mapping[str, float]]):
        """(key path, message) of the first design (named, or a corner of the
        bounds) with an impossible physical quantity (:mod:`.physical`), else None."""
        from .physical import first_problem

        fixed = dict(cls.fixed_parameters)
        fixed.update({k: v for k, v in parameters.items() if k in fixed})
        for dname, design in designs.items():
            env = {**cls.design_defaults, **fixed, **{k: v for k, v in design.items() if k in cls.design_parameters}}
            env = {k: v for k, v in env.items() if k in cls.design_parameters or k in cls.fixed_parameters}
            for k in cls.design_parameters:
                env.setdefault(k, float("nan"))
            problem = first_problem(cls.description, constants(cls.description, env))
            if problem:
                return problem[0], f"{problem[1]} ({dname})"
        return None

    @classmethod
    def check_config(cls, parameters: Mapping[str, float], designs: Mapping[str, Mapping[str, float]]):
        """(key path, message) of the first problem of the description with the
        config's fixed parameters and named designs, else None (expressions not
        finite, zero directions, legs that do not close at the home pose, a
        Jacobian singular at and around the home pose)."""
        from .checks import check_designs

        return check_designs(cls, parameters, designs)


def _param_table(desc: Description) -> tuple:
    out = []
    for p in desc.params:
        low, low_open = None, False
        if p.kind in ("length", "stiffness"):
            low, low_open = 0.0, True
        elif p.kind in ("mass", "inertia"):
            low = 0.0
        out.append(Param(p.name, p.kind, default=p.default, design=p.design, low=low, low_open=low_open, doc=p.doc))
    return tuple(out)


def make_class(desc: Description, registry_name: str) -> type[DescribedMechanism]:
    """A Mechanism subclass for the description, registered as ``registry_name``."""
    design = tuple(p.name for p in desc.params if p.design)
    fixed = {p.name: p.default for p in desc.params if not p.design}
    base: type = DescribedMechanism
    pose_names = tuple(desc.pose.names[i] for i in desc.pose.independent_index)
    roles = tuple(desc.pose.roles[i] for i in desc.pose.independent_index)
    attrs: dict[str, Any] = {
        "name": registry_name,
        "description": desc,
        "parameters": _param_table(desc),
        "pose_names": pose_names,
        "actuator_names": desc.actuator_names,
        "design_parameters": design,
        "design_defaults": {p.name: p.default for p in desc.params if p.design and p.default is not None},
        "length_parameters": tuple(p.name for p in desc.params if p.design and p.kind == "length"),
        "fixed_parameters": fixed,
        "positive_parameters": tuple(p.name for p in desc.params if not p.design and p.kind in ("length", "stiffness")),
        "nonnegative_parameters": tuple(p.name for p in desc.params if not p.design and p.kind in ("mass", "inertia")),
        "multibody_check": "optdesign.mechanisms.described.mujoco" if desc.has_dynamics else None,
        "supported_indices": KINEMATIC_INDICES + (("dynamic",) if desc.has_dynamics else ()),
        "angular_axes": tuple(n for n, r in zip(pose_names, roles) if r in ("roll", "pitch", "yaw")),
        "__doc__": f"Described mechanism {desc.label!r}: {len(desc.legs)} legs "
                   f"({', '.join(sorted({leg.kind for leg in desc.legs}))}), {desc.pose.type} pose "
                   f"({', '.join(desc.pose.names)}).",
    }
    if desc.is_chain:                       # lower mobility (optdesign.mechanisms.described.chain_mechanism)
        from .chain_mechanism import ChainMechanism, chain_attributes

        base = ChainMechanism
        attrs.update(chain_attributes(desc, attrs))
    return DescribedMeta(f"Described_{desc.label}", (base,), attrs)
