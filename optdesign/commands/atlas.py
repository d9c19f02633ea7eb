"""optdesign atlas CONFIG --design NAME: local index maps over a workspace plane."""
from __future__ import annotations

from pathlib import Path

COMMAND = "atlas"


def register(sub):
    p = sub.add_parser(COMMAND, help="write local index maps (CSV + contour PNGs) to indices/<config>-<design>/")
    p.add_argument("config", help="YAML config file")
    p.add_argument("--design", action="append", metavar="NAME", help="named design (repeatable; default: all)")
    p.add_argument("--resolution", type=int, default=None, metavar="N",
                   help="grid points per plotted axis (default: 81; the atlas has a grid of its own)")
    p.add_argument("--out", default="indices", metavar="DIR", help="parent folder (default: indices)")
    p.add_argument("--no-plots", action="store_true", help="write the CSV only")
    p.set_defaults(func=run)


def run(args) -> int:
    from ._common import UsageError, check_out_root, design_names, make_out_root, open_config
    from ..report.atlas import check_atlas_size, write_atlas
    from ..names import OutsideRoot

    if args.resolution is not None and not 2 <= args.resolution <= 2000:
        raise UsageError(f"--resolution: expected an integer in [2, 2000], got {args.resolution}")
    check_out_root(args.out)
    cfg = open_config(args.config)
    names = design_names(cfg, args.design)
    check_atlas_size(cfg, args.resolution)     # its size is checked before anything is written
    make_out_root(args.out)
    for name in names:
        try:
            out = write_atlas(cfg, name, Path(args.out) / f"{cfg.name}-{name}", args.resolution,
                              plots=not args.no_plots, root=args.out)
        except OutsideRoot as exc:
            raise UsageError(f"--out: {exc}") from None
        print(f"wrote {out}/ (local_indices.csv" + ("" if args.no_plots else ", " + ", ".join(f"{k}.png" for k in cfg.indices)) + ")")
    return 0
