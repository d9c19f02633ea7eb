"""The dynamics example of the 3-P(4S) paper (seed paper 001, sections 1.4 and 2.4).

The "before" design (r_a = 0.25 m, r_b = 0.67 m, L = 0.38 m, d = 0.12 m,
phi = 30 deg), the paper's masses, and the motion x = y = 0.001 sin(40 pi t),
z = 0.57 m over 0 <= t <= 0.1 s.  Computes the actuator velocities (the paper's
figure 5), accelerations (figure 6) and forces (figure 9), and quantifies what
the paper's printed dynamics would change:

* eq. 21's extra rod term 2 J_wd^T (r_d x m_d g), which is not in our model;
* eq. 23's M and N without the factor 2 of eq. 20 for the two rods per branch;
* eq. 23's overall minus sign (d'Alembert convention).

Run from the repository root:  python docs/dynamics_example.py
Writes docs/figures/p4s_fig5_velocities.png, p4s_fig6_accelerations.png,
p4s_fig9_forces.png, p4s_eq21_gravity_term.png and p4s_dynamics_example.json.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from optdesign.mechanisms import get

OUT = Path(__file__).resolve().parent / "figures"
DESIGN = dict(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=np.radians(30.0))   # section 1.1
W = 40 * np.pi                                                           # rad/s (20 Hz)


def trajectory(t: np.ndarray):
    """Platform position, velocity and acceleration (N, 3) of section 2.4."""
    s, c = np.sin(W * t), np.cos(W * t)
    z = np.zeros_like(t)
    X = np.stack([1e-3 * s, 1e-3 * s, z + 0.57], -1)
    V = np.stack([1e-3 * W * c, 1e-3 * W * c, z], -1)
    A = np.stack([-1e-3 * W * W * s, -1e-3 * W * W * s, z], -1)
    return X, V, A


def paper_eq21_extra_term(mech, X: np.ndarray) -> np.ndarray:
    """The term 2 sum_i J_wdi^T (r_di x m_d g) of the paper's eq. 21 in actuator
    space, J^-T sum_i 2 J_wi^T (r_di x m_d g z), with r_di the rod centre (eq. 10)
    measured from the base origin.  Gravity does no work on a rod's rotation
    about its centre, so this term does not belong in the model."""
    J = mech.jacobian(X)
    Jw = mech.rod_angular_velocity_map(X)                          # (N, 3, 3, 3)
    rods = mech.body_positions(X)["rods"].mean(axis=-2)            # rod-pair centre, eq. 10
    weight = float(mech.params["m_rod"]) * float(mech.params["g"]) * np.array([0.0, 0.0, 1.0])
    moment = np.cross(rods, weight)                                # (N, 3, 3)
    F = 2.0 * np.einsum("nbki,nbk->ni", Jw, moment)
    return np.linalg.solve(np.swapaxes(J, -1, -2), F[..., None])[..., 0]


def main() -> dict:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    P4S = get("p4s")
    mech = P4S(**DESIGN)                     # the paper's masses are the defaults
    t = np.linspace(0.0, 0.1, 2001)
    X, V, A = trajectory(t)
    qd = np.einsum("nij,nj->ni", mech.jacobian(X), V)                   # eq. 8
    qdd = mech.accelerations(X, V, A)                                    # eq. 13
    tau = mech.actuator_forces(X, V, A)                                  # eq. 23, corrected
    grav = mech.gravity_term(X)
    inertial = tau - grav

    # what the printed equations would give
    one_rod = P4S(**DESIGN, rods_per_branch=1.0)
    inertial_eq23 = one_rod.actuator_forces(X, V, A) - one_rod.gravity_term(X)   # no factor 2 in M, N
    extra21 = paper_eq21_extra_term(mech, X)
    power = np.sum(tau * qd, -1)
    extra_power = np.sum(extra21 * qd, -1)

    # an independent check of the forces along the trajectory: the CasADi route
    from optdesign.mechanisms.p4s import symbolic_model

    sym = symbolic_model()
    p = {k: float(v) for k, v in mech.params.items()}
    tau_ad = sym.actuator_forces(X, mech.inverse(X), V, A, p)

    # the same comparison for a vertical motion z = 0.57 + 0.01 sin(10 pi t), where
    # gravity does work: the power of eq. 21's extra term against the true power
    wz = 10 * np.pi
    Xz = np.stack([0 * t, 0 * t, 0.57 + 0.01 * np.sin(wz * t)], -1)
    Vz = np.stack([0 * t, 0 * t, 0.01 * wz * np.cos(wz * t)], -1)
    Az = np.stack([0 * t, 0 * t, -0.01 * wz * wz * np.sin(wz * t)], -1)
    qdz = np.einsum("nij,nj->ni", mech.jacobian(Xz), Vz)
    power_z = np.sum(mech.actuator_forces(Xz, Vz, Az) * qdz, -1)
    extra_power_z = np.sum(paper_eq21_extra_term(mech, Xz) * qdz, -1)

    def peak(a):
        return [float(v) for v in np.max(np.abs(a), axis=0)]

    res = {
        "design": {k: float(v) for k, v in DESIGN.items()},
        "strokes_at_t0_m": [float(v) for v in mech.inverse(X[:1])[0]],
        "peak_velocity_m_s": peak(qd),
        "peak_acceleration_m_s2": peak(qdd),
        "force_min_N": [float(v) for v in tau.min(0)],
        "force_max_N": [float(v) for v in tau.max(0)],
        "static_force_at_centre_N": [float(v) for v in grav[0]],
        "peak_inertial_force_N": peak(inertial),
        "peak_inertial_force_eq23_without_factor_2_N": peak(inertial_eq23),
        "eq21_extra_term_range_N": [[float(v) for v in extra21.min(0)], [float(v) for v in extra21.max(0)]],
        "eq21_extra_power_over_peak_power": float(np.abs(extra_power).max() / np.abs(power).max()),
        "eq21_extra_power_over_peak_power_vertical": float(np.abs(extra_power_z).max() / np.abs(power_z).max()),
        "gravity_term_range_N": [float(grav.min()), float(grav.max())],
        "max_rel_difference_vs_casadi": float(np.abs(tau_ad - tau).max() / np.abs(tau).max()),
    }

    OUT.mkdir(parents=True, exist_ok=True)
    labels = ["actuator 1", "actuator 2", "actuator 3"]
    for name, data, ylabel, title in (
        ("p4s_fig5_velocities.png", qd * 1e3, "stroke velocity [mm/s]", "Actuator velocities (paper fig. 5)"),
        ("p4s_fig6_accelerations.png", qdd, "stroke acceleration [m/s$^2$]", "Actuator accelerations (paper fig. 6)"),
        ("p4s_fig9_forces.png", tau, "actuator force [N]", "Actuator forces (paper fig. 9)"),
    ):
        fig, ax = plt.subplots(figsize=(7, 3.8), layout="constrained")
        for k in range(3):
            ax.plot(t, data[:, k], label=labels[k], lw=1.2, ls=("-", "--", ":")[k])
        ax.set_xlabel("t [s]")
        ax.set_ylabel(ylabel)
        ax.set_title(title + ": x = y = 0.001 sin(40 pi t) m, z = 0.57 m, before design")
        ax.title.set_fontsize(9)
        ax.grid(alpha=0.3)
        # the legend beside the plot, never over a curve
        ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5), frameon=False)
        fig.savefig(OUT / name, dpi=110)
        plt.close(fig)

    from matplotlib.lines import Line2D

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    for k in range(3):
        axes[0].plot(t, grav[:, k], color=f"C{k}", lw=1.2)
        axes[0].plot(t, grav[:, k] + extra21[:, k], color=f"C{k}", ls="--", lw=1.0)
        axes[1].plot(t, inertial[:, k], color=f"C{k}", lw=1.2)
        axes[1].plot(t, inertial_eq23[:, k], color=f"C{k}", ls="--", lw=1.0)
    axes[0].set_title("gravity term", fontsize=10)
    axes[1].set_title("inertial + velocity terms", fontsize=10)
    axes[1].margins(y=0.22)   # room for the legend above the peaks
    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.set_ylabel("actuator force [N]")
        ax.grid(alpha=0.3)
    # one legend for the colours (actuators), one per panel for the line styles (models)
    actuators = [Line2D([], [], color=f"C{k}", lw=1.2, label=labels[k]) for k in range(3)]
    axes[0].legend(handles=[Line2D([], [], color="k", lw=1.2, label="ours (energy-consistent)"),
                            Line2D([], [], color="k", ls="--", lw=1.0, label="with eq. 21's rod term")],
                   fontsize=8, loc="center right")
    axes[1].legend(handles=[Line2D([], [], color="k", lw=1.2, label="two rods per branch"),
                            Line2D([], [], color="k", ls="--", lw=1.0, label="eq. 23 (one rod)")],
                   fontsize=8, loc="upper right", framealpha=0.9)
    fig.legend(handles=actuators, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    fig.savefig(OUT / "p4s_eq21_gravity_term.png", dpi=110)
    plt.close(fig)
    (OUT / "p4s_dynamics_example.json").write_text(json.dumps(res, indent=2) + "\n")
    return res


if __name__ == "__main__":
    r = main()
    print(json.dumps(r, indent=2))
