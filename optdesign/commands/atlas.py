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
    from ..config import ConfigError
    from ..evaluate import DesignModel
    from ..report.atlas import atlas_size, write_atlas
    from ..names import OutsideRoot
    from ..workspace import WorkspaceTooLarge

    if args.resolution is not None and not 2 <= args.resolution <= 2000:
        raise UsageError(f"--resolution: expected an integer in [2, 2000], got {args.resolution}")
    check_out_root(args.out)
    cfg = open_config(args.config)
    names = design_names(cfg, args.design)
    model, units = DesignModel.from_config(cfg), cfg.units()     # what an atlas reads of the config
    try:                                       # its size is checked before anything is written
        atlas_size(cfg.workspace, model.mechanism.pose_names, args.resolution)
    except WorkspaceTooLarge as exc:
        raise ConfigError(cfg.source, "workspace" if args.resolution is None else "--resolution", str(exc)) from None
    make_out_root(args.out)
    for name in names:
        try:
            out = write_atlas(model, units, cfg.workspace, cfg.design(name), Path(args.out) / f"{cfg.name}-{name}",
                              args.resolution, plots=not args.no_plots, root=args.out, config_name=cfg.name,
                              design_name=f"the {name} design")
        except OutsideRoot as exc:
            raise UsageError(f"--out: {exc}") from None
        print(f"wrote {out}/ (local_indices.csv" + ("" if args.no_plots else ", " + ", ".join(f"{k}.png" for k in cfg.indices)) + ")")
    return 0
