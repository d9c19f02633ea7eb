"""Interval enclosures of the hand-written 3-P(4S)'s kinematics over boxes of
poses (optdesign.mechanisms.p4s: ``w_i = p + (rho - r_b) e_i``,
``disc_i = L^2 - |w_i|^2 + (m_i.w_i)^2``, ``J_i = m_i + (w_i - (m_i.w_i) m_i) / sqrt(disc_i)``,
the row n_i / (n_i.m_i) of model.py rewritten with q_i = m_i.w_i - sqrt(disc_i)).

The branch directions e_i are enclosed with both their exact values
(cos 120 deg = -1/2 ...) and the float ones of geometry.E, so the proof holds
for the mechanism as defined and as computed.
"""
from __future__ import annotations

import numpy as np

from ...intervals.interval import Interval, cos_point, hull, point, sin_point

__all__ = ["P4SEnclosure"]


def _branch_dirs():
    g = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
    fl = np.stack([np.cos(g), np.sin(g), np.zeros(3)], -1)
    fl[np.abs(fl) < 1e-15] = 0.0
    h = Interval(3.0).sqrt() * 0.5
    exact_lo = np.array([[1.0, 0.0, 0.0], [-0.5, h.lo, 0.0], [-0.5, -h.hi, 0.0]])
    exact_hi = np.array([[1.0, 0.0, 0.0], [-0.5, h.hi, 0.0], [-0.5, -h.lo, 0.0]])
    return hull(fl, exact_lo, exact_hi)


class P4SEnclosure:
    """Enclosures for one design of the 3-P(4S) (SI parameters r_a, r_b, L, d, phi)."""

    def __init__(self, r_a: float, r_b: float, L: float, d: float, phi: float):
        ra, dd = point(r_a), point(d)
        self.rho = (ra.sqr() - dd.sqr() * 0.25).sqrt()
        self.rb, self.L = point(r_b), point(L)
        E = _branch_dirs()
        c, s = cos_point(phi), sin_point(phi)
        self.e = [[E[i, k] for k in range(3)] for i in range(3)]
        self.m = [[-(c * self.e[i][0]), -(c * self.e[i][1]), s] for i in range(3)]
        self.off = self.rho - self.rb

    def legs(self, lo: np.ndarray, hi: np.ndarray):
        """Per leg (w, b = m.w, disc) over boxes lo, hi (K, 3)."""
        p = [Interval(lo[:, k], hi[:, k]) for k in range(3)]
        out = []
        for i in range(3):
            w = [p[k] + self.off * self.e[i][k] for k in range(3)]
            m = self.m[i]
            b = w[0] * m[0] + w[1] * m[1] + w[2] * m[2]
            disc = self.L.sqr() - (w[0].sqr() + w[1].sqr() + w[2].sqr()) + b.sqr()
            out.append((w, b, disc))
        return out

    def evaluate(self, lo: np.ndarray, hi: np.ndarray) -> dict:
        """``reach_lo`` (K,): a lower bound of min_i disc_i (> 0: every pose
        of the box reachable), ``J``: the interval Jacobian (3 x 3 of (K,)),
        ``q``: the stroke intervals per leg."""
        legs = self.legs(lo, hi)
        J, q = [], []
        reach = None
        for i, (w, b, disc) in enumerate(legs):
            root = disc.sqrt()
            m = self.m[i]
            row = [m[k] + (w[k] - b * m[k]) / root for k in range(3)]
            J.append(row)
            q.append(b - root)
            reach = disc.lo if reach is None else np.minimum(reach, disc.lo)
        return {"reach_lo": reach, "J": J, "q": q}
