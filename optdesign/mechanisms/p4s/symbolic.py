"""The 3-P(4S) for the CasADi route (optdesign.symbolic): closure equations and
body energies written from each body's own velocity, independent of the
hand-derived eq. 8-23 of :mod:`.model` and :mod:`.dynamics`."""
from __future__ import annotations

from .geometry import E, Z

__all__ = ["symbolic_model"]


def symbolic_model():
    """The 3-P(4S) as closure equations and body energies for the CasADi route
    (optdesign.symbolic).  Independent of the hand-derived eq. 8-23 above: the
    energies are written from each body's own velocity (platform, three sliders,
    two rods per branch translating with their centres and rotating with
    omega = n x ndot), and every derivative comes from automatic differentiation.
    """
    import casadi as ca

    from ...symbolic import SymbolicModel

    names = ("r_a", "r_b", "L", "d", "phi", "m_platform", "m_slider", "m_rod", "rod_Ixx", "g", "rods_per_branch")

    def geometry(x, q, p):
        rho = ca.sqrt(p["r_a"] ** 2 - p["d"] ** 2 / 4)
        out = []
        for i in range(3):
            e = ca.DM(E[i])
            m = -ca.cos(p["phi"]) * e + ca.sin(p["phi"]) * ca.DM(Z)
            c = p["r_b"] * e + q[i] * m          # slider (bottom midpoint)
            dpt = x + rho * e                    # top midpoint on the platform
            out.append((c, dpt, m))
        return out

    def closure(x, q, p):
        return ca.vertcat(*[ca.sumsqr(dpt - c) - p["L"] ** 2 for c, dpt, _ in geometry(x, q, p)])

    def kinetic(x, q, xd, qd, p):
        T = 0.5 * p["m_platform"] * ca.sumsqr(xd)
        for i, (c, dpt, m) in enumerate(geometry(x, q, p)):
            cd = qd[i] * m                        # slider velocity
            T += 0.5 * p["m_slider"] * ca.sumsqr(cd)
            vmid = 0.5 * (cd + xd)                # rod centre velocity (both rods)
            n = (dpt - c) / p["L"]
            ndot = (xd - cd) / p["L"]
            omega = ca.cross(n, ndot)
            T += p["rods_per_branch"] * (0.5 * p["m_rod"] * ca.sumsqr(vmid) + 0.5 * p["rod_Ixx"] * ca.sumsqr(omega))
        return T

    def potential(x, q, p):
        V = p["m_platform"] * p["g"] * x[2]
        for i, (c, dpt, m) in enumerate(geometry(x, q, p)):
            V += p["m_slider"] * p["g"] * c[2]
            V += p["rods_per_branch"] * p["m_rod"] * p["g"] * 0.5 * (c[2] + dpt[2])
        return V

    return SymbolicModel(3, 3, names, closure, kinetic, potential)
