"""The certificates section of results.md: for each reported design its status
over the continuous workspace (certified / refuted with the witness pose /
unknown with the share of W proved / not supported), in the config's units."""
from __future__ import annotations

from ..units import Units

__all__ = ["certificate_lines", "refutation", "status_text"]


def _pose_text(units: Units, names, pose) -> str:
    from ..units import pose_display

    parts = []
    for a, v in zip(names, pose):
        unit, f = pose_display(units, a)
        parts.append(f"{a} = {v * f:.6g} {unit}")
    return ", ".join(parts)


def refutation(cert: dict, gt: str = ">") -> str:
    """Why a refuted certificate failed, in words (``gt``: how to write ">")."""
    v = cert.get("value")
    return {"unreachable": "a pose of W is unreachable", "stroke": "a stroke limit is broken"}.get(
        cert.get("reason"), f"cond {v:.4g} {gt} {cert['limit']:.4g}" if v is not None and cert.get("limit") is not None
        else "singular")


def status_text(cert: dict | None) -> str:
    """A short status for a table cell or a line."""
    if not cert:
        return "not certified"
    s = cert["status"]
    if s == "certified":
        return "certified"
    if s == "refuted":
        return f"REFUTED ({refutation(cert)})"
    if s == "unknown":
        return f"unknown ({100 * cert['share_proved']:.1f} % of W proved)"
    return "not supported"


def certificate_lines(units: Units, results: dict) -> list[str]:
    """Markdown lines (empty when the results have no certificates)."""
    certs = results.get("certificates")
    if not certs:
        return []
    limit = next((c["limit"] for c in certs.values() if c.get("limit") is not None), None)
    bound = f"at most {limit:g}" if limit is not None else "within the singularity limit"
    out = ["", "## Certificates over the continuous workspace", "",
           "Interval branch and bound over boxes of W (docs/certificates.md): `certified` means every pose of W "
           f"is reachable and the condition number is {bound} there (and the stroke limits hold, when set), "
           "proved for the whole continuum, not only at the samples; `refuted` gives a pose of W where the design "
           "breaks a constraint; `unknown` the share of W's volume proved within the budget.", ""]
    rows = []
    for key, c in certs.items():
        detail = ""
        if c["status"] == "refuted" and c.get("witness") is not None:
            detail = "witness " + _pose_text(units, c.get("axes") or (), c["witness"])
        elif c["status"] == "not_supported":
            detail = c.get("reason", "")
        rows.append(f"| {key} | {status_text(c)} | {c.get('boxes', 0)} | {detail} |")
    out += ["| design | status | boxes | detail |", "|---|---|---|---|", *rows, ""]
    bad = [k for k, c in certs.items() if c["status"] != "certified"]
    if bad:
        out.append(f"- Not certified: {', '.join(bad)}. Their numbers above hold at the samples of W only.")
    else:
        out.append("- Every reported design is certified.")
    return out
