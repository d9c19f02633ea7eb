"""Dynamics of a chain mechanism with every link's mass, in the independent
coordinates x (Kane's form of Lagrange's equations).

Velocities.  The unknowns' rates are ``udot = U xdot`` (U = du/dx from the
closures, :mod:`.chain_solve`), so every joint rate, the parasitic rates and
the platform twist ``xi = S (P xdot)`` are linear in xdot.  A link moved by
the variables 1..v of its chain has the spatial twist ``V = sum_(j<=v) T_j
thetadot_j`` (T_j the variables' twists, :mod:`.chain_poe`), its centre
``c`` the velocity ``v + omega x c``, its angular velocity ``omega``.

Accelerations at ``xddot = 0`` (the velocity products).  Differentiating the
closures' velocity form ``Ft thetadot + Fx xi = 0`` once more gives
``Fu uddot + Fx S xddot + h = 0`` with ``h`` the closure's acceleration at
zero second derivatives: for the end point ``pddot = vdot + omegadot x p +
omega x pdot`` of the last link's ``Vdot = sum_j Tdot_j thetadot_j``
(``Tdot_j = [V_(j-1), T_j]``, the Lie bracket, plus ``R (a x (a x Rot side))
thetadot_j`` for a parallelogram), minus the platform point's ``sigma_v +
sigma_omega x r + omega x (omega x r)`` (``sigma = Sdot xdot``, :func:`.poses.rate_bias`);
for a frame closure also ``L (omegadot_end - sigma_omega)``.  So
``uddot_bias = -Fu^+ h`` and every body's bias acceleration follows.

Each link contributes ``m Vc^T Vc + W^T I W`` to M, ``m Vc^T a_c + W^T (I alpha
+ omega x I omega)`` to c and ``m g Vc[z]`` to g; the platform and the
shorthand legs' bodies come from :func:`.dynamics.twist_dynamics` in the
platform twist, mapped with ``Xi = S P``: ``Xi^T M_xi Xi``, ``Xi^T (M_xi
xidot_bias + c_xi)``, ``Xi^T g_xi``.  Then ``tau = J^-T (M xddot + c + g)``
(power: tau.qdot = F.xdot) and ``T = xdot^T M xdot / 2``, ``V = g sum m z``.
"""
from __future__ import annotations

import numpy as np

from .chain_poe import chain_poe, lsq, skew
from .chain_solve import full_rate_map
from .dynamics import potential_energy, twist_dynamics
from .poses import rate_bias

__all__ = ["chain_dynamics", "chain_potential", "ChainDynamics"]


def _bracket(V, T):
    """[V, T] of spatial twists (omega; v) (..., 6)."""
    wv, vv = V[..., :3], V[..., 3:]
    wt, vt = T[..., :3], T[..., 3:]
    return np.concatenate([np.cross(wv, wt), np.cross(wv, vt) - np.cross(wt, vv)], -1)


def _mv(A, x):
    return np.einsum("...ij,...j->...i", A, x)


def _legs(mech, core, V):
    """Per chain leg: the chain (links), joint rates, cumulative twists and
    the twists' derivatives at zero joint accelerations."""
    cc = mech.chain_constants
    spec = mech.pose_spec
    nth = sum(leg.k for leg in cc.legs)
    out, off = [], 0
    for i, leg in enumerate(cc.legs):
        d = leg.as_dict()
        ch = chain_poe(d, core["theta"][i], links=True)
        Ul = core["U"][..., off:off + leg.k, :]
        td = _mv(Ul, V) if V is not None else None
        item = {"d": d, "ch": ch, "U": Ul, "off": off}
        if td is not None:
            tw = ch["tw"]
            Vc = np.zeros(tw.shape[:-2] + (6,))
            tdot = []
            for j in range(leg.k):
                tdot.append(_bracket(Vc, tw[..., j, :]) + np.concatenate(
                    [np.zeros(tw.shape[:-2] + (3,)), ch["dpara"][..., j, :] * td[..., j, None]], -1))
                Vc = Vc + tw[..., j, :] * td[..., j, None]
            item.update(td=td, tdot=np.stack(tdot, -2) if tdot else np.zeros(tw.shape), Vend=Vc)
        out.append(item)
        off += leg.k
    return out, nth, len(spec.parasitic_index)


