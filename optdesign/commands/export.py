"""optdesign export RUN_DIR --mjcf FILE [--design optimum|NAME]: a MuJoCo model of a run's design.

Writes the MJCF model (SI units) of one design of a finished run: the
mechanism's multibody model (closed loops as ``connect`` equality
constraints), a position servo on each actuated joint and a keyframe
``home`` at the centre of the workspace (every loop closed; see
:mod:`optdesign.mjcf_export`).  The run folder is only read (its
JSON and YAML, never code); the one file written is FILE, through a
temporary file in FILE's folder and a rename.
"""
from __future__ import annotations

COMMAND = "export"


def register(sub):
    p = sub.add_parser(COMMAND, help="write a MuJoCo model (MJCF) of a finished run's design",
                       description="Write a MuJoCo model (MJCF XML, SI units) of one design of a finished run: "
                                   "the mechanism's bodies and joints, its closed loops as equality constraints, "
                                   "a position servo on each actuated joint (ctrl = actuator value in m or rad) and "
                                   "a keyframe 'home' at the centre of the workspace with every loop closed.")
    p.add_argument("run_dir", metavar="RUN_DIR", help="a finished run folder (manifest.json status: complete)")
    p.add_argument("--mjcf", required=True, metavar="FILE", help="the model to write, an .xml file")
    p.add_argument("--design", default="optimum", metavar="NAME",
                   help="optimum (default; the weighted-sum optimum), a design the run evaluated (see results.json "
                        "'designs'), or FRONT_K, the K-th design of a Pareto front (as in report.html's snippets)")
    p.add_argument("--servo-frequency", type=float, default=None, metavar="HZ",
                   help="each servo's natural frequency (default 10 Hz; critically damped)")
    p.set_defaults(func=run)


def _check_target(path: str) -> None:
    """FILE: an .xml name in an existing folder; an existing FILE must be a regular
    file (never a link) that already holds an XML/MJCF text."""
    import os
    from pathlib import Path

    from ._common import UsageError, check_out_file
    from ..config.reader import plain

    check_out_file(path, "--mjcf", suffixes=(".xml", ".mjcf"), kind="MJCF")
    p = Path(path)
    if p.exists() and p.stat().st_size:
        fd = os.open(p, os.O_RDONLY | os.O_NOFOLLOW | getattr(os, "O_NONBLOCK", 0))
        try:
            head = os.read(fd, 512)
        finally:
            os.close(fd)
        start = head.lstrip(b"\xef\xbb\xbf \t\r\n").lower()
        if not (start.startswith(b"<mujoco") or start.startswith(b"<?xml")):
            raise UsageError(f"--mjcf: {plain(path)} exists and is not an MJCF model; refusing to overwrite it")


def design_of(run, name: str) -> tuple[str, dict]:
    """(label, SI design variables) of a design of the run, named as ``--design`` takes it."""
    import math
    import re

    from ._common import UsageError
    from ..config.reader import shorten, suggest

    res = run.results
    names = ["optimum"] + [n for n in res.get("designs", {}) if isinstance(n, str)]
    def numbers(values: dict, key: str) -> dict:
        out = {k: values[k] for k in run.units.variables if k in values}
        for k, v in out.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise UsageError(f"{run.path / 'results.json'}: {key}.{k}: expected a finite number, got {shorten(v)}")
        return {k: float(v) for k, v in out.items()}

    if name == "optimum":
        return "the weighted-sum optimum", numbers(res["optimum"], "optimum")
    d = res.get("designs", {}).get(name)
    if isinstance(d, dict) and isinstance(d.get("parameters"), dict):
        return f"design {name}", numbers(d["parameters"], f"designs.{name}.parameters")
    m = re.fullmatch(r"(.+)_([0-9]{1,9})", name)
    if m and m.group(1) in run.fronts:
        front, k = run.fronts[m.group(1)], int(m.group(2))
        if 1 <= k <= front.size:
            out = {v: float(a[k - 1]) for v, a in front.designs.items()}
            if all(math.isfinite(x) for x in out.values()):
                return f"design {k} of the Pareto front {front.name}", out
        raise UsageError(f"{run.path / 'results.json'}: --design: the front {front.name} has designs 1 to {front.size}, "
                         f"got {shorten(name)}")
    fronts = [f"{f}_1" + (f"..{f}_{run.fronts[f].size}" if run.fronts[f].size > 1 else "")
              for f in run.fronts if run.fronts[f].size]
    raise UsageError(f"{run.path / 'results.json'}: --design: no design named {shorten(name)}{suggest(name, names)}; "
                     f"the run has {', '.join(names + fronts)}")


def keyframe_pose(ws, mech):
    """The centre of the workspace W (its spec ``ws``; SI), or W's first reachable sample point."""
    import numpy as np

    from ..workspace import sample

    names = mech.pose_names
    if ws.type == "cylinder":
        X = np.array([ws.center[0], ws.center[1], 0.5 * sum(ws.axes[names[2]])] + [0.5 * sum(ws.axes[a]) for a in names[3:]])
    else:
        X = np.array([0.5 * sum(ws.axes[a]) for a in names], float)
    if bool(mech.reachable(X[None])[0]):
        return X, "the centre of W"
    S = sample(ws, names).X
    ok = np.asarray(mech.reachable(S))
    if not ok.any():
        raise ValueError("the design reaches no point of the workspace W")
    return S[int(np.argmax(ok))], "the first reachable sample point of W"


def run(args) -> int:
    import math
    from pathlib import Path

    from ._common import UsageError
    from ..io import atomic_write_text
    from ..mjcf_export import DEFAULT_FREQUENCY, export_mjcf, model_module
    from ..report.html.rundata import load_run
    from ..runs import RunFolderError

    f = DEFAULT_FREQUENCY if args.servo_frequency is None else args.servo_frequency
    if not (math.isfinite(f) and 0.01 <= f <= 1000):
        raise UsageError(f"--servo-frequency: expected 0.01 to 1000 Hz, got {f:g}")
    _check_target(args.mjcf)
    try:
        run_data = load_run(args.run_dir)
    except RunFolderError as exc:
        raise UsageError(str(exc)) from None
    label, design = design_of(run_data, args.design)
    try:
        mech = run_data.model.build(design)
    except (ValueError, TypeError) as exc:
        raise UsageError(f"{run_data.path / 'results.json'}: design {args.design}: {exc}") from None
    if model_module(mech) is None:
        raise UsageError(f"{run_data.path / 'config.yaml'}: mechanism: mechanism {run_data.mechanism!r} has no MuJoCo model "
                         "(the 3-P(4S) and described mechanisms with masses have one)")
    try:
        import mujoco
    except ImportError:
        raise UsageError("MuJoCo is not installed; install the validation extra: pip install 'optdesign[validation]'") from None
    try:
        X, where = keyframe_pose(run_data.workspace, mech)
        text = export_mjcf(mech, X, frequency=f, model_name=f"{run_data.name}-{args.design}")
        model = mujoco.MjModel.from_xml_string(text)        # it loads and steps before it is written
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, 0)
        mujoco.mj_step(model, data)
    except (ValueError, NotImplementedError) as exc:
        raise UsageError(f"{run_data.path}: design {args.design}: {exc}") from None
    out = Path(args.mjcf)
    atomic_write_text(out, text)
    print(f"wrote {out}: MuJoCo model of {label} ({model.nbody - 1} bodies, {model.neq} loop constraints, "
          f"{model.nu} position servos at {f:g} Hz; keyframe 'home' at {where})")
    return 0
