"""Interval enclosures of the hand-written 3-P(4S)'s kinematics over boxes of
poses (optdesign.mechanisms.p4s: ``w_i = p + (rho - r_b) e_i``,
``disc_i = L^2 - |w_i|^2 + (m_i.w_i)^2``, ``J_i = m_i + (w_i - (m_i.w_i) m_i) / sqrt(disc_i)``,
the row n_i / (n_i.m_i) of model.py rewritten with q_i = m_i.w_i - sqrt(disc_i)).

Over a box the entries of J (and the legs' discriminants and strokes) are
enclosed in mean-value form: interval derivatives over the box
(:mod:`optdesign.intervals.dual`, seeded with the box's free coordinates)
around the float-exact interval value at the box's midpoint, intersected with
the natural interval extension.  ``evaluate`` also returns the duals of J over
the box and J at the midpoints, for mean-value forms of functions of J
(determinant, adjugate: :mod:`optdesign.intervals.matrix`).

The branch directions e_i are enclosed with both their exact values
(cos 120 deg = -1/2 ...) and the float ones of geometry.E, so the proof holds
for the mechanism as defined and as computed.
"""
from __future__ import annotations

import numpy as np

from ...intervals.dual import mean_value, seed
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

    def legs(self, lo: np.ndarray, hi: np.ndarray, dual: bool = False):
        """Per leg (w, b = m.w, disc) over boxes lo, hi (K, 3); with ``dual``
        the coordinates that vary in some box are seeded as duals."""
        p = []
        for k in range(3):
            if dual and np.any(hi[:, k] > lo[:, k]):
                p.append(seed(lo[:, k], hi[:, k], k, 3))
            else:
                p.append(Interval(lo[:, k], hi[:, k]))
        out = []
        for i in range(3):
            w = [p[k] + self.off * self.e[i][k] for k in range(3)]
            m = self.m[i]
            b = w[0] * m[0] + w[1] * m[1] + w[2] * m[2]
            disc = self.L.sqr() - (w[0].sqr() + w[1].sqr() + w[2].sqr()) + b.sqr()
            out.append((w, b, disc))
        return out

    def _core(self, lo, hi, dual: bool):
        J, q, disc = [], [], []
        for i, (w, b, dc) in enumerate(self.legs(lo, hi, dual)):
            root = dc.sqrt()
            m = self.m[i]
            J.append([(w[k] - b * m[k]) / root + m[k] for k in range(3)])
            q.append(b - root)
            disc.append(dc)
        return J, q, disc

    def evaluate(self, lo: np.ndarray, hi: np.ndarray) -> dict:
        """``reach_lo`` (K,): a lower bound of min_i disc_i (> 0: every pose
        of the box reachable), ``J``: the interval Jacobian (3 x 3 of (K,)),
        ``q``: the stroke intervals per leg (both in mean-value form),
        ``J_dual``: J's entries as duals over the boxes, ``J_mid``: J at the
        boxes' midpoints (intervals)."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        mid = 0.5 * lo + 0.5 * hi
        Jd, qd, dd = self._core(lo, hi, True)
        Jm, qm, dm = self._core(mid, mid, False)
        J = [[mean_value(e, m, lo, hi) for e, m in zip(row, mrow)] for row, mrow in zip(Jd, Jm)]
        q = [mean_value(e, m, lo, hi) for e, m in zip(qd, qm)]
        reach = None
        for e, m in zip(dd, dm):
            lo_ = mean_value(e, m, lo, hi).lo
            reach = lo_ if reach is None else np.minimum(reach, lo_)
        return {"reach_lo": reach, "J": J, "q": q, "J_dual": Jd, "J_mid": Jm}
