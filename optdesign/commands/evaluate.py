"""optdesign evaluate CONFIG [--design NAME] [--json]: global indices of named designs."""
from __future__ import annotations

import json

COMMAND = "evaluate"


def register(sub):
    p = sub.add_parser(COMMAND, help="global indices (mean ± error estimate, min, max over W) of the config's designs")
    p.add_argument("config", help="YAML config file")
    p.add_argument("--design", action="append", metavar="NAME",
                   help="a named design of the config (repeatable; default: all)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    p.set_defaults(func=run)


def comparison_rows(cfg, results: dict) -> list[list[str]]:
    """Rows: design, index, mean, ± its error estimate (the index's units),
    reference value, relative difference."""
    from ..tables import fmt, fmt_g

    rows = []
    for dname, rec in results.items():
        ref = cfg.reference.get(dname, {})
        for iname in cfg.indices:
            v = rec[iname]
            paper = ref.get(iname)
            rel = (v["mean"] - paper) / paper if paper else None
            err = rec.get("global_indices_error", {}).get(iname)
            status = rec.get("global_indices_status", {}).get(iname)   # sampling: adaptive
            mean = "unbounded" if status == "unbounded" else fmt(v["mean"])
            e = "inf" if status == "unbounded" else (fmt_g(err, 2) if err is not None else "-")
            if status == "not_converged":
                e += " (nc)"
            rows.append([dname, iname, mean, e,
                         fmt(paper) if paper is not None else "-",
                         f"{100 * rel:+.2f}%" if rel is not None else "-"])
    return rows


def spread_rows(cfg, results: dict) -> list[list[str]]:
    """Rows: design, index, min, max and standard deviation over the points of W."""
    from ..tables import fmt

    return [[d, k, fmt(rec[k]["min"]), fmt(rec[k]["max"]), fmt(rec[k]["std"])]
            for d, rec in results.items() for k in cfg.indices]


def run(args) -> int:
    from ._common import design_names, open_config
    from ..tables import print_table
    from ..config import ConfigError
    from ..evaluate import error_method, evaluate_named, workspace_of
    from ._common import unreachable_design, unreachable_message

    cfg = open_config(args.config)
    names = design_names(cfg, args.design)
    ws = workspace_of(cfg)
    bad = unreachable_design(cfg, names, ws)
    if bad is not None:   # every index would be '-': an error, not a table of dashes
        key = f"designs.{bad}" if bad in (cfg.raw.get("designs") or {}) else "design_variables"
        raise ConfigError(cfg.source, key, unreachable_message(cfg, bad))
    from contextlib import nullcontext

    from .. import fast

    # a small evaluation takes the numpy path (the reference): loading the
    # compiled engine would cost more than it saves (fast.SMALL_WORK)
    with nullcontext() if fast.worth_compiling(len(names) * ws.n) else fast.disabled():
        res = evaluate_named(cfg, names, ws)
    if args.json:
        out = {"config": cfg.source, "mechanism": cfg.mechanism, "workspace_points": ws.n,
               "error_method": error_method(ws), "designs": {}}
        for n, rec in res.items():
            d = {k: rec[k] for k in cfg.indices}
            d["global_indices_error"] = {k: rec["global_indices_error"][k] for k in cfg.indices}
            if "global_indices_status" in rec:
                d["global_indices_status"] = rec["global_indices_status"]
            d["reachable_fraction"] = rec["reachable_fraction"]
            d["parameters"] = cfg.design(n)
            if n in cfg.reference:
                d["paper"] = cfg.reference[n]
            out["designs"][n] = d
        print(json.dumps(out, indent=2, allow_nan=True))
        return 0
    from ..units import index_label

    from ..units import pose_display

    units = cfg.units()
    shown = {a: pose_display(units, a) for a in ws.names}   # the workspace in the config's units, each named
    print(f"{cfg.source}: {cfg.mechanism}, workspace {ws.describe(shown)}")
    print(f"±: error estimate of the mean against the integral over W: {error_method(ws)}")
    if ws.spec.sampling == "adaptive":
        print("unbounded: the integrand is not bounded on W (a singularity inside W); "
              "(nc): the tolerance was not reached within max_points")
    headers = ["design", "index", "mean", "±", "reference", "rel. diff"]
    rows = comparison_rows(cfg, res)
    for r in rows:   # the index with its unit (SI)
        r[1] = index_label(units, r[1])
    if not cfg.reference:   # no reference values: no columns for them
        keep = [i for i, h in enumerate(headers) if h not in ("reference", "rel. diff")]
        headers, rows = [headers[i] for i in keep], [[r[i] for i in keep] for r in rows]
    print_table(headers, rows)
    print()
    spread = spread_rows(cfg, res)
    for r in spread:
        r[1] = index_label(units, r[1])
    print_table(["design", "index", "min over W", "max over W", "std over W"], spread)
    print()
    print_table(["design", "reachable fraction"], [[n, f"{r['reachable_fraction']:.4f}"] for n, r in res.items()])
    return 0
