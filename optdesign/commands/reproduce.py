"""optdesign reproduce [CONFIG]: the paper reproduction (the README's main job)."""
from __future__ import annotations

COMMAND = "reproduce"


def register(sub):
    p = sub.add_parser(COMMAND, help="reproduce the 3-P(4S) paper (default: the embedded configs/p4s_paper.yaml)")
    p.add_argument("config", nargs="?", default=None, help="YAML config (default: embedded p4s_paper.yaml)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._common import open_config, table
    from .evaluate import comparison_rows
    from ..evaluate import evaluate_named, workspace_of

    cfg = open_config(args.config)
    ws = workspace_of(cfg)
    names = [n for n in ("before", "after") if n in cfg.designs] or list(cfg.designs)
    res = evaluate_named(cfg, names, ws)
    print(f"{cfg.source}: workspace {ws.describe()}")
    print(table(["design", "index", "mean", "min", "max", "paper", "rel. diff"], comparison_rows(cfg, res)))
    return 0
