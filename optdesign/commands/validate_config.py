"""optdesign validate-config FILE: check a config alone."""
from __future__ import annotations

COMMAND = "validate-config"


def register(sub):
    p = sub.add_parser(COMMAND, help="check a config file and report the first mistake")
    p.add_argument("config", nargs="+", help="YAML config file(s)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._common import open_config
    from ..evaluate import workspace_of

    for path in args.config:
        cfg = open_config(path)
        ws = workspace_of(cfg)
        free = ", ".join(v.name for v in cfg.free_variables) or "none"
        print(f"{path}: ok ({cfg.mechanism}; {len(cfg.designs)} designs; free variables: {free}; "
              f"indices: {', '.join(cfg.indices)}; workspace {ws.n} points)")
    return 0
