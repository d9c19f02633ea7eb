"""The certificates of report.html: each reported design's status over the
continuous workspace (results.json["certificates"]), in the config's units."""
from __future__ import annotations

from ...units import pose_display
from ..certificates import refutation
from .figures import esc
from .rundata import RunData
from .tables import html_table

__all__ = ["certificates_html", "optimum_status_html"]

_CLASS = {"certified": "ok", "refuted": "bad", "unknown": "warn", "not_supported": "warn"}


def _status(c: dict) -> str:
    s = c["status"]
    if s == "refuted":
        return f"<b>refuted</b> ({refutation(c, gt='&gt;')})"
    if s == "unknown":
        return f"unknown ({100 * c['share_proved']:.1f} % of W proved)"
    return esc(s.replace("_", " "))


def _witness(run: RunData, c: dict) -> str:
    if c.get("witness") is None:
        return esc(c.get("reason", "")) if c["status"] == "not_supported" else ""
    parts = []
    for a, v in zip(c.get("axes") or (), c["witness"]):
        unit, f = pose_display(run.units, a)
        parts.append(f"{esc(a)}&nbsp;=&nbsp;{v * f:.6g}&nbsp;{esc(unit)}")
    return ", ".join(parts)


def optimum_status_html(run: RunData) -> str:
    c = (run.results.get("certificates") or {}).get("optimum")
    if not c:
        return ""
    return (f'<p class="cert {_CLASS.get(c["status"], "")}">Over the continuous workspace the optimum is '
            f'{_status(c)} (<a href="#certificates">certificates</a>).</p>')


def certificates_html(run: RunData) -> str:
    certs = run.results.get("certificates") or {}
    if not certs:
        return ""
    limit = next((c["limit"] for c in certs.values() if c.get("limit") is not None), None)
    bound = f"at most {limit:g}" if limit is not None else "within the singularity limit"
    rows = [[f"<code>{esc(k)}</code>", _status(c), str(int(c.get("boxes", 0))), _witness(run, c)]
            for k, c in certs.items()]
    note = ("<p class=note>Interval branch and bound over boxes of W: <i>certified</i> means every pose of the "
            f"continuous W is reachable and the condition number is {bound} there (and the stroke limits "
            "hold, when set); <i>refuted</i> gives a pose of W where the design breaks a constraint; "
            "<i>unknown</i> the share of W's volume proved within the budget. A design that is not certified "
            "holds its numbers at the samples of W only.</p>")
    return html_table(["design", "status over W", "boxes", "witness pose / detail"], rows, numeric_from=2,
                      cls="cert", text_cols=(3,)) + note
