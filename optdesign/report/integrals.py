"""The results.md section and the table of ``results.json["integrals"]`` (the
integral over W of the reported designs' indices beside the config's
quadrature; computed by :mod:`optdesign.optimize.integrals`)."""
from __future__ import annotations

__all__ = ["integral_lines", "integral_table"]


def _cell(v, e) -> str:
    from ..tables import fmt_g

    return f"{fmt_g(v, 6)} ± {fmt_g(e, 2)}" if e is not None and e == e else fmt_g(v, 6)


def integral_table(units, results: dict, keys=None) -> str:
    """The Markdown table of ``results["integrals"]`` (the designs of ``keys``, default all)."""
    from ..units import index_label

    rec = results["integrals"]
    rows = ["| design | index | quadrature ± error | integral ± error | status |", "|---|---|---|---|---|"]
    for key, r in rec["designs"].items():
        if keys is not None and key not in keys:
            continue
        for k in units.indices:
            q, i = r["quadrature"][k], r["integral"][k]
            val = "unbounded" if i["status"] == "unbounded" else _cell(i["mean"], i["error"])
            rows.append(f"| {key} | {index_label(units, k)} | {_cell(q['mean'], q['error'])} | {val} | {i['status'].replace('_', ' ')} |")
    return "\n".join(rows)


def integral_lines(units, results: dict) -> list[str]:
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
           integral_table(units, results)]
    bad = sorted({key for key, r in rec["designs"].items()
                  if any(r["integral"][k]["status"] == "unbounded" for k in units.indices)})
    if bad:
        out += ["", "Singular inside W (an unbounded integral): " + ", ".join(f"`{b}`" for b in bad)
                + ". Their quadrature values are artifacts of the points, not means over W."]
    return out
