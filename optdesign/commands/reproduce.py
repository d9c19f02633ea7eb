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
    from ..optimize.report import index_table, parameter_table

    cfg = open_config(args.config)

    def show(res):
        r = res.results
        print()
        print("Table 3 (design parameters):")
        print(parameter_table(cfg, r))
        print()
        print("Global indices beside the paper's:")
        print(index_table(cfg, r))
        paper_f = r.get("reference", {}).get("after", {}).get("objective")
        print()
        print(f"weighted-sum objective at our optimum: {r['objective']:.4f}"
              + (f" (paper f_min = {paper_f}; not comparable without the paper's bounds, see docs/reproduction.md)" if paper_f else ""))
        print(f"full report: {res.folder.path / 'results.md'}")

    return execute(args, after=show, cfg=cfg)
