"""Described mechanisms with chain legs (lower mobility, parasitic motion).

A :class:`ChainMechanism` is the class :func:`.mechanism.make_class` makes of a
description with a ``kind: chain`` leg or with ``pose.independent``.  Its pose
coordinates (``pose_names``) are the independent ones; the parasitic ones
(``parasitic_names``) follow from the chains' closures
(:mod:`.chain_solve`).  Shorthand legs (prismatic, revolute, strut) keep their
closed forms at the whole pose.  ``jacobian`` is dq/dx in the independent
coordinates' rates; the screw-theory Jacobians and the constraint singularity
are in :mod:`.chain_screws`, the dynamics in :mod:`.chain_dynamics`.
See docs/lower-mobility.md.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from .chain_constants import SLIDE, ChainConstants, chain_constants
from .chain_poe import lsq
from .chain_solve import continuation, fk_system, flat_constants, ik_system, newton
from .legs import leg_state
from .chain_checks import ChainChecks
from .chain_dynamics import ChainDynamics
from .chain_screws import ChainScrews
from .chain_maps import coordinate_map, home_coordinates, unmap
from .mechanism import DescribedMechanism

__all__ = ["ChainMechanism", "chain_attributes"]

_ANGLES = ("roll", "pitch", "yaw")


class ChainMechanism(ChainScrews, ChainDynamics, ChainChecks, DescribedMechanism):
    """A described mechanism with chain legs and parasitic pose coordinates."""

    #: the parasitic pose coordinates' names (solved from the closures)
    parasitic_names: ClassVar[tuple] = ()

    @classmethod
    def actuator_units(cls, params=None) -> tuple[str, ...]:
        desc = cls.description
        out = []
        for _, src, i in desc.actuators:
            if src == "leg":
                out.append("rad" if desc.legs[i].kind == "revolute" else "m")
            else:
                c = desc.chains[i]
                j = next(j for j in c.joints if j.actuated is not None)
                slide = j.type == "P" or (j.type == "C" and j.actuated == 0)
                out.append("m" if slide else "rad")
        return tuple(out)

    # ------------------------------------------------------------------ constants
    @property
    def chain_constants(self) -> ChainConstants:
        c = self.__dict__.get("_chain_constants")
        if c is None:
            c = chain_constants(self.description, self.params)
            self.__dict__["_chain_constants"] = c
            self.__dict__["_constants"] = c.base
        return c

    @property
    def constants(self):
        return self.chain_constants.base

    def _sizes(self):
        cc = self.chain_constants
        ks = [leg.k for leg in cc.legs]
        return ks, int(np.sum(ks)), len(self.pose_spec.parasitic_index)

    def _weights(self, fc, fk: bool = False) -> np.ndarray:
        """Per unknown: L for angles, 1 for lengths (the continuation's jump test)."""
        L = fc["length"][:, None]
        cols = []
        for leg in fc["legs"]:
            for j, code in enumerate(leg["codes"]):
                if not (fk and j == leg["act"]):
                    cols.append(L if code != SLIDE else np.ones_like(L))
        spec = self.pose_spec
        idx = range(spec.dof) if fk else spec.parasitic_index
        for i in idx:
            cols.append(L if spec.roles[i] in _ANGLES else np.ones_like(L))
        return np.concatenate(cols, 1) if cols else np.zeros((len(L), 0))

    def _flat(self, batch):
        """(flat constants, design index (B,)) for a batch shape of points."""
        S = self.chain_constants.base.shape
        D = int(np.prod(S)) if S else 1
        didx = np.broadcast_to(np.arange(D).reshape(S) if S else np.array(0), batch).ravel()
        return flat_constants(self.chain_constants, didx), didx

    # ------------------------------------------------------------------ home
    def home_solution(self):
        """(u (D, nu), solved (D,)): the home configuration of every design (the
        closure's solution Newton reaches from the joints' ``home`` values and
        ``pose.home``)."""
        h = self.__dict__.get("_home")
        if h is not None:
            return h
        cc = self.chain_constants
        S = cc.base.shape
        D = int(np.prod(S)) if S else 1
        fc = flat_constants(cc, np.arange(D))
        spec = self.pose_spec
        home = np.asarray(spec.home, dtype=float)
        u0 = np.concatenate([leg["home"] for leg in fc["legs"]] +
                            [np.broadcast_to(home[list(spec.parasitic_index)], (D, len(spec.parasitic_index)))], 1)
        p = np.broadcast_to(home[list(spec.independent_index)], (D, len(spec.independent_index)))
        u, ok, _ = newton(lambda x, q: ik_system(self.description, fc, x, q), u0, p, fc["length"], iters=100,
                          damped=True)
        h = (np.where(ok[:, None], u, np.nan), ok)
        self.__dict__["_home"] = h
        return h

    # ------------------------------------------------------------------ inverse kinematics
    def chain_state(self, X: np.ndarray) -> dict:
        """Everything the inverse kinematics gives at independent coordinates X
        (..., N, n_ind): ``q`` (..., N, n_act) and ``reachable``; ``Xf`` the whole
        pose (..., N, dof); ``theta`` (list per chain, (..., N, k)); ``U`` =
        du/dx (..., N, nu, n_ind) of the unknowns u = (theta..., x_par); ``P`` =
        dXf/dx (..., N, dof, n_ind); ``J`` = dq/dx; ``st`` the shorthand legs'
        state at Xf (:func:`.legs.leg_state`)."""
        X = Xin = np.asarray(X, dtype=float)
        desc, spec = self.description, self.pose_spec
        ind, par = list(spec.independent_index), list(spec.parasitic_index)
        S = self.chain_constants.base.shape
        cmap = None
        if spec.cmap is not None:
            cmap = self._coordinate_map(X)
            X = cmap[0]
        batch = np.broadcast_shapes(S, X.shape[:-1])
        fc, didx = self._flat(batch)
        B = len(didx)
        p1 = np.broadcast_to(X, batch + X.shape[-1:]).reshape(B, -1)
        uh, hok = self.home_solution()
        home = np.asarray(spec.home, dtype=float)
        p0 = np.broadcast_to(home[ind], p1.shape)
        fun = lambda c, x, q: ik_system(desc, c, x, q)  # noqa: E731
        u, ok = continuation(fun, fc, uh[didx], p0, p1, self._weights(fc))
        with np.errstate(all="ignore"):
            _, Fu, Fp = ik_system(desc, fc, np.where(ok[:, None], u, 0.0), p1)
            U = -lsq(Fu, Fp)
        U = np.where(ok[:, None, None], U, np.nan)
        ks, nth, npar = self._sizes()
        Xf = np.zeros((B, spec.dof))
        Xf[:, ind] = p1
        Xf[:, par] = u[:, nth:]
        P = np.zeros((B, spec.dof, len(ind)))
        P[:, ind, :] = np.eye(len(ind))
        P[:, par, :] = U[:, nth:, :]
        shp = lambda a: a.reshape(batch + a.shape[1:])  # noqa: E731
        Xf, P, U, u, ok, Fu = shp(Xf), shp(P), shp(U), shp(u), shp(ok), shp(Fu)
        st = leg_state(self.chain_constants.base, spec, np.where(ok[..., None], Xf, np.nan))
        thetas, offs = [], np.cumsum([0] + ks)
        for i in range(len(ks)):
            thetas.append(u[..., offs[i]:offs[i + 1]])
        n_act = len(desc.actuators)
        q = np.full(batch + (n_act,), np.nan)
        J = np.full(batch + (n_act, len(ind)), np.nan)
        with np.errstate(all="ignore"):
            for a, (_, src, i) in enumerate(desc.actuators):
                if src == "chain":
                    leg = self.chain_constants.legs[i]
                    j = offs[i] + leg.act
                    q[..., a] = u[..., j] + leg.offset[..., leg.act]
                    J[..., a, :] = U[..., j, :]
                else:
                    from .chain_solve import full_rate_map

                    Sf = full_rate_map(spec, st["frames"])
                    q[..., a] = st["q"][..., i]
                    J[..., a, :] = np.einsum("...k,...kl,...lj->...j", st["G"][..., i, :], Sf, P)
        out = {"X": Xin, "Xf": Xf, "u": u, "theta": thetas, "U": U, "P": P, "J": J, "st": st, "Fu": Fu}
        if cmap is not None:                      # d/d(coordinates) = d/d(pose coordinates) Df
            Df, H = cmap[1], cmap[2]
            out.update(Ur=U, Pr=P, H=H, Df=Df, U=U @ Df, P=P @ Df, J=J @ Df)
            J = out["J"]
        reach = ok & np.all(np.isfinite(q), axis=-1) & np.all(np.isfinite(J), axis=(-1, -2))
        out["q"] = np.where(reach[..., None], q, np.nan)
        out["reachable"] = reach
        return out

    # ------------------------------------------------------------------ a declared coordinate map (chain_maps)
    def _coordinate_map(self, X):
        return coordinate_map(self, X)

    def _unmap(self, Xr):
        return unmap(self, Xr)

    def home_coordinates(self) -> np.ndarray:
        """The independent coordinates of the home pose, S + (n,) (the map
        inverted where there is one: per design when it has parameters)."""
        return home_coordinates(self)

    def kinematic_core(self, X):
        return self.chain_state(X)

    def inverse_of(self, st):
        return st.core["q"]

    def reachable_of(self, st):
        return st.core["reachable"]

    def jacobian_of(self, st):
        return np.where(st.core["reachable"][..., None, None], st.core["J"], np.nan)

    def index_matrices_of(self, st, needs):
        out = {}
        if "J" in needs:
            out["J"] = st.J
        if "M" in needs:
            self._require_dynamics()
            out["M"] = self._actuator_mass(st)
        if "C" in needs:
            from .chain_screws import constraint_value

            out["C"] = constraint_value(self, st.core)
        return out

    def jacobian_rates(self, X):
        """dq/dx in the independent coordinates' rates (the ``jacobian``)."""
        return self.jacobian(X)

    def jacobian_twist(self, X):
        return self.jacobian(X)

    def leg_state(self, Xf):
        """The shorthand legs' state (:func:`.legs.leg_state`) at *whole* poses Xf
        (..., N, dof of the pose type); :meth:`chain_state` takes the independent
        coordinates."""
        return leg_state(self.constants, self.pose_spec, Xf)

    def parasitic(self, X: np.ndarray) -> np.ndarray:
        """The parasitic coordinates (..., N, n_par) at independent coordinates X."""
        core = self.state(X).core
        par = list(self.pose_spec.parasitic_index)
        return np.where(core["reachable"][..., None], core["Xf"][..., par], np.nan)

    def parasitic_jacobian(self, X: np.ndarray) -> np.ndarray:
        """d x_par / d x (..., N, n_par, n_ind)."""
        core = self.state(X).core
        par = list(self.pose_spec.parasitic_index)
        return np.where(core["reachable"][..., None, None], core["P"][..., par, :], np.nan)

    def whole_pose(self, X: np.ndarray) -> np.ndarray:
        """Every coordinate of the pose type (..., N, dof of the type), in ``pose.coordinates`` order."""
        core = self.state(X).core
        return np.where(core["reachable"][..., None], core["Xf"], np.nan)

    def joint_values(self, X: np.ndarray) -> list:
        """Per chain leg, its joint values (..., N, k) (variables of the reference
        configuration's motions, without the offsets; NaN where not reachable)."""
        core = self.state(X).core
        return [np.where(core["reachable"][..., None], t, np.nan) for t in core["theta"]]

    # ------------------------------------------------------------------ screw theory
    def home_state(self) -> dict:
        """The home configuration of every design as (D, 1)-shaped arrays:
        ``Xf`` (D, 1, dof), ``theta`` (list of (D, 1, k)), ``U`` (D, 1, nu, n_ind)
        (NaN where the closures' Jacobian in the unknowns is rank deficient)."""
        spec = self.pose_spec
        u, ok = self.home_solution()
        D = len(u)
        ks, nth, npar = self._sizes()
        home = np.asarray(spec.home, dtype=float)
        Xf = np.broadcast_to(home, (D, spec.dof)).copy()
        Xf[:, list(spec.parasitic_index)] = u[:, nth:]
        fc = flat_constants(self.chain_constants, np.arange(D))
        p = np.broadcast_to(home[list(spec.independent_index)], (D, len(spec.independent_index)))
        with np.errstate(all="ignore"):
            _, Fu, Fp = ik_system(self.description, fc, np.where(ok[:, None], u, 0.0), p)
            U = -lsq(Fu, Fp)
        offs = np.cumsum([0] + ks)
        S = self.chain_constants.base.shape
        shp = lambda a: a.reshape(tuple(S) + a.shape[1:]) if S else a[0]  # noqa: E731
        return {"Xf": shp(Xf), "theta": [shp(u[:, offs[i]:offs[i + 1]]) for i in range(len(ks))], "U": shp(U),
                "ok": shp(ok)}

    # ------------------------------------------------------------------ forward kinematics
    def forward(self, Q: np.ndarray, X0=None) -> np.ndarray:
        """Forward kinematics (..., N, n_ind): the pose connected to the home
        configuration by continuation along the straight segment from the home
        actuator values to Q (docs/lower-mobility.md); NaN where none is found
        or its inverse kinematics (in the description's branch) does not give
        Q back (1e-9 relative).  ``X0`` is not used (the branch is defined)."""
        Q = np.asarray(Q, dtype=float)
        desc, spec = self.description, self.pose_spec
        S = self.chain_constants.base.shape
        batch = np.broadcast_shapes(S, Q.shape[:-1])
        fc, didx = self._flat(batch)
        B = len(didx)
        p1 = np.broadcast_to(Q, batch + Q.shape[-1:]).reshape(B, -1)
        uh, _ = self.home_solution()
        home = np.asarray(spec.home, dtype=float)
        D = len(uh)
        Xh = np.broadcast_to(home, (D, spec.dof)).copy()
        ks, nth, npar = self._sizes()
        Xh[:, list(spec.parasitic_index)] = uh[:, nth:]
        qh = self._home_actuators()
        keep = [o + j for o, leg in zip(np.cumsum([0] + ks), self.chain_constants.legs)
                for j in range(leg.k) if j != leg.act]
        u0 = np.concatenate([uh[:, keep], Xh], 1)[didx]
        fun = lambda c, x, q: fk_system(desc, c, x, q)  # noqa: E731
        u, ok = continuation(fun, fc, u0, qh[didx], p1, self._weights(fc, fk=True))
        X = u[:, u.shape[1] - spec.dof:][:, list(spec.independent_index)]
        X = X.reshape(batch + (X.shape[-1],))
        if spec.cmap is not None:
            X = self._unmap(X)
        with np.errstate(all="ignore"):
            back = self.inverse(X)
            Qb = np.broadcast_to(Q, back.shape)
            good = np.all(np.abs(back - Qb) <= 1e-9 * (1.0 + np.abs(Qb)), axis=-1) & ok.reshape(batch)
        return np.where(good[..., None], X, np.nan)

    def _home_actuators(self) -> np.ndarray:
        """The actuator values (D, n_act) of every design's home configuration."""
        home = self.home_coordinates()                     # S + (n,): a population's S ends in the pose axis
        S = self.chain_constants.base.shape
        q = self.inverse(home if S else home[None])        # S + (n_act,) or (1, n_act)
        D = int(np.prod(S)) if S else 1
        return np.broadcast_to(q, tuple(S) + q.shape[-2:]).reshape(D, -1)

    def forward_all(self, Q, **kw):
        raise NotImplementedError("forward_all: a chain mechanism's forward kinematics follows one branch "
                                  "(forward); enumerating every assembly is not implemented")

    # ------------------------------------------------------------------ what the compiled path does not cover
    def enclosure(self):
        raise NotImplementedError("no interval enclosure of chain legs yet")

    def global_statistics(self, requests, X, want_max_cond: bool = False):
        """The chain kernel's statistics (:mod:`.chain_compiled`), or None (the numpy path)."""
        from .chain_compiled import global_statistics

        return global_statistics(self, requests, X, want_max_cond)

    def local_values_at(self, requests, X):
        """The chain kernel's local values (:func:`.chain_compiled.local_values_at`), or None."""
        from .chain_compiled import local_values_at

        return local_values_at(self, requests, X)

    def local_values(self, requests, X):
        """The chain kernel's local values of the designs at shared points X (N, dof), or None."""
        from .chain_compiled import local_values

        return local_values(self, requests, X)

    def kernel_source(self, title: str):
        return None

    def drawing(self, X):
        from .drawing import chain_drawing

        return chain_drawing(self, X)


def chain_attributes(desc, attrs) -> dict:
    """The class attributes a chain description sets beside :func:`.mechanism.make_class`'s:
    the parasitic coordinates' names, the ``constraint`` index and, with a coordinate map, its
    coordinates and units."""
    out = {"parasitic_names": tuple(desc.pose.names[i] for i in desc.pose.parasitic_index),
           "supported_indices": attrs["supported_indices"] + ("constraint",)}
    names = attrs["pose_names"]
    if desc.pose.coords is not None:
        out["pose_names"] = names = desc.pose.coords
        out["pose_units"] = dict(zip(desc.pose.coords, desc.pose.units))
        out["angular_axes"] = tuple(c for c, u in zip(desc.pose.coords, desc.pose.units) if u == "rad")
    out["__doc__"] = (f"Described mechanism {desc.label!r}: {len(desc.chains)} chain legs, {len(desc.legs)} "
                      f"shorthand legs, {desc.pose.type} pose, independent {', '.join(names)}, parasitic "
                      f"{', '.join(out['parasitic_names']) or 'none'}.")
    return out
