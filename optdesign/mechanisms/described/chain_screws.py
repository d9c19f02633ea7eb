"""Screw theory of chain mechanisms: the legs' twist systems, their constraint
and actuation wrenches, the platform's mobility, the actuation and
constraint Jacobians and the local singularity values (batched over poses
and designs; twists ``(omega; v)`` and wrenches ``(f; m)`` about the base
origin as in :mod:`optdesign.screws`).

* A chain leg's **twist system** at a configuration: its variables' spatial
  twists (:func:`.chain_poe.chain_poe`) and, for a chain ending in S, the
  three rotations about the S centre.  Shorthand legs (U-P-S, P-S-S, R-S-S)
  have six-dimensional twist systems: no constraint.
* Its **constraint wrenches**: the wrenches reciprocal to every twist of the
  leg (``c = 6 - rank`` of them); the pose type adds the constraints it
  declares (``translation``: three couples; ``planar``: a force along z and
  couples about x and y; ``rotation``: three forces through the centre).
* The **mobility** = 6 - rank of all constraint wrenches.
* A leg's **actuation wrench**: reciprocal to its passive twists, not to the
  actuated one, taken orthogonal (in the scaled metric below) to its
  constraint wrenches (Joshi and Tsai 2002).  Power balance gives the
  actuation Jacobian's row ``qdot_i = (W_i o xi) / (W_i o T_i)``.

Ranks and orthogonality use a length scale ``L`` (the chain constants'): a
twist ``(omega; v / L)``, a wrench ``(f; m / L)``.  In the platform-twist
convention of the package, ``xi = (v_o, omega)`` (``v_o`` the velocity of the
platform origin o), a wrench's row is ``(f, m - o x f)``.
"""
from __future__ import annotations

import numpy as np

from .chain_poe import chain_poe
from .chain_solve import full_rate_map
from .poses import frames

__all__ = ["leg_twists", "pose_constraints", "wrench_systems", "jacobians", "constraint_value", "unscaled",
           "ChainScrews", "RANK_TOL"]

#: relative singular-value tolerance of the ranks
RANK_TOL = 1e-9
_DELTA = np.block([[np.zeros((3, 3)), np.eye(3)], [np.eye(3), np.zeros((3, 3))]])


def leg_twists(leg, theta) -> np.ndarray:
    """The twist system (..., k (+3), 6) of one chain leg at joint values theta."""
    ch = chain_poe(leg, theta)
    T = ch["tw"]
    if leg["closure"] == "position":
        e = ch["end"]
        S = np.stack([np.concatenate([np.broadcast_to(a, e.shape), np.cross(e, np.broadcast_to(a, e.shape))], -1)
                      for a in np.eye(3)], -2)
        T = np.concatenate([T, S], -2)
    return T


def pose_constraints(spec, shape) -> np.ndarray:
    """The wrenches (..., c, 6) the pose type declares, moments about the
    platform origin (see the module docstring)."""
    e = np.eye(3)
    z = np.zeros(3)
    rows = {"translation": [np.concatenate([z, a]) for a in e],
            "planar": [np.concatenate([z, e[0]]), np.concatenate([z, e[1]]), np.concatenate([e[2], z])],
            "rotation": [np.concatenate([a, z]) for a in e]}.get(spec.type, [])
    if not rows:
        return np.zeros(shape + (0, 6))
    return np.broadcast_to(np.stack(rows), shape + (len(rows), 6))


def _scaled(A, L):
    """(omega; v / L) or (f; m / L)."""
    return np.concatenate([A[..., :3], A[..., 3:] / L[..., None, None]], -1)


def _at(T, origin):
    """Twists (omega; v) about the base origin -> about the point ``origin`` (..., 3)."""
    return np.concatenate([T[..., :3], T[..., 3:] + np.cross(T[..., :3], origin[..., None, :])], -1)


def _null(A, count: int) -> np.ndarray:
    """The ``count`` right singular vectors of A (..., m, 6) of smallest singular value (..., count, 6)."""
    if count <= 0:
        return np.zeros(A.shape[:-2] + (0, 6))
    good = np.all(np.isfinite(A), axis=(-1, -2))
    A = np.where(good[..., None, None], A, 0.0)
    if A.shape[-2] < 6:
        A = np.concatenate([A, np.zeros(A.shape[:-2] + (6 - A.shape[-2], 6))], -2)
    _, _, vt = np.linalg.svd(A)
    return np.where(good[..., None, None], vt[..., 6 - count:, :], np.nan)


def _rank(A) -> np.ndarray:
    good = np.all(np.isfinite(A), axis=(-1, -2))
    A = np.where(good[..., None, None], A, 0.0)
    if A.shape[-2] == 0:
        return np.zeros(A.shape[:-2], dtype=int)
    s = np.linalg.svd(A, compute_uv=False)
    return np.where(good, np.sum(s > RANK_TOL * np.maximum(1.0, s[..., :1]), axis=-1), -1)