def _closure_bias(mech, core, legs, fr, xi, sigma):
    """h (..., m): the closures' acceleration at zero second derivatives."""
    L = np.asarray(mech.chain_constants.length, dtype=float)
    w = xi[..., 3:]
    hs = []
    for leg, it in zip(mech.chain_constants.legs, legs):
        ch, td = it["ch"], it["td"]
        bias = np.einsum("...kj,...k->...j", it["tdot"], td)          # Vdot of the last link at theta_ddot = 0
        we, ve = it["Vend"][..., :3], it["Vend"][..., 3:]
        p = ch["end"]
        pd = ve + np.cross(we, p)
        pdd = bias[..., 3:] + np.cross(bias[..., :3], p) + np.cross(we, pd)
        r = _mv(fr.R, leg.P)
        bdd = sigma[..., :3] + np.cross(sigma[..., 3:], r) + np.cross(w, np.cross(w, r))
        h = pdd - bdd
        if leg.closure == "frame":
            h = np.concatenate([h, L[..., None] * (bias[..., :3] - sigma[..., 3:])], -1)
        hs.append(h)
    return np.concatenate(hs, -1)


def unknowns_bias(mech, core, legs, fr, xi, sigma, V):
    """(uddot, xf_ddot) at zero accelerations of the independent coordinates: the
    unknowns' (joint values, parasitic coordinates) and the whole pose's second
    derivatives; with a coordinate map the mapped pose coordinates accelerate by
    ``xb_k = v^T H_k v`` (H_k the Hessian of the map's k-th expression)."""
    spec = mech.pose_spec
    par = list(spec.parasitic_index)
    nth = sum(leg.k for leg in mech.chain_constants.legs)
    ub = -lsq(core["Fu"], _closure_bias(mech, core, legs, fr, xi, sigma))
    xf = np.zeros(ub.shape[:-1] + (spec.dof,))
    xf[..., par] = ub[..., nth:]
    if core.get("H") is not None:
        xb = np.einsum("...kij,...i,...j->...k", core["H"], V, V)
        ub = ub + _mv(core["Ur"], xb)
        xf = xf + _mv(core["Pr"], xb)
    return ub, xf


def chain_dynamics(mech, core, V=None) -> dict:
    """``M`` (..., N, n, n), ``g`` (..., N, n) and, with the rates V (..., N, n),
    ``c`` (..., N, n) and ``qddot_bias`` (the actuators' accelerations at xddot = 0),
    in the independent coordinates."""
    cc = mech.chain_constants
    spec = mech.pose_spec
    C = cc.base
    st = core["st"]
    fr = st["frames"]
    S = full_rate_map(spec, fr)
    Xi = S @ core["P"]
    if V is not None:
        V = np.broadcast_to(np.asarray(V, dtype=float), core["X"].shape[:-1] + (core["P"].shape[-1],))
        V = np.broadcast_to(V, core["P"].shape[:-2] + V.shape[-1:])
        xd_full = _mv(core["P"], V)
        xi = _mv(S, xd_full)
        sigma = rate_bias(spec, fr, xd_full)
    legs, nth, npar = _legs(mech, core, V)
    gval = np.asarray(C.g, dtype=float)[..., None]
    with np.errstate(all="ignore"):
        if V is not None:
            ub, xf_bias = unknowns_bias(mech, core, legs, fr, xi, sigma, V)
            xi_bias = _mv(S, xf_bias) + sigma
        dyn = twist_dynamics(C, st, xi if V is not None else None)
        M = np.einsum("...ki,...kl,...lj->...ij", Xi, dyn["M"], Xi)
        g = np.einsum("...ki,...k->...i", Xi, dyn["g"])
        if V is not None:
            c = np.einsum("...ki,...k->...i", Xi, _mv(dyn["M"], xi_bias) + dyn["c"])
        for leg, it in zip(cc.legs, legs):
            if not leg.bodies:
                continue
            ch = it["ch"]
            tw = ch["tw"]
            cum = np.cumsum(tw[..., :, :, None] * it["U"][..., :, None, :], axis=-3)   # (..., k, 6, n)
            if V is not None:
                tdd = ub[..., it["off"]:it["off"] + leg.k]
                acc = np.cumsum(tw * tdd[..., None] + it["tdot"] * it["td"][..., None], axis=-2)
                vel = np.cumsum(tw * it["td"][..., None], axis=-2)
            for v, m, c_ref, I_ref in leg.bodies:
                R, p = ch["Rs"][v + 1], ch["ps"][v + 1]
                cen = _mv(R, c_ref) + p
                Tw = cum[..., v, :, :]
                Wb = Tw[..., :3, :]
                Vc = Tw[..., 3:, :] - skew(cen) @ Wb
                Iw = R @ I_ref @ np.swapaxes(R, -1, -2)
                mm = np.asarray(m, dtype=float)[..., None, None]
                M = M + mm * np.swapaxes(Vc, -1, -2) @ Vc + np.swapaxes(Wb, -1, -2) @ Iw @ Wb
                g = g + gval * np.asarray(m, dtype=float)[..., None] * Vc[..., 2, :]
                if V is not None:
                    om, vo = vel[..., v, :3], vel[..., v, 3:]
                    al, ao = acc[..., v, :3], acc[..., v, 3:]
                    cd = vo + np.cross(om, cen)
                    ac = ao + np.cross(al, cen) + np.cross(om, cd)
                    c = c + np.asarray(m, dtype=float)[..., None] * np.einsum("...ki,...k->...i", Vc, ac) \
                        + np.einsum("...ki,...k->...i", Wb, _mv(Iw, al) + np.cross(om, _mv(Iw, om)))
    out = {"M": M, "g": g, "Xi": Xi}
    if V is not None:
        out["c"] = c
        out["ub"] = ub
        out["xf_bias"] = xf_bias
    return out


