"""optdesign ik / fk: inverse and forward kinematics of a named design."""
from __future__ import annotations

import json
import re

import numpy as np

#: what argparse takes for a negative number rather than an option: -1, -.5, -1e-3, -2.5E+4, -inf
_NEGATIVE = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$", re.IGNORECASE)

COMMAND = "ik"


def register(sub):
    for name, helptext, meta in (("ik", "inverse kinematics: pose -> actuator values", "POSE"),
                                 ("fk", "forward kinematics: actuator values -> pose", "ACT")):
        p = sub.add_parser(name, help=helptext)
        p._negative_number_matcher = _NEGATIVE   # noqa: SLF001 - argparse's hook for negative numbers as values
        p.add_argument("config", help="YAML config file")
        p.add_argument("--design", default=None, metavar="NAME", help="named design (default: the initial design)")
        p.add_argument("values", nargs="+", type=float, metavar=meta,
                       help="pose coordinates (SI: m, rad)" if name == "ik" else "actuator values (SI: m, rad)")
        p.add_argument("--json", action="store_true", help="print JSON")
        p.set_defaults(func=run, kin=name)


def run(args) -> int:
    from ._common import UsageError, open_config

    cfg = open_config(args.config)
    design = args.design or ("initial" if "initial" in cfg.designs else next(iter(cfg.designs)))
    from ..evaluate import build

    mech = build(cfg, design)
    n_in = mech.dof if args.kin == "ik" else mech.n_act
    names_in = mech.pose_names if args.kin == "ik" else mech.actuator_names
    names_out = mech.actuator_names if args.kin == "ik" else mech.pose_names
    if len(args.values) != n_in:
        raise UsageError(f"{args.kin}: expected {n_in} values ({', '.join(names_in)}), got {len(args.values)}")
    v = np.array([args.values], dtype=float)
    if not np.all(np.isfinite(v)):
        raise UsageError(f"{args.kin}: expected finite numbers, got {args.values}")
    with np.errstate(all="ignore"):
        out = (mech.inverse(v) if args.kin == "ik" else mech.forward(v))[0]
    ok = bool(np.all(np.isfinite(out)))
    if args.json:
        rec = {"design": design, "input": dict(zip(names_in, args.values)),
               "output": dict(zip(names_out, [float(x) if np.isfinite(x) else None for x in out])),
               "reachable": ok}
        if args.kin == "ik":
            rec.update(_jacobians(mech, v))
        par = _parasitic(mech, v if args.kin == "ik" else out[None])
        if par is not None:
            rec["parasitic"] = {k: (float(x) if np.isfinite(x) else None) for k, x in par.items()}
        print(json.dumps(rec))
    elif ok:
        from ..units import actuator_units, pose_unit

        shown = cfg.units()
        units = actuator_units(shown) if args.kin == "ik" else [pose_unit(shown, a) for a in names_out]
        print("  ".join(f"{n} = {x:.12g}" + ("" if u == "1" else f" {u}") for n, x, u in zip(names_out, out, units)))
        par = _parasitic(mech, v if args.kin == "ik" else out[None])
        if par is not None:
            print("parasitic: " + "  ".join(f"{n} = {x:.12g} {'rad' if n in _angle_names(mech) else 'm'}"
                                            for n, x in par.items()))
    else:
        what = "this pose" if args.kin == "ik" else "these actuator values"
        print(f"unreachable: no real solution for {what} ({design} design)")
    return 0 if ok else 1


def _rows(J):
    return [[float(x) if np.isfinite(x) else None for x in row] for row in J]


def _jacobians(mech, v) -> dict:
    """``jacobian``: dq/dx at the pose (rows: actuators, columns: pose coordinates,
    in order; SI: per m and per rad); where the mechanism's own Jacobian (the one
    its indices use) is on other velocity coordinates (angular velocity), that
    one too, as ``jacobian_angular_velocity``."""
    with np.errstate(all="ignore"):
        own = mech.jacobian(v)[0]
        rates = None
        for name in ("jacobian_rates", "jacobian_euler"):  # described mechanisms; the 3-SPS-S module
            if hasattr(mech, name):
                rates = getattr(mech, name)(v)[0]
                break
    out = {"jacobian": _rows(own if rates is None else rates)}
    if rates is not None and not np.array_equal(rates, own, equal_nan=True):
        out["jacobian_angular_velocity"] = _rows(own)
    return out



def _parasitic(mech, x):
    """{name: value} of the parasitic pose coordinates at independent coordinates
    x (1, dof) (chain mechanisms, docs/lower-mobility.md), or None."""
    names = getattr(mech, "parasitic_names", ())
    if not names:
        return None
    with np.errstate(all="ignore"):
        vals = mech.parasitic(x)[0]
    return dict(zip(names, vals))


def _angle_names(mech) -> set:
    spec = mech.pose_spec
    return {n for n, r in zip(spec.names, spec.roles) if r in ("roll", "pitch", "yaw")}
