"""optdesign reproduce [CONFIG]: the paper's whole optimization (the README's main job)."""
from __future__ import annotations

COMMAND = "reproduce"


def register(sub):
    p = sub.add_parser(COMMAND, help="reproduce the 3-P(4S) paper's optimization (default: the embedded configs/p4s_paper.yaml)")
    p.add_argument("config", nargs="?", default=None, help="YAML config (default: embedded p4s_paper.yaml)")
    p.add_argument("--seed", type=int, default=None, help="random seed (default: the config's optimizer.seed)")
    p.add_argument("--out", default="runs", metavar="DIR", help="parent folder of run folders (default: runs)")
    p.add_argument("--no-pareto", action="store_true", help="skip the NSGA-II/III Pareto runs")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--jobs", type=int, default=None, metavar="N",
                   help="processes running the GA stages at once (default: the CPUs available); results do not depend on it")
    p.set_defaults(func=run, resume=None, name=None)


def run(args) -> int:
    from ._common import open_config
    from .run import execute
    from ..report.md import index_table, parameter_table, reference_table
    from ..tables import print_text

    cfg = open_config(args.config)

    def show(res):
        r = res.results
        print()
        print("Table 3 (design parameters):" if cfg.reference else "Design parameters:")
        print_text(parameter_table(cfg.units(), r))
        print()
        print("Global indices (means over W):")
        print_text(index_table(cfg.units(), r))
        ref = reference_table(cfg.units(), r)
        if ref:
            print()
            print("Beside the paper's values (the config's reference):")
            print_text(ref)
        if r.get("integrals"):
            from ..report.integrals import integral_table

            keys = ["optimum"] + list(r.get("designs") or {})
            print()
            print(f"The integral over W (adaptive cubature, relative tolerance {r['integrals']['tolerance']:g}) "
                  "beside the config's quadrature:")
            print_text(integral_table(cfg.units(), r, keys))
        ref_f = [f"{v['objective']} ({n})" for n, v in (r.get("reference") or {}).items()
                 if isinstance(v, dict) and isinstance(v.get("objective"), (int, float))]
        print()
        f = r["objective"]
        print(f"weighted-sum objective f at the optimum: {'0 (to round-off)' if abs(f) < 1e-12 else f'{f:.4f}'}"
              + (f" (paper f_min = {', '.join(ref_f)}; not comparable without the paper's bounds, see docs/reproduction.md)"
                 if ref_f else ""))
        print(f"full report: {res.folder.path / 'results.md'} and {res.folder.path / 'report.html'}")

    return execute(args, after=show, cfg=cfg)
