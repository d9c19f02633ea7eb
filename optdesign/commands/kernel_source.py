"""optdesign kernel-source CONFIG [--out FILE]: the generated code of a
described mechanism's compiled kernel, as readable Python."""
from __future__ import annotations

COMMAND = "kernel-source"

#: how the written source starts (an existing --out file must start so, or it is not overwritten)
HEADER = "# The generated routines of"


def register(sub):
    p = sub.add_parser(COMMAND, help="print the generated kernel code of a described mechanism as Python")
    p.add_argument("config", help="YAML config file (its mechanism: a description)")
    p.add_argument("--out", default=None, metavar="FILE", help="write it to FILE (*.py) instead of printing it")
    p.set_defaults(func=run)


def _check_target(path: str) -> None:
    """FILE: a .py name in an existing folder; an existing FILE must be a regular
    file (never a link) that holds source this command wrote."""
    import os
    from pathlib import Path

    from ..config.reader import plain
    from ._common import UsageError, check_out_file

    check_out_file(path, "--out", suffixes=(".py",), kind="Python")
    p = Path(path)
    if p.exists() and p.stat().st_size:
        fd = os.open(p, os.O_RDONLY | os.O_NOFOLLOW | getattr(os, "O_NONBLOCK", 0))
        try:
            head = os.read(fd, len(HEADER))
        finally:
            os.close(fd)
        if head != HEADER.encode():
            raise UsageError(f"--out: {plain(path)} exists and was not written by kernel-source; refusing to overwrite it")


def run(args) -> int:
    from ..evaluate import build
    from ._common import UsageError, open_config

    if args.out is not None:
        _check_target(args.out)
    cfg = open_config(args.config)
    design = "initial" if "initial" in cfg.designs else next(iter(cfg.designs))
    mech = build(cfg, design)
    name = cfg.mechanism.split("@")[0]
    src = mech.kernel_source(f"the mechanism {name} of {cfg.source}")
    if src is None:
        if getattr(getattr(mech, "description", None), "is_chain", False):
            raise UsageError(f"{cfg.source}: mechanism: {name} has no generated kernel (a description with chain "
                             "legs runs on the engine's chain kernel, one code for every chain shape: "
                             "optdesign/engine/chain_kernels.py, docs/lower-mobility.md)")
        raise UsageError(f"{cfg.source}: mechanism: {name} has no generated kernel (kernel-source applies to "
                         "mechanisms given as a description; this one's compiled path, if any, is hand-written)")
    if args.out is None:
        print(src, end="")
        return 0
    from ..io import atomic_write_text

    atomic_write_text(args.out, src)
    print(f"wrote {args.out}")
    return 0
