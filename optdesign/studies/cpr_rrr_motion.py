"""The 2-CPR/RRR paper's motion example (seed paper 002, section 5, fig. 4):
the input motion, the platform motion through both input types, and the figure
(``docs/cpr_rrr_motion.py`` draws it)."""
from __future__ import annotations

import numpy as np

from ..mechanisms.cpr_rrr import CPR_RRR, LINEAR, ROTARY

__all__ = ["PAPER_MOTION", "paper_motion", "motion_profile", "plot_motion_example"]

#: the paper's motion example (section 5): input displacements of the C slides,
#: X = 10 sin(pi t / 10 + pi / 2), Y = 7.5 sin(pi t / 7.5), 25 s in 200 steps.
#: The paper gives no units; we read mm and s (the Adams defaults).
PAPER_MOTION = {"amplitude_x": 10e-3, "period_x": 20.0, "phase_x": np.pi / 2,
                "amplitude_y": 7.5e-3, "period_y": 15.0, "phase_y": 0.0,
                "duration": 25.0, "steps": 200}


def paper_motion(t: np.ndarray) -> dict[str, np.ndarray]:
    """The input motion of section 5 (linear inputs = platform motion, eq. 21-22):
    ``x = 10 sin(pi t / 10 + pi / 2)``, ``y = 7.5 sin(pi t / 7.5)`` (mm in the
    paper, m here) and their exact time derivatives, each (len(t), 2)."""
    t = np.asarray(t, dtype=float)
    P = PAPER_MOTION
    out = {"X": [], "V": [], "A": []}
    for ax in ("x", "y"):
        A0, w, ph = P[f"amplitude_{ax}"], 2 * np.pi / P[f"period_{ax}"], P[f"phase_{ax}"]
        out["X"].append(A0 * np.sin(w * t + ph))
        out["V"].append(A0 * w * np.cos(w * t + ph))
        out["A"].append(-A0 * w * w * np.sin(w * t + ph))
    return {k: np.stack(v, axis=-1) for k, v in out.items()}


def motion_profile(t: np.ndarray, **design) -> dict[str, np.ndarray]:
    """The motion example through both input types of one design.

    Linear inputs (m1, m2) are the paper's inputs; the platform motion follows
    from eq. 21-24 (forward map, J = I).  The rotary inputs that produce the
    same platform motion come from the inverse kinematics, and their rates and
    accelerations from qdot = J v and qdd = J a + c; the platform velocity and
    acceleration are then recomputed from the rotary inputs with the paper's
    forward maps (eq. 15-18), an independent route to the same curves.
    """
    lin = CPR_RRR(input_type=LINEAR, **design)
    rot = CPR_RRR(input_type=ROTARY, **design)
    m = paper_motion(t)
    X = lin.forward(m["X"])
    V = lin.forward_velocity(m["X"], m["V"])
    A = lin.forward_acceleration(m["X"], m["V"], m["A"])
    th = rot.inverse(X)
    thd = np.einsum("...ij,...j->...i", rot.jacobian(X), V)
    thdd = rot.accelerations(X, V, A)
    return {"t": np.asarray(t, float), "m": m["X"], "md": m["V"], "mdd": m["A"], "X": X, "V": V, "A": A,
            "theta": th, "thetad": thd, "thetadd": thdd,
            "V_from_rotary": rot.forward_velocity(th, thd),
            "A_from_rotary": rot.forward_acceleration(th, thd, thdd)}


def plot_motion_example(path, t=None, **design):
    """Figure 4 of the paper from :func:`motion_profile`: platform displacement,
    velocity and acceleration (linear inputs, eq. 21-24; the rotary route of
    eq. 15-18 drawn dashed on top), and the inputs of both types.  Writes a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    P = PAPER_MOTION
    if t is None:
        t = np.linspace(0.0, P["duration"], P["steps"] + 1)
    mp = motion_profile(t, **design)
    fig, axs = plt.subplots(2, 3, figsize=(13, 7.4), layout="constrained")
    mm = 1e3
    rows = [("displacement [mm]", mp["X"], None), ("velocity [mm/s]", mp["V"], mp["V_from_rotary"]),
            ("acceleration [mm/s$^2$]", mp["A"], mp["A_from_rotary"])]
    for ax, (label, lin, rot) in zip(axs[0], rows):
        ax.plot(t, mm * lin[:, 0], label="x")
        ax.plot(t, mm * lin[:, 1], label="y")
        if rot is not None:
            ax.plot(t, mm * rot[:, 0], "k--", lw=0.8, label="x, from rotary inputs (eq. 15-18)")
            ax.plot(t, mm * rot[:, 1], "k:", lw=0.8, label="y, from rotary inputs")
        ax.set_xlabel("t [s]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axs[0, 0].legend(fontsize=8)
    # room above the curves for the four entries, which would otherwise cover them
    axs[0, 1].margins(y=0.45)
    axs[0, 1].legend(fontsize=7, loc="upper center", ncol=2)
    ax = axs[1, 0]
    ax.plot(t, mm * mp["m"][:, 0], label="m1")
    ax.plot(t, mm * mp["m"][:, 1], label="m2")
    ax.set_ylabel("linear inputs [mm]")
    ax.set_title("linear inputs (= platform x, y)", fontsize=9)
    ax = axs[1, 1]
    ax.plot(t, np.degrees(mp["theta"][:, 0]), label="theta2")
    ax.plot(t, np.degrees(mp["theta"][:, 1]), label="theta1")
    ax.set_ylabel("rotary inputs [deg]")
    ax.set_title("rotary inputs for the same motion", fontsize=9)
    ax = axs[1, 2]
    ax.plot(t, np.degrees(mp["thetad"][:, 0]), label="theta2 rate")
    ax.plot(t, np.degrees(mp["thetad"][:, 1]), label="theta1 rate")
    ax.set_ylabel("rotary input rates [deg/s]")
    for ax in axs[1]:
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    mech = CPR_RRR(**design)
    fig.suptitle("2-CPR/RRR motion example (paper section 5, fig. 4): X = 10 sin(pi t/10 + pi/2), "
                 f"Y = 7.5 sin(pi t/7.5) mm; n = {1e3 * float(mech.n):g} mm, "
                 f"f = {1e3 * float(mech.f):g} mm, w = {1e3 * float(mech.w):g} mm", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return mp
