"""optdesign validate-config FILE: check a config alone."""
from __future__ import annotations

COMMAND = "validate-config"


def register(sub):
    p = sub.add_parser(COMMAND, help="check a config file and report the first mistake")
    p.add_argument("config", nargs="+", help="YAML config file(s)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._common import open_config
    from ..config import ConfigError
    from ..evaluate import workspace_of
    from ._common import unreachable_design, unreachable_message

    from ..batch import is_batch_file, load_batch_file

    for path in args.config:
        if is_batch_file(path):
            bf = load_batch_file(path)
            print(f"{path}: ok (batch file; {len(bf.combinations)} configs"
                  + (f" x {len(bf.seeds)} seeds" if bf.seeds else "") + ")")
            continue
        cfg = open_config(path)
        ws = workspace_of(cfg)
        if "initial" in cfg.designs and unreachable_design(cfg, ["initial"], ws) is not None:
            raise ConfigError(cfg.source, "design_variables", unreachable_message(cfg, "initial"))
        free = ", ".join(v.name for v in cfg.free_variables) or "none"
        print(f"{path}: ok ({cfg.mechanism}; {len(cfg.designs)} designs; free variables: {free}; "
              f"indices: {', '.join(cfg.indices)}; workspace {ws.n} points)")
    return 0
