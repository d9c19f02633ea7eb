"""The 2-CPR/RRR planar translational mechanism (seed paper 002, Chen et al. 2019).

The extracted text of the paper keeps its joint screws (eq. 1-3), the
linear-input equations (eq. 19-24) and the determinant (eq. 25) but loses the
position equations (eq. 4-14); the model below is rebuilt from eq. 1 and the
geometry of section 1, and checked against the paper's Jacobian and Hessian
forms, finite differences, automatic differentiation and screw theory.

Geometry (base frame O-XYZ of section 1):

* chain L1: the cylindrical joint C1 lies on the X axis (slide ``m1`` along X,
  rotation ``theta1`` about X); the prismatic joint P1 runs along
  ``u1 = (0, cos theta1, sin theta1)`` (S13 of eq. 1); the revolute R1 on the
  platform is parallel to X at distance ``d1`` from the X axis along u1 (S14);
* chain L2: the same about the Y axis: slide ``m2`` along Y, P2 along
  ``u2 = (cos theta2, 0, sin theta2)`` (theta2 measured from +X towards +Z, a
  rotation about -Y), R2 parallel to Y;
* chain L3 (the "pure constraint" chain): three revolutes parallel to Z, the
  first at ``(rrr_base_x, rrr_base_y)`` on the base, links ``l1`` and ``l2``,
  the last at the platform point ``p + (rrr_attach_x, rrr_attach_y)``.

The platform translates in the plane at height ``n`` (L3 fixes z and the three
chains fix every rotation, eq. 2-3).  With the platform reference point
``p = (x, y)``:

* ``n`` -- height of the R1 and R2 axes above the plane of the C axes (the
  constant ``d_i sin theta_i``);
* ``w`` -- offset along Y from the R1 axis to the platform point
  (R1 axis at ``y - w``);
* ``f`` -- offset along X from the R2 axis to the platform point
  (R2 axis at ``x - f``);
* ``d_i`` -- the stroke of P_i, the distance from the C_i axis to the R_i axis,
  ``d_i = n / sin theta_i``.  The paper lists d_i among the structure parameters
  and writes theta_i = arcsin(d_i / n); since d_i >= n only arcsin(n / d_i) is
  possible, and d_i varies with the pose.

Position equations (the lost eq. 12-14, in the paper's notation):
``x = n cot theta2 + f``, ``y = n cot theta1 + w`` (rotary inputs) and
``x = m1``, ``y = m2`` (linear inputs, eq. 21-22).  Their derivatives are the
paper's diagonal Jacobian (eq. 16) ``diag(-n csc^2 theta2, -n csc^2 theta1)``
-- the printed eq. 16 and 25 also carry ``- f`` and ``- w`` in the diagonal,
which no position equation of this form produces (the derivative of a constant
offset is zero; see docs/reproduction.md) -- and the Hessian (eq. 18)
``diag(2 n csc^2 theta2 cot theta2, 2 n csc^2 theta1 cot theta1)`` with
``a = H thetadot^2 + J thetaddot`` (eq. 17; the extraction prints thetaddot^2).

Input type: the fixed parameter ``input_type`` is 0 for rotary inputs (the C
joints' angles; actuators ``(theta2, theta1)`` in the paper's order of eq. 15,
so that J is diagonal with the actuator driving x first) and 1 for linear
inputs (the C joints' slides; actuators ``(m1, m2)``, J = I).

``jacobian`` follows the package convention ``qdot = J xdot`` (the inverse of
the paper's V = J thetadot): rotary ``diag(-sin^2 theta2 / n, -sin^2 theta1 / n)``.
Everything is batched over poses and (broadcast) designs.
"""
from __future__ import annotations

import numpy as np

from . import register
from .base import Mechanism
from .params import Param

ROTARY, LINEAR = 0, 1


def _p(a, k: int) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return a.reshape(a.shape + (1,) * k)


