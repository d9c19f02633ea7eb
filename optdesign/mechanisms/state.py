"""The state of a mechanism at poses: one per (design population, poses).

In the spirit of Pinocchio's model/data split, a :class:`~optdesign.mechanisms.Mechanism`
holds the design (its parameters), and a :class:`PoseState`, made by
``mech.state(X)``, holds what is computed at the poses X: the inverse
kinematics and the per-leg geometry it yields (``core``), the actuator values
``q``, the reachable mask, the Jacobian ``J`` and the actuator-space mass
matrix ``M``.  Each is computed on first use and kept, so every index,
constraint and backend that asks for it at these poses shares one inverse
kinematics.

The mechanism says how each quantity follows from the state through its
``*_of`` methods (``kinematic_core``, ``inverse_of``, ``reachable_of``,
``jacobian_of``, ``index_matrices_of``); the defaults call the public methods,
so a mechanism without a shared core works unchanged.
"""
from __future__ import annotations

import numpy as np

__all__ = ["PoseState"]

_UNSET = object()


class PoseState:
    """Quantities of one mechanism (a design or a population) at poses X, each
    computed once, on first use (see the module docstring)."""

    __slots__ = ("X", "_J", "_core", "_mats", "_q", "_reachable", "mech", "notes")

    def __init__(self, mech, X):
        self.mech = mech
        self.X = np.asarray(X, dtype=float)
        self._core = self._q = self._reachable = self._J = _UNSET
        self._mats: dict[str, np.ndarray] = {}
        #: what a mechanism records about how a quantity was computed (e.g.
        #: whether ``q`` came from its compiled path)
        self.notes: dict[str, object] = {}

    @property
    def core(self):
        """The mechanism's per-pose kinematic core (its inverse kinematics and the
        per-leg geometry), or None where it has none."""
        if self._core is _UNSET:
            self._core = self.mech.kinematic_core(self.X)
        return self._core

    @property
    def q(self) -> np.ndarray:
        """Actuator values (..., N, n_act), NaN where not reachable."""
        if self._q is _UNSET:
            self._q = self.mech.inverse_of(self)
        return self._q

    @property
    def reachable(self) -> np.ndarray:
        """Boolean mask (..., N): the pose is reachable."""
        if self._reachable is _UNSET:
            self._reachable = self.mech.reachable_of(self)
        return self._reachable

    @property
    def J(self) -> np.ndarray:
        """The Jacobian (..., N, n_act, dof), qdot = J xdot."""
        if self._J is _UNSET:
            self._J = self._mats["J"] if "J" in self._mats else self.mech.jacobian_of(self)
        return self._J

    def matrices(self, needs) -> dict[str, np.ndarray]:
        """The matrices the local indices need (``J``, ``M``), computed together
        where the mechanism builds them together, each at most once."""
        have = set(self._mats) | ({"J"} if self._J is not _UNSET else set())
        missing = set(needs) - have
        if missing:
            self._mats.update(self.mech.index_matrices_of(self, missing))
            if "J" in self._mats and self._J is _UNSET:
                self._J = self._mats["J"]
        return {k: (self._J if k == "J" else self._mats[k]) for k in needs}
