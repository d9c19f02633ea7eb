"""Helpers shared by the subcommands."""
from __future__ import annotations

from typing import Sequence

from ..config import Config, load_config

PACKAGED_PAPER_CONFIG = "p4s_paper.yaml"


class UsageError(Exception):
    """A mistake in the command line (exit status 2, one line)."""


def add_config_arg(p, optional: bool = False):
    if optional:
        p.add_argument("config", nargs="?", default=None,
                       help="YAML config (default: the embedded configs/p4s_paper.yaml)")
    else:
        p.add_argument("config", help="YAML config file")


def open_config(path: str | None) -> Config:
    """Load a config; ``None`` loads the embedded paper config."""
    if path is None:
        from importlib.resources import as_file, files

        with as_file(files("optdesign") / "data" / PACKAGED_PAPER_CONFIG) as p:
            cfg = load_config(p)
        cfg.source = f"configs/{PACKAGED_PAPER_CONFIG}"
        return cfg
    return load_config(path)


def design_names(cfg: Config, requested: Sequence[str] | None) -> list[str]:
    if not requested:
        return [n for n in cfg.designs if n != "initial" or len(cfg.designs) == 1]
    for n in requested:
        if n not in cfg.designs:
            raise UsageError(f"{cfg.source}: designs: no design named {n!r}; the config has {', '.join(cfg.designs)}")
    return list(requested)