def wrench_systems(mech, Xf, thetas, counts=None, actuation: bool = True) -> dict:
    """At whole poses Xf (..., dof) with the chains' joint values ``thetas``
    (list of (..., k)): per chain leg its scaled twist system ``T`` and
    constraint wrenches ``Wc`` ((..., c_i, 6), scaled, c_i from ``counts`` or
    the rank here), the pose type's ``Wp``, the actuation wrench ``Wa`` of
    each actuated chain leg (scaled, unit) and ``power`` = W_a o T_a (SI);
    ``L`` the length scale and ``origin`` the platform origin (``actuation``
    false: no ``Wa`` and ``power``)."""
    cc = mech.chain_constants
    spec = mech.pose_spec
    L = np.asarray(cc.length, dtype=float)
    C = cc.base
    fr = frames(spec, Xf, C.centre, C.fixed)
    out = {"T": [], "Wc": [], "Wa": {}, "power": {}, "counts": [], "L": L, "origin": fr.origin, "frames": fr}
    for i, leg in enumerate(cc.legs):
        d = leg.as_dict()
        T = _scaled(_at(leg_twists(d, thetas[i]), fr.origin), L)
        c = int(counts[i]) if counts is not None else int(np.max(6 - _rank(T)))
        Wc = _null(T @ _DELTA, c)
        out["T"].append(T)
        out["Wc"].append(Wc)
        out["counts"].append(c)
        if actuation and leg.act is not None:
            Tp = np.delete(T, leg.act, axis=-2)
            Np = _null(Tp @ _DELTA, c + 1)
            beta = np.einsum("...ij,...j->...i", Np @ _DELTA, T[..., leg.act, :])
            w = np.einsum("...i,...ij->...j", beta, Np)
            w = w / np.linalg.norm(w, axis=-1, keepdims=True)
            Ta = T[..., leg.act, :]
            out["Wa"][i] = w
            # W o T in SI: (f; L m') o (omega; L v') = L (f . v' + m' . omega)
            out["power"][i] = L * (np.sum(w[..., :3] * Ta[..., 3:], -1) + np.sum(w[..., 3:] * Ta[..., :3], -1))
    Wp = _scaled(pose_constraints(spec, fr.origin.shape[:-1]), L)
    out["Wp"] = Wp / np.linalg.norm(Wp, axis=-1, keepdims=True) if Wp.shape[-2] else Wp
    return out


def unscaled(W: np.ndarray, L) -> np.ndarray:
    """Rows (f, m_o) in SI of scaled wrenches (f; m_o / L)."""
    return np.concatenate([W[..., :3], W[..., 3:] * np.asarray(L, dtype=float)[..., None, None]], -1)


def jacobians(mech, core) -> dict:
    """The actuation Jacobian ``Ja`` (..., n_act, 6) (qdot = Ja xi, xi = (v_o,
    omega)), the constraint Jacobian ``Jc`` (..., n_c, 6) (Jc xi = 0 for every
    admissible twist; unit rows in the scaled metric, moments about o), the
    twist map ``Xi`` (..., 6, n_ind) (xi = Xi xdot) and the singularity values
    ``constraint`` (sigma_r of the stacked unit constraint wrenches (f, m_o / L),
    r = 6 - n_ind; 0 at a constraint singularity, dimensionless) and
    ``actuation`` (sigma_6 of the actuation and constraint wrenches together,
    each a unit row; 0 at an actuation or constraint singularity)."""
    spec = mech.pose_spec
    desc = mech.description
    Xf = core["Xf"]
    ws = wrench_systems(mech, Xf, core["theta"], counts=mech.constraint_counts())
    L, fr = np.asarray(ws["L"], dtype=float), ws["frames"]
    Jcs = _stacked(ws, Xf.shape[:-1])
    Jc = unscaled(Jcs, L)
    rows, unit = [], []
    st = core["st"]
    for _, src, i in desc.actuators:
        if src == "chain":
            w = ws["Wa"][i]
            rows.append(unscaled(w[..., None, :], L)[..., 0, :] / ws["power"][i][..., None])
            unit.append(w)
        else:
            G = st["G"][..., i, :]
            rows.append(G)
            u = np.concatenate([G[..., :3], G[..., 3:] / L[..., None]], -1)
            unit.append(u / np.linalg.norm(u, axis=-1, keepdims=True))
    Ja = np.stack(rows, -2)
    Xi = full_rate_map(spec, fr) @ core["P"]
    with np.errstate(all="ignore"):
        cval = _sigma_r(Jcs, 6 - len(spec.independent_index), Xf.shape[:-1])
        A = np.concatenate([np.stack(unit, -2), Jcs], -2)
        sa = np.linalg.svd(np.where(np.isfinite(A), A, 0.0), compute_uv=False)
        aval = sa[..., 5] if sa.shape[-1] >= 6 else np.zeros(Xf.shape[:-1])
    bad = ~core["reachable"]
    nan = lambda a: np.where(bad.reshape(bad.shape + (1,) * (a.ndim - bad.ndim)), np.nan, a)  # noqa: E731
    return {"Ja": nan(Ja), "Jc": nan(Jc), "Xi": nan(Xi), "constraint": nan(cval), "actuation": nan(aval)}


