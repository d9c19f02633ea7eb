"""Checks shared by the chain-mechanism tests (docs/lower-mobility.md): the
dynamics against a second route written from positions only (finite
differences), the energy balance on a trajectory."""
from __future__ import annotations

import numpy as np

from optdesign.mechanisms.described.chain_poe import chain_poe


def trajectory(home, amp, seed=0):
    """t -> (X, V, A): two sines per coordinate around ``home``."""
    rng = np.random.default_rng(seed)
    home, amp = np.asarray(home, float), np.asarray(amp, float)
    f = rng.uniform(0.5, 2.0, (2, len(home)))
    ph = rng.uniform(0, 2 * np.pi, (2, len(home)))

    def traj(t):
        t = np.asarray(t, float)[:, None]
        X, V, A = home + 0 * t, 0 * t, 0 * t
        for j in range(2):
            w = 2 * np.pi * f[j]
            X = X + 0.5 * amp * np.sin(w * t + ph[j])
            V = V + 0.5 * amp * w * np.cos(w * t + ph[j])
            A = A - 0.5 * amp * w * w * np.sin(w * t + ph[j])
        return X, V, A
    return traj


def energy_balance(mech, traj, t, h=1e-4):
    """(max |tau.qdot - dE/dt|, peak |tau.qdot|) along the trajectory (dE/dt by a
    five-point central difference of T + V)."""
    X, V, A = traj(t)
    tau = mech.actuator_forces(X, V, A)
    qd = np.einsum("nij,nj->ni", mech.jacobian(X), V)
    P = np.sum(tau * qd, -1)

    def E(tt):
        Xh, Vh, _ = traj(tt)
        T, U = mech.energies(Xh, Vh)
        return T + U
    dE = (-E(t + 2 * h) + 8 * E(t + h) - 8 * E(t - h) + E(t - 2 * h)) / (12 * h)
    return float(np.max(np.abs(P - dE))), float(np.max(np.abs(P)))


def bodies_at(mech, X):
    """From positions only: per body (mass, centre (N, 3), rotation (N, 3, 3),
    inertia in its own frame at the reference configuration (3, 3)) for every
    chain link and the platform, at independent coordinates X (N, n)."""
    core = mech.state(X).core
    C = mech.constants
    fr = core["st"]["frames"]
    out = [(float(C.m_platform), fr.origin + np.einsum("nij,j->ni", fr.R, C.com), fr.R, np.asarray(C.I_platform))]
    for i, leg in enumerate(mech.chain_constants.legs):
        ch = chain_poe(leg.as_dict(), core["theta"][i], links=True)
        for v, m, c_ref, I_ref in leg.bodies:
            R, p = ch["Rs"][v + 1], ch["ps"][v + 1]
            out.append((float(m), np.einsum("nij,j->ni", R, c_ref) + p, R, np.asarray(I_ref)))
    return out


def kinetic_by_differences(mech, X, V, h=1e-6):
    """T (N,) at X with rates V from the bodies' positions at X -+ h V."""
    plus, minus = bodies_at(mech, X + h * V), bodies_at(mech, X - h * V)
    T = np.zeros(len(X))
    for (m, cp, Rp, I), (_, cm, Rm, _) in zip(plus, minus):
        v = (cp - cm) / (2 * h)
        Rd = (Rp - Rm) / (2 * h)
        R0 = 0.5 * (Rp + Rm)
        W = np.einsum("nij,nkj->nik", Rd, R0)                      # skew(omega) = Rdot R^T
        w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1)
        Iw = np.einsum("nij,jk,nlk->nil", R0, I, R0)
        T += 0.5 * m * np.sum(v * v, -1) + 0.5 * np.einsum("ni,nij,nj->n", w, Iw, w)
    return T


def christoffel_c(mech, X, V, h=1e-5):
    """c(x, v) = sum_ij (dM_kj/dx_i - dM_ij/dx_k / 2) v_i v_j with dM by central differences of M."""
    n = X.shape[-1]
    dM = []
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        dM.append((mech.platform_mass_matrix(X + e) - mech.platform_mass_matrix(X - e)) / (2 * h))
    dM = np.stack(dM, 1)                                             # (N, i, k, j)
    return (np.einsum("nikj,ni,nj->nk", dM, V, V) - 0.5 * np.einsum("nkij,ni,nj->nk", dM, V, V))


def gravity_by_differences(mech, X, h=1e-6):
    n = X.shape[-1]
    out = []
    z = np.zeros_like(X)
    for i in range(n):
        e = np.zeros(n)
        e[i] = h
        out.append((mech.energies(X + e, z)[1] - mech.energies(X - e, z)[1]) / (2 * h))
    return np.stack(out, -1)
