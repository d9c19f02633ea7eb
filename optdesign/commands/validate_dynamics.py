"""optdesign validate-dynamics CONFIG --design NAME [--out DIR]: our dynamics against MuJoCo.

A described mechanism (with masses; ``optdesign.mechanisms.described.mujoco``):
MuJoCo's inverse dynamics and its mass matrix reduced to the pose rates
against ours on two smooth paths around the home pose (small and large
amplitudes), written as ``forces.png``, ``summary.json`` and the model.

The 3-P(4S): runs the two comparisons of its MuJoCo check
(``optdesign.mechanisms.p4s.mujoco``) on the
paper's path (x = y = 0.001 sin(40 pi t)) and on a larger one, prints the
agreement numbers and writes ``forces.png`` (the actuator forces from our
model and from MuJoCo, as the 3-P(4S) paper's figures 9 and 10), ``tracking.png``
(the platform's deviation in MuJoCo's simulation driven by our forces),
``summary.json`` and the model ``p4s.xml`` (MJCF, loads in MuJoCo's viewer)
into DIR (default ``validation/<design>``).
"""
from __future__ import annotations

import io
import math

COMMAND = "validate-dynamics"


def register(sub):
    p = sub.add_parser(COMMAND, help="check the dynamic model against MuJoCo (inverse dynamics and simulation)")
    p.add_argument("config", help="YAML config file")
    p.add_argument("--design", required=True, metavar="NAME", help="a named design of the config")
    p.add_argument("--out", metavar="DIR", default=None, help="output folder (default: validation/<design>)")
    p.add_argument("--z", type=float, default=None,
                   help="height of the paths' centre in m (default: the middle of the workspace's z range)")
    p.add_argument("--duration", type=float, default=0.1, help="seconds of the paper's path (default 0.1)")
    p.add_argument("--large-duration", type=float, default=1.0, help="seconds of the larger path (default 1.0)")
    p.add_argument("--points", type=int, default=201, help="poses per path for the inverse comparison (default 201)")
    p.add_argument("--timestep", type=float, default=None, help="simulation step in s (default 1e-4)")
    p.set_defaults(func=run)


def _check_args(args):
    from ._common import UsageError

    for name in ("duration", "large_duration"):
        v = getattr(args, name)
        if not (math.isfinite(v) and 0 < v <= 60):
            raise UsageError(f"--{name.replace('_', '-')}: expected a duration in (0, 60] s, got {v:g}")
    if not 2 <= args.points <= 100_000:
        raise UsageError(f"--points: expected 2 to 100000, got {args.points}")
    if args.timestep is not None and not (math.isfinite(args.timestep) and 1e-7 <= args.timestep <= 1e-2):
        raise UsageError(f"--timestep: expected 1e-7 to 1e-2 s, got {args.timestep:g}")
    if args.z is not None and not math.isfinite(args.z):
        raise UsageError(f"--z: expected a finite height, got {args.z:g}")