def _stacked(ws, shape) -> np.ndarray:
    """The legs' and the pose type's scaled unit constraint wrenches stacked (..., n_c, 6)."""
    return np.concatenate([np.broadcast_to(w, shape + w.shape[-2:]) for w in ws["Wc"] + [ws["Wp"]]], -2)


def _sigma_r(Jcs, r: int, shape) -> np.ndarray:
    """sigma_r of the stacked wrenches (1 where r = 0: no constraint to lose)."""
    if not Jcs.shape[-2] or r <= 0:
        return np.ones(shape)
    return np.linalg.svd(np.where(np.isfinite(Jcs), Jcs, 0.0), compute_uv=False)[..., r - 1]


def constraint_value(mech, core) -> np.ndarray:
    """The constraint-singularity value (...) of :func:`jacobians` alone (no
    actuation wrenches): what the ``constraint`` index reads; NaN where not reachable."""
    Xf = core["Xf"]
    ws = wrench_systems(mech, Xf, core["theta"], counts=mech.constraint_counts(), actuation=False)
    with np.errstate(all="ignore"):
        c = _sigma_r(_stacked(ws, Xf.shape[:-1]), 6 - len(mech.pose_spec.independent_index), Xf.shape[:-1])
    return np.where(core["reachable"], c, np.nan)


class ChainScrews:
    """The screw-theory methods of :class:`.chain_mechanism.ChainMechanism`:
    the mobility at home, the constraint counts, the actuation and constraint
    Jacobians and the singularity values at poses."""

    def mobility(self) -> dict:
        """The platform's mobility at the home configuration of every design:
        ``mobility`` (S) = 6 - ``rank`` (S) of all constraint wrenches (the
        legs' and the pose type's), ``leg_ranks`` (S + (m,)) the rank of each
        chain leg's twist system, ``counts`` its constraint wrenches (the mode
        over the designs), ``without`` (S + (m,)) the mobility without each leg's
        wrenches (which leg to look at), ``pose_constraints`` the pose type's count."""
        core = self.home_state()
        ws = wrench_systems(self, core["Xf"], core["theta"])
        ranks = np.stack([_rank(T) for T in ws["T"]], -1) if ws["T"] else np.zeros(core["Xf"].shape[:-2] + (0,))
        parts = [w for w in ws["Wc"]]
        allw = np.concatenate(parts + [np.broadcast_to(ws["Wp"], ws["Wp"].shape)], -2) if parts or ws["Wp"].size \
            else np.zeros(ranks.shape[:-1] + (0, 6))
        rank = _rank(allw) if allw.shape[-2] else np.zeros(ranks.shape[:-1], dtype=int)
        without = []
        for i in range(len(parts)):
            rest = parts[:i] + parts[i + 1:] + [ws["Wp"]]
            W = np.concatenate(rest, -2)
            without.append(6 - (_rank(W) if W.shape[-2] else 0))
        return {"mobility": 6 - rank, "rank": rank, "leg_ranks": ranks, "counts": tuple(ws["counts"]),
                "without": np.stack(without, -1) if without else ranks, "pose_constraints": ws["Wp"].shape[-2]}

    def constraint_counts(self) -> tuple:
        """Each chain leg's number of constraint wrenches at home (the most
        frequent over the designs), used at every pose."""
        c = self.__dict__.get("_counts")
        if c is None:
            r = np.asarray(self.mobility()["leg_ranks"]).reshape(-1, len(self.chain_constants.legs))
            c = []
            for i in range(r.shape[1]):
                vals, n = np.unique(6 - r[:, i][r[:, i] >= 0], return_counts=True)
                c.append(int(vals[np.argmax(n)]) if len(vals) else 0)
            c = tuple(c)
            self.__dict__["_counts"] = c
        return c

    def screw_jacobians(self, X) -> dict:
        """The actuation Jacobian ``Ja`` (qdot = Ja xi), the constraint Jacobian
        ``Jc`` (Jc xi = 0), ``Xi`` (xi = Xi xdot) and the singularity values
        ``constraint`` and ``actuation`` at independent coordinates X
        (:func:`.chain_screws.jacobians`, docs/lower-mobility.md)."""
        return jacobians(self, self.state(X).core)

    def actuation_jacobian(self, X):
        """Ja (..., N, n_act, 6): qdot = Ja xi for the platform twist xi = (v_o, omega)."""
        return self.screw_jacobians(X)["Ja"]

    def constraint_jacobian(self, X):
        """Jc (..., N, n_c, 6): Jc xi = 0 for every twist the legs allow."""
        return self.screw_jacobians(X)["Jc"]

    def constraint_singularity(self, X):
        """The local constraint-singularity value (..., N): sigma_(6 - n_ind) of the
        stacked unit constraint wrenches (f, m_o / L), dimensionless, 0 where
        the constraints lose rank (the platform gains a motion)."""
        return self.screw_jacobians(X)["constraint"]
