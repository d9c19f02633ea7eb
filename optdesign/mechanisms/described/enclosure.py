"""Interval enclosures of a described mechanism's kinematics over boxes of
poses (the formulas of :mod:`.legs`, in interval arithmetic; the
certificates of optdesign.certify use them through ``Mechanism.enclosure``).

For one design (its constants evaluated in floats: the proof holds for the
mechanism as computed), over K boxes at once:

* the platform frame: origin and ``R = Rz(yaw) Ry(pitch) Rx(roll)`` with
  interval cos and sin of the angles' ranges;
* per leg, with ``w = b - A``:

  - ``prismatic``: ``w_perp = w - (u.w) u``, ``disc = l^2 - |w_perp|^2``,
    ``d = w_perp -+ sqrt(disc) u``, ``d.t = -+sqrt(disc)`` (``plus`` / ``minus``);
  - ``revolute``: ``P = w.r``, ``Q = w.s``, ``C = (|w|^2 + L_a^2 - l^2) / (2 L_a)``,
    ``h = sqrt(P^2 + Q^2 - C^2)`` and, without any angle,
    ``cos q = (P C -+ Q h) / (P^2 + Q^2)``, ``sin q = (Q C +- P h) / (P^2 + Q^2)``
    (``q = atan2(Q, P) +- atan2(h, C)``), the crank tip ``a`` and
    ``d.t = -+L_a h``;
  - ``strut``: ``d = w``, ``d.t = |w|``;

* the twist rows ``G = (d, r x d) / (d.t)`` and the Jacobian in the
  description's convention (``G`` on the pose's twist components, or ``G S(x)``
  with the Euler-rate columns of S).

The prismatic branches ``outer`` / ``inner`` compare the two roots' distances
from the base origin; the difference has the sign of ``u.b`` where the leg
closes, so a box is proved only where that sign is the same over the whole box
(else its bound is inf and it is split).  A revolute leg's root is settled once
per design at the home pose (``Constants.sign``), the same over every box.  A leg whose actuated point the float model puts outside the
enclosure at the box's midpoint (a branch rule this module does not know)
leaves the box unproved.
"""
from __future__ import annotations

import numpy as np

from ...intervals.dual import cos, mean_value, seed, sin
from ...intervals.interval import Interval

__all__ = ["DescribedEnclosure", "supports"]

_ZERO = Interval(0.0)


def supports(mech) -> str | None:
    """None if the enclosure covers this described mechanism, else why not."""
    C = mech.constants
    if C.shape != ():
        return "one design at a time"
    n, dof = len(C.kind), mech.pose_spec.dof
    if n != dof:
        return f"{n} actuators for {dof} pose coordinates (the Jacobian is not square)"
    if np.any(C.kind > 2):
        return "a leg kind without an enclosure"
    return None


def _dot(a, b):
    out = a[0] * b[0]
    for x, y in zip(a[1:], b[1:]):
        out = out + x * y
    return out


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _sign(x: Interval) -> np.ndarray:
    """+1 where x > 0 over the box, -1 where x < 0, 0 where undecided."""
    return np.where(x.lo > 0, 1, np.where(x.hi < 0, -1, 0))