def run(args) -> int:
    import sys
    from pathlib import Path

    import numpy as np

    from ..io import atomic_write_bytes, atomic_write_json
    from ._common import UsageError, design_names, open_config
    from ..tables import fmt, print_table

    _check_args(args)
    cfg = open_config(args.config)
    from ..evaluate import build, mechanism_class

    check = mechanism_class(cfg).multibody_check
    if check is None:
        raise UsageError(f"{cfg.source}: mechanism: mechanism {cfg.mechanism!r} has no MuJoCo model to check against")
    design_names(cfg, [args.design])
    try:
        import mujoco  # noqa: F401
    except ImportError:
        raise UsageError("MuJoCo is not installed; install the validation extra: pip install 'optdesign[validation]'") from None
    import importlib

    mv = importlib.import_module(check)
    mech = build(cfg, args.design)
    if not hasattr(mv, "simulate"):
        return _run_described(args, cfg, mech, mv)
    z = args.z if args.z is not None else 0.5 * sum(cfg.workspace.axes["z"])
    out = Path(args.out) if args.out else Path("validation") / args.design
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out: {out} exists and is not a folder")
    sim_kw = {"timestep": args.timestep} if args.timestep else {}
    if args.timestep:
        sim_kw["solref"] = (2 * args.timestep, 1.0)
    paths = [(mv.paper_trajectory(z), args.duration), (mv.large_trajectory(z), args.large_duration)]
    results = {}
    try:
        for traj, t_end in paths:
            t = np.linspace(0.0, t_end, args.points)
            X, V, A = traj(t)
            if not np.all(mech.reachable(X)):
                print(f"optdesign: error: design {args.design!r} cannot follow the {traj.name} path "
                      f"({traj.describe()}): a pose is out of reach", file=sys.stderr)
                return 1
            inv = mv.inverse_dynamics(mech, X, V, A)
            sim = mv.simulate(mech, traj, t_end, **sim_kw)
            results[traj.name] = (traj, t, inv, sim)
    except ValueError as exc:
        print(f"optdesign: error: {exc}", file=sys.stderr)
        return 1

    rows = []
    summary = {"config": cfg.source, "design": args.design, "parameters": cfg.design(args.design),
               "timestep": sim_kw.get("timestep", mv.SIM_TIMESTEP), "paths": {}}
    for name, (traj, t, inv, sim) in results.items():
        peak = float(np.abs(inv["ours"]).max())
        rel = float(np.abs(inv["forces"] - inv["ours"]).max() / peak)
        err_um = float(1e6 * sim["error"].max())
        rows.append([name, fmt(peak, 2), f"{rel:.2e}", f"{inv['loop_gap'].max():.1e}",
                     f"{inv['residual'].max():.1e}", f"{err_um:.3f}", f"{sim['max_loop_gap']:.1e}"])
        summary["paths"][name] = {
            "path": traj.describe(), "duration_s": float(t[-1]), "points": len(t),
            "peak_force_N": peak, "max_relative_difference": rel,
            "max_loop_gap_m": float(inv["loop_gap"].max()),
            "max_unbalanced_passive_force": float(inv["residual"].max()),
            "max_tracking_error_um": err_um, "final_tracking_error_um": float(1e6 * sim["error"][-1]),
            "simulation_max_loop_gap_m": float(sim["max_loop_gap"]),
            "simulation_max_platform_rotation_rad": float(sim["max_platform_rotation"]),
            "simulation_max_rod_spin_rad_s": float(sim["max_rod_spin"]),
        }
    print(f"{cfg.source}: design {args.design}, MuJoCo {mujoco.__version__}, simulation step "
          f"{summary['timestep']:g} s (RK4)")
    print_table(["path", "peak force [N]", "max diff / peak [–]", "loop gap [m]", "unbalanced [N]",
                 "tracking error [µm]", "sim. loop gap [m]"], rows)

    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out: cannot make the folder {out} ({exc.strerror or exc})") from None
    atomic_write_bytes(out / "forces.png", _forces_figure(results, args.design))
    atomic_write_bytes(out / "tracking.png", _tracking_figure(results, args.design))
    atomic_write_json(out / "summary.json", summary)
    model = out / f"{cfg.mechanism}.xml"
    atomic_write_bytes(model, mv.mjcf(mech).encode())
    print(f"wrote {out / 'forces.png'}, {out / 'tracking.png'}, {out / 'summary.json'}, {model} (the MuJoCo model)")
    return 0


#: the described paths: (name, amplitude in m, amplitude in rad); durations from --duration, --large-duration
DESCRIBED_PATHS = (("small", 0.005, 0.02), ("large", 0.02, 0.08))


