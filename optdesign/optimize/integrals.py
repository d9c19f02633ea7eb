"""The integral over W of every global index of the designs a run reports
(``results.json["integrals"]``), beside the config's own quadrature.

A fixed rule (the paper's 11 x 11 grid) reproduces the paper's numbers, but
its mean is not the integral of eq. 29, and a design singular between its
points gets a finite mean there.  For the optimum, each named design and each
normalization extreme, the integral by adaptive cubature to a relative
``TOLERANCE`` (:mod:`optdesign.cubature`) is recorded beside the config's
mean and its error estimate; an index whose integrand is unbounded on W is
recorded ``unbounded``, never as a finite mean.  A config whose sampling is
already adaptive gets no second record (its global indices are the integrals).
"""
from __future__ import annotations

from ..evaluate import adaptive_workspace, error_method, evaluate, integral_records

__all__ = ["integrals_of_reported", "TOLERANCE", "MAX_POINTS", "integral_lines", "integral_table"]

#: relative tolerance and node budget (per design) of the recorded integrals
TOLERANCE, MAX_POINTS = 1e-4, 200_000


def _designs(results: dict, parameters) -> dict[str, dict]:
    keep = lambda d: {k: float(d[k]) for k in parameters if k in d}  # noqa: E731
    out = {"optimum": keep(results["optimum"])}
    for n, rec in (results.get("designs") or {}).items():
        out[n] = keep(rec["parameters"])
    for k, rec in (results.get("normalization") or {}).items():
        for b in ("min", "max"):
            d = rec.get(f"{b}_design")
            if isinstance(d, dict):
                out[f"{k}.{b}"] = keep(d)
    return out


def integrals_of_reported(cfg, results: dict, ws) -> dict | None:
    """``{"method", "tolerance", "max_points", "quadrature", "quadrature_error_method", "designs": {key: {"design",
    "quadrature": {index: {"mean", "error"}}, "integral": {index: {"mean", "error", "status", "max"}},
    "reachable_fraction", "points"}}}``; None when the config's sampling is adaptive."""
    if ws.spec.sampling == "adaptive":
        return None
    designs = _designs(results, {k: dv.value for k, dv in cfg.design_variables.items()})
    full = [{**{k: dv.value for k, dv in cfg.design_variables.items()}, **d} for d in designs.values()]
    ev = evaluate(cfg, full, ws)
    recs = integral_records(cfg, full, TOLERANCE, MAX_POINTS)
    out = {}
    for j, (key, d) in enumerate(designs.items()):
        rec = recs[j]
        out[key] = {"design": d,
                    "quadrature": {k: {"mean": float(ev.summary[k]["mean"][j]), "error": float(ev.error[k][j])}
                                   for k in cfg.indices},
                    "integral": {k: rec[k] for k in cfg.indices},
                    "reachable_fraction": rec["reachable_fraction"], "points": rec["points"]}
    return {"method": error_method(adaptive_workspace(cfg, TOLERANCE, MAX_POINTS)), "tolerance": TOLERANCE,
            "max_points": MAX_POINTS, "quadrature": ws.describe(), "quadrature_error_method": error_method(ws),
            "designs": out}


def _cell(v, e) -> str:
    from ..tables import fmt_g

    return f"{fmt_g(v, 6)} ± {fmt_g(e, 2)}" if e is not None and e == e else fmt_g(v, 6)


def integral_table(cfg, results: dict, keys=None) -> str:
    """The Markdown table of ``results["integrals"]`` (the designs of ``keys``, default all)."""
    rec = results["integrals"]
    rows = ["| design | index | quadrature ± error | integral ± error | status |", "|---|---|---|---|---|"]
    for key, r in rec["designs"].items():
        if keys is not None and key not in keys:
            continue
        for k in cfg.indices:
            q, i = r["quadrature"][k], r["integral"][k]
            val = "unbounded" if i["status"] == "unbounded" else _cell(i["mean"], i["error"])
            rows.append(f"| {key} | {k} | {_cell(q['mean'], q['error'])} | {val} | {i['status'].replace('_', ' ')} |")
    return "\n".join(rows)


def integral_lines(cfg, results: dict) -> list[str]:
    """The results.md section (empty without ``integrals``)."""
    rec = results.get("integrals")
    if not rec:
        return []
    out = ["", "## Integrals over W beside the config's quadrature", "",
           f"The config's quadrature ({rec['quadrature']}) with its error estimate "
           f"({rec['quadrature_error_method']}), beside the integral mean over W by adaptive cubature to a relative "
           f"tolerance {rec['tolerance']:g} ({rec['method']}; at most {rec['max_points']:,} nodes per design). "
           "`unbounded`: the integrand is not bounded on W (the design is singular inside W): its mean over W is "
           "not finite, whatever a fixed rule gives; `not converged`: the tolerance was not reached within the "
           "budget (the value and its error are the last estimate).", "",
           integral_table(cfg, results)]
    bad = sorted({key for key, r in rec["designs"].items()
                  if any(r["integral"][k]["status"] == "unbounded" for k in cfg.indices)})
    if bad:
        out += ["", "Singular inside W (an unbounded integral): " + ", ".join(f"`{b}`" for b in bad)
                + ". Their quadrature values are artifacts of the points, not means over W."]
    return out