class DescribedEnclosure:
    """Enclosures for one design of a described mechanism (``mech`` of shape ())."""

    def __init__(self, mech):
        why = supports(mech)
        if why is not None:
            raise ValueError(f"no interval enclosure: {why}")
        self.mech = mech
        self.C = mech.constants
        self.spec = mech.pose_spec

    # ------------------------------------------------------------------ frames
    def _frames(self, lo, hi, dual: bool):
        spec, C = self.spec, self.C
        K = lo.shape[0]
        v = {}
        for i, role in enumerate(spec.roles):
            v[role] = seed(lo[:, i], hi[:, i], i, spec.dof) if dual else Interval(lo[:, i], hi[:, i])
        for j, a in enumerate(("roll", "pitch", "yaw")):
            if a not in v:
                v[a] = Interval(np.full(K, float(C.fixed[j])))
        if spec.type == "translation":
            one, zero = Interval(np.ones(K)), Interval(np.zeros(K))
            R = [[one, zero, zero], [zero, one, zero], [zero, zero, one]]
        elif spec.type == "planar":
            c, s = cos(v["yaw"]), sin(v["yaw"])
            zero, one = Interval(np.zeros(K)), Interval(np.ones(K))
            R = [[c, -s, zero], [s, c, zero], [zero, zero, one]]
        else:
            cr, sr = cos(v["roll"]), sin(v["roll"])
            cp, sp = cos(v["pitch"]), sin(v["pitch"])
            cy, sy = cos(v["yaw"]), sin(v["yaw"])
            R = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sr * sy],
                 [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                 [-sp, cp * sr, cp * cr]]
        if spec.type == "rotation":
            origin = [Interval(np.full(K, float(C.centre[k]))) for k in range(3)]
        else:
            origin = [v[a] if a in v else Interval(np.zeros(K)) for a in ("x", "y", "z")]
        return origin, R, v

    # ------------------------------------------------------------------ legs
    def evaluate(self, lo: np.ndarray, hi: np.ndarray) -> dict:
        """``reach_lo`` (K,): > 0 where every leg closes at every pose of the
        box (a lower bound of each leg's closing margin), ``J``: the interval
        Jacobian (rows of Interval (K,)), the mean-value form intersected with
        the natural extension, ``q``: per leg an enclosure of the actuator
        value (None for revolute legs), ``ok`` (K,): the branch is decided over
        the box and agrees with the float model at its midpoint."""
        lo, hi = np.asarray(lo, float), np.asarray(hi, float)
        mid = 0.5 * lo + 0.5 * hi
        box = self._core(lo, hi, True)
        at_mid = self._core(mid, mid, False)
        J = [[mean_value(e, m, lo, hi) for e, m in zip(row, mrow)] for row, mrow in zip(box["J"], at_mid["J"])]
        q = [None if x is None else mean_value(x, m, lo, hi) for x, m in zip(box["q"], at_mid["q"])]
        ok = box["ok"] & at_mid["ok"]
        return {"reach_lo": np.where(ok, box["reach_lo"], -np.inf), "J": J, "q": q, "ok": ok,
                "J_dual": box["J"], "J_mid": at_mid["J"]}

    def _core(self, lo: np.ndarray, hi: np.ndarray, dual: bool) -> dict:
        C = self.C
        K = lo.shape[0]
        origin, R, ang = self._frames(lo, hi, dual)
        mid_state = self.mech.leg_state(0.5 * lo + 0.5 * hi)
        reach = np.full(K, np.inf)
        ok = np.ones(K, bool)
        rows, qs = [], []
        for i in range(len(C.kind)):
            P = C.P[i]
            r = [R[j][0] * P[0] + R[j][1] * P[1] + R[j][2] * P[2] for j in range(3)]
            b = [origin[j] + r[j] for j in range(3)]
            w = [b[j] - C.A[i][j] for j in range(3)]
            kind, br = int(C.kind[i]), int(C.branch[i])
            if kind == 0:
                u = C.U[i]
                uw = _dot(w, list(u))
                wp = [w[j] - uw * u[j] for j in range(3)]
                disc = float(C.Lr[i]) ** 2 - (wp[0].sqr() + wp[1].sqr() + wp[2].sqr())
                reach = np.minimum(reach, disc.lo)
                root = disc.sqrt()
                if br in (2, 3):
                    s = _sign(_dot(b, list(u)))
                    plus = s > 0 if br == 2 else s < 0
                    ok &= s != 0
                else:
                    plus = np.full(K, br == 1)
                sg = np.where(plus, 1.0, -1.0)
                d = [wp[j] - (root * sg) * u[j] for j in range(3)]
                den = root * (-sg)
                qs.append(uw + root * sg)
                a = [C.A[i][j] + qs[-1] * u[j] for j in range(3)]
            elif kind == 1:
                La, Lr = float(C.La[i]), float(C.Lr[i])
                R0, S0 = list(C.R0[i]), list(C.S0[i])
                Pc, Qc = _dot(w, R0), _dot(w, S0)
                ww = w[0].sqr() + w[1].sqr() + w[2].sqr()
                Cc = (ww + (La * La - Lr * Lr)) / (2.0 * La)
                rho2 = Pc.sqr() + Qc.sqr()
                h2 = rho2 - Cc.sqr()
                reach = np.minimum(reach, h2.lo)
                h = h2.sqrt()
                sgn = float(C.sign[i])          # the root settled for the design at home (Constants.sign)
                if not np.isfinite(sgn):
                    ok &= False
                plus = np.full(K, sgn > 0)
                sg = np.where(plus, 1.0, -1.0)
                cq = (Pc * Cc - Qc * h * sg) / rho2
                sq = (Qc * Cc + Pc * h * sg) / rho2
                ch = [cq * R0[j] + sq * S0[j] for j in range(3)]
                a = [C.A[i][j] + La * ch[j] for j in range(3)]
                d = [w[j] - La * ch[j] for j in range(3)]
                den = h * (-La * sg)
                qs.append(None)
            else:
                ww = w[0].sqr() + w[1].sqr() + w[2].sqr()
                reach = np.minimum(reach, ww.lo)
                q = ww.sqrt()
                d, den = w, q
                qs.append(q)
                a = None
            if a is not None:   # the float model's actuated point at the midpoint lies in the enclosure
                am = mid_state["a"][:, i, :]
                for j in range(3):
                    ok &= a[j].contains(am[:, j]) | ~np.isfinite(am[:, j])
            rc = _cross(r, d)
            G = [x / den for x in d + rc]
            rows.append(G)
        J = [self._columns(G, ang) for G in rows]
        return {"reach_lo": reach, "J": J, "q": qs, "ok": ok}

    def _columns(self, G, ang):
        """One Jacobian row from the twist row G (6 intervals)."""
        spec = self.spec
        conv = spec.jacobian
        if spec.type == "translation":
            return G[:3]
        if spec.type == "planar":
            return [G[0], G[1], G[5]]
        if conv == "angular_velocity":
            return G[3:] if spec.type == "rotation" else G
        cp, sp = cos(ang["pitch"]), sin(ang["pitch"])
        cy, sy = cos(ang["yaw"]), sin(ang["yaw"])
        E = {"roll": [cy * cp, sy * cp, -sp], "pitch": [-sy, cy, None], "yaw": [None, None, 1.0]}
        out = []
        for role in spec.roles:
            if role in ("x", "y", "z"):
                out.append(G[("x", "y", "z").index(role)])
            else:
                col = E[role]
                acc = None
                for k in range(3):
                    if col[k] is None:
                        continue
                    t = G[3 + k] * col[k]
                    acc = t if acc is None else acc + t
                out.append(acc)
        return out