@register
class CPR_RRR(Mechanism):
    """2-CPR/RRR planar translational parallel mechanism (two translations).

    Design parameters (SI): ``n`` height of the R1/R2 axes above the C axes,
    ``f`` and ``w`` offsets from the R2 and R1 axes to the platform point,
    ``l1``, ``l2`` the link lengths of the RRR chain.  Fixed parameters:
    ``input_type`` (0 rotary, 1 linear), the RRR base and platform attachment
    points, ``elbow`` (+1 or -1: the RRR assembly mode), ``k`` actuator
    stiffness for the stiffness index.

    >>> mech = CPR_RRR(n=0.1, f=0.02, w=0.02)
    >>> mech.inverse(np.array([[0.02, 0.12]])).round(4)
    array([[1.5708, 0.7854]])
    """

    name = "cpr_rrr"
    pose_names = ("x", "y")
    actuator_names = ("q1", "q2")  # per instance: ("theta2", "theta1") or ("m1", "m2")
    parameters = (
        Param("n", "length", design=True, low=0.0, low_open=True, doc="height of the R1/R2 axes above the C axes"),
        Param("f", "length", 0.02, design=True, doc="offset from the R2 axis to the platform point"),
        Param("w", "length", 0.02, design=True, doc="offset from the R1 axis to the platform point"),
        Param("l1", "length", 0.2, design=True, low=0.0, low_open=True, doc="first link of the RRR chain"),
        Param("l2", "length", 0.2, design=True, low=0.0, low_open=True, doc="second link of the RRR chain"),
        Param("input_type", "switch", "rotary", choices={"rotary": ROTARY, "linear": LINEAR},
              doc="rotary inputs (the C angles theta2, theta1) or linear inputs (the C slides m1, m2)"),
        Param("rrr_base_x", "length", -0.2, doc="RRR base joint, x"),
        Param("rrr_base_y", "length", -0.2, doc="RRR base joint, y"),
        Param("rrr_attach_x", "length", 0.0, doc="RRR platform attachment, x (platform frame)"),
        Param("rrr_attach_y", "length", 0.0, doc="RRR platform attachment, y (platform frame)"),
        Param("elbow", "switch", "plus", choices={"plus": 1.0, "minus": -1.0},
              doc="RRR assembly mode: the sign of the elbow angle"),
        Param("k", "stiffness", 1.0, low=0.0, low_open=True, doc="actuator stiffness of the stiffness index"),
    )
    supported_indices = ("isotropy", "dexterity", "manipulability", "driving", "stiffness")

    example = {  # configs/cpr_rrr_opt.yaml: rotary inputs, a 200 mm x 200 mm bed
        "parameters": {"k": 1.0},
        "design_variables": {"n": {"value": 0.1, "bounds": [0.03, 0.3]}, "f": {"value": 0.02, "bounds": [-0.05, 0.25]},
                             "w": {"value": 0.02, "bounds": [-0.05, 0.25]}, "l1": {"value": 0.3}, "l2": {"value": 0.3}},
        "workspace": {"type": "box", "axes": {"x": [0.0, 0.2], "y": [0.0, 0.2]}, "sampling": "grid", "step": 0.02},
        "indices": {"dexterity": {"kind": "dexterity", "convention": "normalized"},
                    "stiffness": {"kind": "stiffness", "convention": "lambda_min_K"}},
    }

    @classmethod
    def actuator_unit(cls, params):
        return "m" if float(params.get("input_type", ROTARY)) == LINEAR else "rad"

    def __init__(self, **params):
        super().__init__(**params)
        it = np.unique(np.asarray(self.input_type, dtype=float))
        if it.size != 1 or it[0] not in (ROTARY, LINEAR):
            raise ValueError(f"cpr_rrr: input_type must be 0 (rotary inputs) or 1 (linear inputs), got {self.input_type}")
        el = np.unique(np.asarray(self.elbow, dtype=float))
        if not np.all(np.isin(el, (-1.0, 1.0))):
            raise ValueError(f"cpr_rrr: elbow must be +1 or -1, got {self.elbow}")
        self.kind = int(it[0])
        self.actuator_names = ("theta2", "theta1") if self.kind == ROTARY else ("m1", "m2")

    # ------------------------------------------------------------------ geometry
    def chain_state(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """Every joint variable at poses X (..., N, 2), (design..., N) arrays:
        ``theta1, theta2`` (C rotations), ``m1, m2`` (C slides), ``d1, d2`` (P
        strokes), ``phi1, phi2, phi3`` (RRR joint angles, absolute, from X),
        points ``B, E, C`` of the RRR axes (..., 2), and ``reachable``."""
        X = np.asarray(X, dtype=float)
        x, y = X[..., 0], X[..., 1]
        n = np.asarray(self.n, dtype=float)
        u2 = x - self.f                      # R2 axis abscissa
        u1 = y - self.w                      # R1 axis ordinate
        theta2 = np.arctan2(n, u2)
        theta1 = np.arctan2(n, u1)
        d2 = np.hypot(n, u2)
        d1 = np.hypot(n, u1)
        bx = np.asarray(self.rrr_base_x, dtype=float)
        rx = x + self.rrr_attach_x - bx
        ry = y + self.rrr_attach_y - self.rrr_base_y
        rho = np.hypot(rx, ry)
        l1, l2 = np.asarray(self.l1, float), np.asarray(self.l2, float)
        c = (rho ** 2 - l1 ** 2 - l2 ** 2) / (2 * l1 * l2)
        ok = (c >= -1.0 - 1e-12) & (c <= 1.0 + 1e-12)
        beta = self.elbow * np.arccos(np.clip(c, -1.0, 1.0))                # elbow angle
        phi1 = np.arctan2(ry, rx) - np.arctan2(l2 * np.sin(beta), l1 + l2 * np.cos(beta))
        phi2 = phi1 + beta
        Bp = np.stack(np.broadcast_arrays(bx + 0 * rx, self.rrr_base_y + 0 * ry), axis=-1)
        E = Bp + np.stack([l1 * np.cos(phi1), l1 * np.sin(phi1)], axis=-1)
        C = np.stack([x + self.rrr_attach_x + 0 * rx, y + self.rrr_attach_y + 0 * ry], axis=-1)
        shape = np.broadcast_shapes(theta1.shape, theta2.shape, ok.shape, self.design_shape)
        nan = np.broadcast_to(np.where(ok, 0.0, np.nan), shape)
        full = lambda a: np.broadcast_to(a, shape) + nan          # noqa: E731
        pts = lambda P: np.broadcast_to(P, shape + (2,)) + nan[..., None]  # noqa: E731
        return {"theta1": full(theta1), "theta2": full(theta2), "m1": full(x), "m2": full(y),
                "d1": full(d1), "d2": full(d2), "phi1": full(phi1), "phi2": full(phi2),
                "phi3": np.zeros(shape) + nan, "B": pts(Bp), "E": pts(E), "C": pts(C),
                "reachable": np.broadcast_to(ok, shape), "n": n}

    # ------------------------------------------------------------------ kinematics
    def inverse(self, X: np.ndarray) -> np.ndarray:
        """Actuator values (design..., N, 2): ``(theta2, theta1)`` in rad (rotary)
        or ``(m1, m2)`` in m (linear); NaN where the RRR chain cannot reach."""
        st = self.chain_state(X)
        if self.kind == ROTARY:
            return np.stack([st["theta2"], st["theta1"]], axis=-1)
        return np.stack([st["m1"], st["m2"]], axis=-1)

    def reachable(self, X: np.ndarray) -> np.ndarray:
        """Mask (design..., N): the RRR chain reaches the platform point,
        ``|l1 - l2| <= |C - B| <= l1 + l2`` (the CPR chains reach every point)."""
        return self.chain_state(X)["reachable"]

    def forward(self, Q: np.ndarray) -> np.ndarray:
        """Platform position (design..., N, 2) for actuator values Q (..., N, 2):
        ``x = n cot theta2 + f``, ``y = n cot theta1 + w`` or ``x = m1``, ``y = m2``
        (eq. 21-22).  NaN where theta is outside (0, pi) or the RRR chain cannot
        reach the result."""
        Q = np.asarray(Q, dtype=float)
        if self.kind == ROTARY:
            t2, t1 = Q[..., 0], Q[..., 1]
            bad = (t1 <= 0) | (t1 >= np.pi) | (t2 <= 0) | (t2 >= np.pi)
            with np.errstate(divide="ignore", invalid="ignore"):
                x = self.n * np.cos(t2) / np.sin(t2) + self.f
                y = self.n * np.cos(t1) / np.sin(t1) + self.w
            x, y = np.where(bad, np.nan, x), np.where(bad, np.nan, y)
        else:
            x, y = Q[..., 0], Q[..., 1]
        X = np.stack(np.broadcast_arrays(x, y), axis=-1)
        ok = self.reachable(X)
        return np.where(ok[..., None], X, np.nan)

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """J (design..., N, 2, 2) with qdot = J xdot: ``diag(-sin^2 theta2 / n,
        -sin^2 theta1 / n)`` for rotary inputs (the inverse of eq. 16), the
        identity for linear inputs (eq. 23); NaN where unreachable."""
        st = self.chain_state(X)
        nan = np.where(st["reachable"], 0.0, np.nan)
        if self.kind == ROTARY:
            n = np.asarray(self.n, float)
            a = -np.sin(st["theta2"]) ** 2 / n
            b = -np.sin(st["theta1"]) ** 2 / n
        else:
            a = b = 1.0 + nan
        a, b = np.broadcast_arrays(a, b)
        z = np.zeros_like(a)
        return np.stack([np.stack([a, z], -1), np.stack([z, b], -1)], -2)

    def accelerations(self, X, V, A) -> np.ndarray:
        """Actuator accelerations qdd = J a + c(x, v) (design..., N, 2): for rotary
        inputs, with u = x - f, ``thetaddot2 = -n a_x / (n^2 + u^2) + 2 n u v_x^2 /
        (n^2 + u^2)^2`` (and the same for theta1 with y - w); linear: qdd = a."""
        X, V, A = (np.asarray(a, dtype=float) for a in (X, V, A))
        st = self.chain_state(X)
        if self.kind == LINEAR:
            return A + np.where(st["reachable"], 0.0, np.nan)[..., None]
        n = np.asarray(self.n, float)
        out = []
        for u, v, a in ((X[..., 0] - self.f, V[..., 0], A[..., 0]), (X[..., 1] - self.w, V[..., 1], A[..., 1])):
            s = n * n + u * u
            out.append(-n * a / s + 2 * n * u * v * v / s ** 2)
        return np.stack(np.broadcast_arrays(*out), axis=-1) + np.where(st["reachable"], 0.0, np.nan)[..., None]

    # ------------------------------------------------------------------ the paper's forward maps
    def forward_jacobian(self, Q: np.ndarray) -> np.ndarray:
        """The paper's J of V = J qdot (eq. 15-16, 23): ``diag(-n csc^2 theta2,
        -n csc^2 theta1)`` (rotary) or I (linear), (design..., N, 2, 2)."""
        Q = np.asarray(Q, dtype=float)
        if self.kind == ROTARY:
            a = -self.n / np.sin(Q[..., 0]) ** 2
            b = -self.n / np.sin(Q[..., 1]) ** 2
        else:
            a = b = np.ones(Q.shape[:-1])
        a, b = np.broadcast_arrays(a, b)
        z = np.zeros_like(a)
        return np.stack([np.stack([a, z], -1), np.stack([z, b], -1)], -2)

    def hessian(self, Q: np.ndarray) -> np.ndarray:
        """The paper's H of eq. 18 (diagonal, stored as (design..., N, 2)):
        ``2 n csc^2 theta cot theta`` per input (rotary), zero (linear)."""
        Q = np.asarray(Q, dtype=float)
        if self.kind == LINEAR:
            return np.zeros(np.broadcast_shapes(np.shape(self.n), Q.shape))
        return 2 * _p(self.n, 1) * np.cos(Q) / np.sin(Q) ** 3

    def forward_velocity(self, Q, Qd) -> np.ndarray:
        """Platform velocity V = J qdot (eq. 15, 23), (design..., N, 2)."""
        return np.einsum("...ij,...j->...i", self.forward_jacobian(Q), np.asarray(Qd, float))

    def forward_acceleration(self, Q, Qd, Qdd) -> np.ndarray:
        """Platform acceleration a = H qdot^2 + J qddot (eq. 17, 24), (design..., N, 2)."""
        Qd = np.asarray(Qd, float)
        return self.hessian(Q) * Qd ** 2 + self.forward_velocity(Q, Qdd)

    # ------------------------------------------------------------------ screws
    def joint_twists(self, X: np.ndarray) -> list[np.ndarray]:
        """Unit joint twists ``(omega; v)`` of the three chains at poses X, from
        base to platform: L1 and L2 ``(..., N, 4, 6)`` as eq. 1 (C slide, C
        rotation, P, R), L3 ``(..., N, 3, 6)``.  The C2 rotation twist is about
        -Y, so that its rate is thetadot2."""
        from .. import screws as sc

        st = self.chain_state(X)
        t1, t2 = st["theta1"], st["theta2"]
        n = np.broadcast_to(np.asarray(self.n, float), t1.shape)
        zero, one = np.zeros_like(t1), np.ones_like(t1)
        ex = np.stack([one, zero, zero], -1)
        ey = np.stack([zero, one, zero], -1)
        ez = np.stack([zero, zero, one], -1)
        O = np.zeros(t1.shape + (3,))
        u1 = np.stack([zero, np.cos(t1), np.sin(t1)], -1)
        u2 = np.stack([np.cos(t2), zero, np.sin(t2)], -1)
        R1 = st["d1"][..., None] * u1                    # a point of the R1 axis
        R2 = st["d2"][..., None] * u2
        L1 = np.stack([sc.prismatic(ex), sc.revolute(ex, O), sc.prismatic(u1), sc.revolute(ex, R1)], -2)
        L2 = np.stack([sc.prismatic(ey), sc.revolute(-ey, O), sc.prismatic(u2), sc.revolute(ey, R2)], -2)

        def pt(P2):
            P2 = np.broadcast_to(P2, t1.shape + (2,))
            return np.concatenate([P2, n[..., None] * 0], -1)
        L3 = np.stack([sc.revolute(ez, pt(st["B"])), sc.revolute(ez, pt(st["E"])), sc.revolute(ez, pt(st["C"]))], -2)
        return [L1, L2, L3]

    def actuated_joints(self) -> tuple[int, int]:
        """Index of the actuated joint in L1 and L2 of :meth:`joint_twists`
        (1: the C rotation; 0: the C slide); actuator order is (L2, L1) for
        rotary inputs and (L1, L2) for linear ones."""
        return (1, 1) if self.kind == ROTARY else (0, 0)


# ---------------------------------------------------------------------- CasADi model
def symbolic_model(input_type: int = ROTARY):
    """The closure equations for the CasADi route (optdesign.symbolic): the loop
    equation of each CPR chain, ``R_i = m_i s_i1 + d_i u_i`` (eq. 7, the R_i
    axis point reached through the chain), with the P stroke d_i eliminated by a
    cross product.  Rotary: ``(x - f) sin theta2 - n cos theta2 = 0``,
    ``(y - w) sin theta1 - n cos theta1 = 0`` with q = (theta2, theta1);
    linear: ``x - m1 = 0``, ``y - m2 = 0`` with q = (m1, m2)."""
    import casadi as ca

    from ..symbolic import SymbolicModel

    def closure(x, q, p):
        if input_type == ROTARY:
            t2, t1 = q[0], q[1]
            return ca.vertcat((x[0] - p["f"]) * ca.sin(t2) - p["n"] * ca.cos(t2),
                              (x[1] - p["w"]) * ca.sin(t1) - p["n"] * ca.cos(t1))
        return ca.vertcat(x[0] - q[0], x[1] - q[1])

    return SymbolicModel(2, 2, ("n", "f", "w"), closure)
