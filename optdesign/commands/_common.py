"""Helpers shared by the subcommands."""
from __future__ import annotations

import math
from typing import Sequence

from ..config import Config, load_config
from ..cli import UsageError

PACKAGED_PAPER_CONFIG = "p4s_paper.yaml"


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


def fmt(x: float, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    ax = abs(x)
    if ax != 0 and (ax < 1e-3 or ax >= 1e6):
        return f"{x:.{digits}e}"
    return f"{x:.{digits}f}"


def table(headers: Sequence[str], rows: Sequence[Sequence], align: str | None = None) -> str:
    """A plain-text table (also valid Markdown)."""
    cells = [[str(c) for c in r] for r in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) if cells else len(h) for i, h in enumerate(headers)]
    def line(vals):
        return "| " + " | ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(vals, widths))) + " |"
    sep = "|" + "|".join(("-" * (w + 2)) if i == 0 else ("-" * (w + 1) + ":") for i, w in enumerate(widths)) + "|"
    return "\n".join([line(headers), sep] + [line(r) for r in cells])
