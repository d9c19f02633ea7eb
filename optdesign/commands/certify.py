"""optdesign certify CONFIG: interval certificates of a config's named designs
over the continuous workspace (docs/certificates.md)."""
from __future__ import annotations

COMMAND = "certify"


def register(sub):
    p = sub.add_parser(COMMAND, help="prove (or refute) a config's designs over the whole continuous workspace")
    p.add_argument("config", help="YAML config file")
    p.add_argument("--design", action="append", metavar="NAME",
                   help="a named design of the config (repeatable; default: every named design)")
    p.add_argument("--budget", type=int, default=None, metavar="N",
                   help="box evaluations per design (default 300000; 100000 for W of more than 3 free axes)")
    p.add_argument("--json", action="store_true", help="print the certificates as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    """Exit 0 when every design is certified, 1 when one is refuted, unknown or not supported."""
    import numpy as np

    from ._common import UsageError, json_text, open_config
    from ..certify.designs import certify_design, region_of
    from ..certify.reported import budget_for
    from ..evaluate import build, workspace_of
    from ..units import pose_display

    cfg = open_config(args.config)
    names = args.design or list(cfg.designs)
    for n in names:
        if n not in cfg.designs:
            raise UsageError(f"{args.config}: --design: no design {n!r} (the config has: {', '.join(cfg.designs)})")
    if args.budget is not None and not 1 <= args.budget <= 10 ** 9:
        raise UsageError(f"--budget: expected a positive integer up to 1e9, got {args.budget}")
    ws = workspace_of(cfg)
    region = region_of(ws)
    free = int(np.sum(region["hi"] > region["lo"]))
    budget = args.budget if args.budget is not None else budget_for(free, False)
    iso = [k for k, s in cfg.indices.items() if s.kind == "isotropy"]
    conv = (cfg.indices[iso[0]].convention or "frobenius") if iso else "two_norm"
    limit = cfg.optimizer.singularity_threshold
    units = cfg.units()
    out = {}
    for n in names:
        c = certify_design(build(cfg, n), region, limit, conv, cfg.optimizer.stroke_limits, budget=budget)
        if c.get("witness") is not None:
            c["axes"] = list(ws.names)
        out[n] = c
        if not args.json:
            line = f"{n}: {c['status']}"
            if c["status"] == "refuted":
                pose = ", ".join(f"{a} = {v * pose_display(units, a)[1]:.6g} {pose_display(units, a)[0]}"
                                 for a, v in zip(ws.names, c["witness"]))
                val = {"unreachable": "a leg does not close", "stroke": "a stroke limit is broken"}.get(
                    c.get("reason"), f"cond {c['value']:.6g} > {limit:g}" if c.get("value") is not None
                    else "singular (cond infinite)")
                line += f" ({val}) at {pose}"
            elif c["status"] == "unknown":
                line += f" ({100 * c['share_proved']:.2f} % of W proved in {c['boxes']} boxes)"
            elif c["status"] == "certified":
                line += f" (cond <= {limit:g} and every pose reachable over all of W; {c['boxes']} boxes)"
            else:
                line += f" ({c.get('reason')})"
            print(line, flush=True)
    if args.json:
        print(json_text({"config": str(args.config), "limit": limit, "convention": conv, "budget": budget,
                         "certificates": out}))
    return 0 if all(c["status"] == "certified" for c in out.values()) else 1
