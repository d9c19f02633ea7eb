"""A described mechanism on the CasADi route (optdesign.symbolic): the
independent check of :mod:`.legs` and :mod:`.dynamics`.

For one design, the closures and the bodies' energies are written from
positions only -- the platform frame ``o(x) + R(x) P`` (``R`` built from
elementary rotations), each body's centre and orientation as functions of
``(x, q)`` -- and every velocity, Jacobian, mass matrix and velocity term
comes from automatic differentiation (velocities ``d pos / dt`` by ``jtimes``,
angular velocities from ``skew(omega) = Rdot R^T`` for the platform and
``n x ndot`` for rods and struts).  None of the hand-derived maps of
:mod:`.dynamics` (``Vb``, ``G``, the bias accelerations, ``E``, ``sigma``) is
used.
"""
from __future__ import annotations

import numpy as np

__all__ = ["symbolic_model"]


def _rot(ca, axis, a):
    c, s = ca.cos(a), ca.sin(a)
    if axis == "x":
        return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))
    if axis == "y":
        return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def symbolic_model(mech):
    """A :class:`optdesign.symbolic.SymbolicModel` of a single-design described mechanism."""
    import casadi as ca

    from ...symbolic import SymbolicModel

    C = mech.constants
    if C.shape != ():
        raise ValueError("symbolic_model expects a single design")
    spec = mech.pose_spec
    desc = mech.description
    n = len(C.kind)
    DM = lambda v: ca.DM(np.asarray(v, dtype=float))  # noqa: E731
    B = {k: np.asarray(v, dtype=float) for k, v in C.body.items()}

    def frame(x):
        vals = {r: x[i] for i, r in enumerate(spec.roles)}
        for j, a in enumerate(("roll", "pitch", "yaw")):
            vals.setdefault(a, float(C.fixed[j]))
        R = _rot(ca, "z", vals["yaw"]) @ _rot(ca, "y", vals["pitch"]) @ _rot(ca, "x", vals["roll"])
        if spec.type == "rotation":
            o = DM(C.centre)
        else:
            o = ca.vertcat(*[vals.get(c, 0.0) for c in ("x", "y", "z")])
        if spec.type == "translation":
            R = ca.DM.eye(3)
        return o, R

    def points(x, q):
        o, R = frame(x)
        out = []
        for i in range(n):
            b = o + R @ DM(C.P[i])
            A = DM(C.A[i])
            if C.kind[i] == 0:
                a = A + q[i] * DM(C.U[i])
            elif C.kind[i] == 1:
                a = A + float(C.La[i]) * (ca.cos(q[i]) * DM(C.R0[i]) + ca.sin(q[i]) * DM(C.S0[i]))
            else:
                a = A
            out.append((a, b))
        return o, R, out

    def closure(x, q, p):
        _, _, pts = points(x, q)
        f = []
        for i, (a, b) in enumerate(pts):
            d = b - a
            f.append(ca.sumsqr(d) - (q[i] ** 2 if C.kind[i] == 2 else float(C.Lr[i]) ** 2))
        return ca.vertcat(*f)

    def kinetic(x, q, xd, qd, p):
        def dt(e):
            return ca.jtimes(e, x, xd) + ca.jtimes(e, q, qd)

        o, R, pts = points(x, q)
        Rd = ca.horzcat(*[dt(R[:, j]) for j in range(3)])
        W = Rd @ R.T
        w = ca.vertcat(W[2, 1], W[0, 2], W[1, 0])
        c = o + R @ DM(C.com)
        T = 0.5 * float(C.m_platform) * ca.sumsqr(dt(c)) + 0.5 * ca.dot(w, R @ DM(C.I_platform) @ R.T @ w)
        for i, (a, b) in enumerate(pts):
            k = C.kind[i]
            if k in (0, 1):
                if k == 0:
                    T += 0.5 * float(B["slider_mass"][i]) * ca.sumsqr(dt(a))
                else:
                    T += 0.5 * float(B["crank_inertia"][i]) * qd[i] ** 2
                nvec = (b - a) / ca.norm_2(b - a)
                cen = a + float(B["rod_centre"][i]) * (b - a)
                om = ca.cross(nvec, dt(nvec))
                cnt = float(B["rod_count"][i])
                T += cnt * (0.5 * float(B["rod_mass"][i]) * ca.sumsqr(dt(cen))
                            + 0.5 * float(B["rod_inertia"][i]) * ca.sumsqr(om))
            else:
                nvec = (b - a) / ca.norm_2(b - a)
                om = ca.cross(nvec, dt(nvec))
                lo = a + float(B["lower_centre"][i]) * nvec
                up = b - float(B["upper_centre"][i]) * nvec
                T += (0.5 * float(B["lower_mass"][i]) * ca.sumsqr(dt(lo)) + 0.5 * float(B["upper_mass"][i]) * ca.sumsqr(dt(up))
                      + 0.5 * float(B["lower_inertia"][i] + B["upper_inertia"][i]) * ca.sumsqr(om))
        return T

    def potential(x, q, p):
        o, R, pts = points(x, q)
        z = float(C.m_platform) * (o + R @ DM(C.com))[2]
        for i, (a, b) in enumerate(pts):
            k = C.kind[i]
            if k in (0, 1):
                z += float(B["rod_count"][i] * B["rod_mass"][i]) * (a + float(B["rod_centre"][i]) * (b - a))[2]
                if k == 0:
                    z += float(B["slider_mass"][i]) * a[2]
                else:
                    crank = DM(C.A[i]) + float(B["crank_centre"][i]) * (a - DM(C.A[i]))
                    z += float(B["crank_mass"][i]) * crank[2]
            else:
                nvec = (b - a) / ca.norm_2(b - a)
                z += float(B["lower_mass"][i]) * (a + float(B["lower_centre"][i]) * nvec)[2]
                z += float(B["upper_mass"][i]) * (b - float(B["upper_centre"][i]) * nvec)[2]
        return float(C.g) * z

    dyn = desc.has_dynamics
    return SymbolicModel(spec.dof, n, ("unused",), closure, kinetic if dyn else None, potential if dyn else None)