def chain_potential(mech, core) -> np.ndarray:
    """V = g sum m z (..., N) of the platform, the shorthand legs' bodies and
    every chain link (from positions only)."""
    cc = mech.chain_constants
    C = cc.base
    Vp = potential_energy(C, core["st"])
    with np.errstate(all="ignore"):
        for i, leg in enumerate(cc.legs):
            if not leg.bodies:
                continue
            ch = chain_poe(leg.as_dict(), core["theta"][i], links=True)
            for v, m, c_ref, _ in leg.bodies:
                z = (_mv(ch["Rs"][v + 1], c_ref) + ch["ps"][v + 1])[..., 2]
                Vp = Vp + np.asarray(C.g, dtype=float) * np.asarray(m, dtype=float) * z
    return Vp


class ChainDynamics:
    """The dynamics methods of :class:`.chain_mechanism.ChainMechanism` (a mixin):
    M, c, g in the independent coordinates, actuator forces, accelerations, energies."""

    def _dyn(self, X, V=None) -> dict:
        self._require_dynamics()
        core = self.state(X).core
        out = chain_dynamics(self, core, V)
        out["J"] = core["J"]
        out["core"] = core
        return out

    def _actuator_mass(self, st):
        from .mechanism import _solve_T

        d = chain_dynamics(self, st.core)
        return _solve_T(st.J, d["M"])

    def platform_mass_matrix(self, X, convention=None):
        """M (..., N, n, n) in the independent coordinates' rates (T = xdot^T M xdot / 2)."""
        return self._dyn(X)["M"]

    def _forces(self, X, V, A=None, parts=("M", "c", "g")):
        from .dynamics import actuator_forces_of

        return actuator_forces_of(self._dyn(X, V), A, parts, self.dof)

    def gravity_term(self, X):
        X = np.asarray(X, dtype=float)
        return self._forces(X, np.zeros(X.shape), None, ("g",))

    def accelerations(self, X, V, A):
        """qddot (..., N, n_act) at rates V and accelerations A of the independent coordinates."""
        core = self.state(X).core
        V = np.asarray(V, dtype=float)
        A = np.asarray(A, dtype=float)
        return _qddot(self, core, chain_dynamics(self, core, V) if self.description.has_dynamics else None, V, A)

    def energies(self, X, V):
        """Kinetic and potential energy (..., N) at independent coordinates X with rates V."""
        d = self._dyn(X)
        V = np.asarray(V, dtype=float)
        T = 0.5 * np.einsum("...i,...ij,...j->...", V, d["M"], V)
        return T, chain_potential(self, d["core"])


def _qddot(mech, core, dyn, V, A):
    """Actuator accelerations: chain legs from the closures' second derivatives
    (uddot = U a + uddot_bias), shorthand legs from qdot = G xi."""

    spec = mech.pose_spec
    st = core["st"]
    S = full_rate_map(spec, st["frames"])
    xdf = np.einsum("...ij,...j->...i", core["P"], V)
    xi = np.einsum("...ij,...j->...i", S, xdf)
    sigma = rate_bias(spec, st["frames"], xdf)
    if dyn is None:
        legs, _, _ = _legs(mech, core, V)
        with np.errstate(all="ignore"):
            ub, xf = unknowns_bias(mech, core, legs, st["frames"], xi, sigma, V)
    else:
        ub, xf = dyn["ub"], dyn["xf_bias"]
    udd = np.einsum("...ij,...j->...i", core["U"], A) + ub
    xidot = np.einsum("...ij,...j->...i", S, np.einsum("...ij,...j->...i", core["P"], A) + xf) + sigma
    qb = twist_dynamics(mech.constants, st, xi)["qddot_bias"]
    out = []
    offs = np.cumsum([0] + [leg.k for leg in mech.chain_constants.legs])
    for _, src, i in mech.description.actuators:
        if src == "chain":
            out.append(udd[..., offs[i] + mech.chain_constants.legs[i].act])
        else:
            out.append(np.einsum("...k,...k->...", st["G"][..., i, :], xidot) + qb[..., i])
    return np.stack(out, -1)