def _run_described(args, cfg, mech, mv) -> int:
    """Inverse dynamics and reduced mass matrix of a described mechanism against MuJoCo."""
    import sys
    from pathlib import Path

    import mujoco
    import numpy as np

    from ..io import atomic_write_bytes, atomic_write_json
    from ..tables import fmt, print_table
    from ._common import UsageError

    out = Path(args.out) if args.out else Path("validation") / args.design
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out: {out} exists and is not a folder")
    results, rows = {}, []
    summary = {"config": cfg.source, "design": args.design, "parameters": cfg.design(args.design), "paths": {}}
    try:
        model = mv.DescribedModel(mech)
        for (name, amp_l, amp_a), t_end in zip(DESCRIBED_PATHS, (args.duration, args.large_duration)):
            t = np.linspace(0.0, t_end, args.points)
            X, V, A = mv.smooth_trajectory(mech, t, amplitude_length=amp_l, amplitude_angle=amp_a)
            if not np.all(mech.reachable(X)):
                print(f"optdesign: error: design {args.design!r} cannot follow the {name} path around the home "
                      "pose: a pose is out of reach", file=sys.stderr)
                return 1
            inv = mv.inverse_dynamics(mech, X, V, A, model)
            Mj, Mo = mv.mass_matrices(mech, X[:: max(1, len(X) // 20)], model)
            peak = float(np.abs(inv["ours"]).max())
            rel = float(np.abs(inv["forces"] - inv["ours"]).max() / peak)
            mrel = float(np.abs(Mj - Mo).max() / np.abs(Mo).max())
            results[name] = (None, t, inv, None)
            rows.append([name, fmt(peak, 2), f"{rel:.2e}", f"{mrel:.2e}", f"{inv['loop_gap'].max():.1e}",
                         f"{inv['residual'].max():.1e}"])
            summary["paths"][name] = {
                "path": f"two sines per pose coordinate around the home pose, amplitudes {amp_l:g} m, {amp_a:g} rad",
                "duration_s": float(t[-1]), "points": len(t), "peak_force": peak,
                "max_relative_difference": rel, "mass_matrix_max_relative_difference": mrel,
                "max_loop_gap_m": float(inv["loop_gap"].max()),
                "max_unbalanced_passive_force": float(inv["residual"].max())}
    except (ValueError, NotImplementedError) as exc:
        print(f"optdesign: error: {exc}", file=sys.stderr)
        return 1
    print(f"{cfg.source}: design {args.design}, MuJoCo {mujoco.__version__} (inverse dynamics and mass matrix)")
    units = set(mech.actuator_units())
    unit = "N m" if units == {"rad"} else "N" if units == {"m"} else "N or N m"
    print_table(["path", f"peak force [{unit}]", "max diff / peak [–]", "mass matrix diff [–]", "loop gap [m]",
                 "unbalanced [N or N m]"], rows)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out: cannot make the folder {out} ({exc.strerror or exc})") from None
    atomic_write_bytes(out / "forces.png", _forces_figure(results, args.design, unit))
    atomic_write_json(out / "summary.json", summary)
    model_file = out / "model.xml"
    atomic_write_bytes(model_file, mv.mjcf(mech).encode())
    print(f"wrote {out / 'forces.png'}, {out / 'summary.json'}, {model_file} (the MuJoCo model)")
    return 0


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


def _forces_figure(results, design, unit: str = "N") -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(results), 3, figsize=(14, 3.6 * len(results) + 0.6), squeeze=False,
                             layout="constrained")
    for row, (name, (traj, t, inv, _)) in zip(axes, results.items()):
        for k in range(inv["ours"].shape[1]):
            row[0].plot(t, inv["ours"][:, k], label=f"actuator {k + 1}")
            row[1].plot(t, inv["forces"][:, k], label=f"actuator {k + 1}")
            row[2].plot(t, inv["forces"][:, k] - inv["ours"][:, k], label=f"actuator {k + 1}")
        row[0].set_title(f"{name} path: our model", fontsize=10)
        row[1].set_title(f"{name} path: MuJoCo inverse dynamics", fontsize=10)
        row[2].set_title(f"{name} path: MuJoCo − ours", fontsize=10)
        for ax, lab in zip(row, (f"actuator force [{unit}]", f"actuator force [{unit}]", f"difference [{unit}]")):
            ax.set_xlabel("t [s]")
            ax.set_ylabel(lab)
            ax.grid(alpha=0.3)
            ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4), useOffset=False)
    h, lab = axes[0][0].get_legend_handles_labels()
    fig.legend(h, lab, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    fig.suptitle(f"actuator forces, design {design}")
    return _png(fig)


def _tracking_figure(results, design) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(results), figsize=(6 * len(results), 3.8), squeeze=False, layout="constrained")
    for ax, (name, (traj, _, _, sim)) in zip(axes[0], results.items()):
        ax.plot(sim["t"], 1e6 * sim["error"])
        ax.set_title(f"{name} path: {traj.describe()}", fontsize=8, wrap=True)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("|platform − commanded| [µm]")
        ax.grid(alpha=0.3)
    fig.suptitle(f"MuJoCo simulation driven by our actuator forces, design {design}")
    return _png(fig)
