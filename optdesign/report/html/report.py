"""``report.html`` of one finished run folder, from what is on disk."""
from __future__ import annotations

import os
from pathlib import Path

from ...io import atomic_write_text
from ...runs import RunFolderError
from .atlas import DEFAULT_RESOLUTION, atlas_map
from .figures import atlas_figures, convergence_figures, esc, fmt, front_parcoords, front_splom, front_title
from .page import Page, plotly_js_version
from .rundata import RunData, load_run
from .views import COPY_SCRIPT, alternatives, copy_table, mechanism_figure, workspace_figure
from .certificates import certificates_html, optimum_status_html
from .tables import (index_table, manifest_table, normalization_table, objective_text, optimum_table,
                     placement_table, reference_table)
from ...units import index_unit, variable_unit

__all__ = ["build_report", "write_report_html", "REPORT_NAME"]

REPORT_NAME = "report.html"


def _header(run: RunData) -> str:
    r, m = run.results, run.manifest
    desc = run.description
    bits = [f"mechanism <code>{esc(run.mechanism)}</code>", f"seed {esc(r.get('seed', m.get('seed')))}",
            f"{esc(r.get('workspace_points', '?'))} workspace points",
            f"{esc(m.get('evaluations', r.get('evaluations', '?')))} design evaluations",
            f"wall time {esc(m.get('wall_time_s', '?'))} s"]
    if m.get("end_time"):
        bits.append(f"finished {esc(m['end_time'])}")
    opt = ", ".join(f"{esc(k)} = {fmt(dv.display(r['optimum'][k]), 4)} {esc(variable_unit(run.units, k))}"
                    for k, dv in run.units.variables.items() if dv.free)
    idx = ", ".join(f"{esc(k)} = {fmt(v, 4)}" + (f" {esc(u)}" if (u := index_unit(run.units, k)) and u != "–" else "")
                    for k, v in r["global_indices"].items() if k in run.units.indices)
    return ("<header>"
            f"<h1>{esc(run.name)}: optimization report</h1>"
            + (f"<p>{esc(desc)}</p>" if isinstance(desc, str) else "")
            + f"<p>{' · '.join(bits)}</p>"
            f"<p class=key><b>Optimum</b> (weighted sum): {opt or 'no free variable'}<br>"
            f"<b>Global indices</b> (means over W): {idx}</p>"
            f"<p class=note>Run folder <code>{esc(run.path.name)}</code>. Design parameters are in the config's units; "
            "indices in SI with their unit in brackets ([–]: dimensionless). Objectives are shown in their own sense: "
            "a maximized index as itself.</p>"
            "</header>")


def _normalization_text(run: RunData) -> str:
    r = run.results
    lines = [
        "<p class=note>The weighted-sum objective scales each index to [0, 1] between its minimum and maximum over "
        "the design bounds (found by the single-objective stages), flipping a maximized index so that 0 is always its "
        "best value, and sums the scaled terms with the weights: f = Σ w<sub>k</sub> t<sub>k</sub>.</p>",
        f"<p>f at the optimum: <b>{objective_text(r.get('objective'))}</b>."]
    for n, d in r["designs"].items():
        if isinstance(d, dict) and "objective" in d:
            lines.append(f" The {esc(n)} design (config) scores {objective_text(d['objective'])}.")
    lines.append("</p>")
    scores = [r.get("objective")] + [d.get("objective") for d in r["designs"].values() if isinstance(d, dict)]
    if any(isinstance(x, (int, float)) and x < -1e-9 for x in scores):
        lines.append("<p class=note><b>f below 0:</b> a design beats the single-objective stages' best value of an "
                     "index, so those stages did not find the index's true extreme over the bounds (a short run?); "
                     "the scaling above is then only approximate.</p>")
    if run.reference:
        ref_f = run.reference.get("after", {}).get("objective") if isinstance(run.reference.get("after"), dict) else None
        extra = []
        if ref_f is not None:
            extra.append(f"reference f at the after design: {fmt(ref_f)}")
        if isinstance(r.get("objective_paper_literal"), (int, float)):
            extra.append("the paper's literal eq. 38 (every term as if minimized) at the optimum: "
                         f"{fmt(r['objective_paper_literal'], 4)}")
        pl = r.get("paper_literal_optimum")
        if isinstance(pl, dict) and isinstance(pl.get("design"), dict):
            parts = ", ".join(f"{esc(k)} = {fmt(dv.display(pl['design'][k]), 4)} {esc(variable_unit(run.units, k))}"
                              for k, dv in run.units.variables.items() if dv.free and k in pl["design"])
            extra.append(f"minimizing the literal eq. 38 instead gives {parts} (objective {fmt(pl.get('objective'), 4)})")
        if extra:
            lines.append("<p class=note>" + "; ".join(extra) + ".</p>")
    return "".join(lines)


def _front_section(page: Page, run: RunData) -> None:
    pareto = run.results.get("pareto", {}) if isinstance(run.results.get("pareto"), dict) else {}
    for name, front in run.fronts.items():
        if front.size == 0:
            continue
        p = pareto.get(name, {}) if isinstance(pareto.get(name), dict) else {}
        page.html(f"<h3>{front_title(front)}</h3>")
        facts = []
        if isinstance(p.get("hypervolume"), (int, float)):
            facts.append(f"hypervolume {fmt(p['hypervolume'], 4)} (normalized objectives, reference point 1.1 in each)")
        if isinstance(p.get("front_spread"), (int, float)):
            facts.append(f"spread {fmt(p['front_spread'], 4)}")
        if facts:
            page.html("<p class=note>" + "; ".join(facts) + ".</p>")
        page.html(placement_table(run, name))
        page.html("<p class=note>Additive epsilon: how much the front must be worsened in every normalized objective "
                  "until it no longer dominates the design; negative: some front design beats it in every objective "
                  "by at least that much. Hover a point for its parameters and indices; drag to select.</p>")
        page.add_figure(front_splom(run, front))
        page.add_figure(front_parcoords(run, front))
        page.html(copy_table(run, front))


def build_report(run: RunData, atlas_resolution: int = DEFAULT_RESOLUTION) -> str:
    page = Page(f"{run.name}: optimization report")
    page.section("optimum", "Optimum")
    page.html(optimum_table(run))
    page.html(optimum_status_html(run))
    page.section("indices", "Global indices")
    page.html(index_table(run))
    page.html("<p class=note>Means of the local indices over the workspace W (min and max over W at the optimum). "
              "Improvement: the named design's value divided by the optimum's for an index to be minimized, the "
              "optimum's divided by the named design's for one to be maximized."
              + (f" ±: the error estimate of the optimum's mean against the integral over W "
                 f"({esc(run.results['error_method'])})." if run.results.get("error_method") else "")
              + "</p>")
    ref = reference_table(run)
    if ref:
        page.html("<h3>Beside the reference values</h3>")
        page.html(ref)
        page.html("<p class=note>Reference values: the config's <code>reference:</code> section; "
                  "rel. diff = (ours - reference) / reference.</p>")
        if run.results.get("reference_note"):
            page.html(f"<p>{esc(run.results['reference_note'])}</p>")
    page.section("normalization", "Normalization")
    page.html(normalization_table(run))
    page.html(_normalization_text(run))
    if run.results.get("certificates"):
        page.section("certificates", "Certificates over the continuous workspace")
        page.html(certificates_html(run))
    conv = convergence_figures(run)
    if conv:
        page.section("convergence", "Convergence")
        for f in conv:
            page.add_figure(f)
    if any(f.size for f in run.fronts.values()):
        page.section("fronts", "Pareto fronts")
        _front_section(page, run)
    _views_section(page, run)
    page.section("atlas", "Atlases")
    amap = atlas_map(run.model, run.units, run.workspace, run.results["optimum"], atlas_resolution)
    if amap is None:
        page.html("<p>The workspace is a single pose: there is no map to draw.</p>")
    else:
        shape = {"disc": "the cylinder's disc, its boundary drawn", "rectangle": "the box",
                 "segment": "the segment"}[amap.shape]
        page.html(f"<p class=note>Local indices of the weighted-sum optimum on a {len(amap.coords[0])}-point-per-axis "
                  f"grid of the atlas's own (not the optimization's sample), over {shape}"
                  + (f"; slice through the centre of the third axis: {esc(amap.cut)}" if amap.cut else "")
                  + (f"; the workspace holds {esc(amap.held)}" if amap.held else "") + ".</p>")
        figs = atlas_figures(run, amap)
        page.html('<div class="grid2">' + "".join(page.figure(f) for f in figs) + "</div>")
    page.section("manifest", "Run")
    page.html(manifest_table(run))
    return page.render(_header(run), _footer(page))


def _views_section(page: Page, run: RunData) -> None:
    """The mechanism in 3-D (optimum and the best Pareto alternatives) and W in 3-D."""
    page.section("mechanism", "The mechanism in 3-D")
    page.html(f"<script>{COPY_SCRIPT}</script>")   # the copy buttons of the fronts' tables
    fig = mechanism_figure(run, run.results["optimum"], "The weighted-sum optimum")
    if fig is None:
        page.html(f"<p>The mechanism <code>{esc(run.mechanism)}</code> has no drawing.</p>")
        return
    page.html("<p class=note>Drawn from the mechanism's own inverse kinematics at the centre of W, the corners of its "
              "box and the sample pose where the Jacobian is worst conditioned (the slider picks the pose). Base: grey, "
              "each leg's actuated link (rail to slider, crank, strut): green, rods: blue, joints: red, platform: "
              "orange; lengths in m.</p>")
    page.add_figure(fig)
    alts = [(t, d) for t, d in alternatives(run)]
    if alts:
        page.html("<h3>The best Pareto alternatives</h3>")
        figs = [mechanism_figure(run, d, t, height=480) for t, d in alts]
        page.html('<div class="grid2">' + "".join(page.figure(f) for f in figs if f is not None) + "</div>")
    wfig = workspace_figure(run, run.results["optimum"])
    if wfig is not None:
        page.add_figure(wfig)


def _footer(page: Page) -> str:
    return (f"Written by optdesign from the run folder's files. Self-contained: plotly.js {esc(plotly_js_version())} "
            f"is embedded once (about 4.8 MB of the page); {page.figures} figures; nothing is loaded from the "
            "network.")


def _target(folder: Path) -> Path:
    """report.html inside the resolved run folder (a symlink named report.html is
    replaced, never followed)."""
    root = folder.resolve()
    out = root / REPORT_NAME
    if out.parent != root:  # pragma: no cover - cannot happen with a plain name
        raise RunFolderError(f"{out}: outside the run folder {root}")
    return out


def write_report_html(folder_path: str | os.PathLike, atlas_resolution: int = DEFAULT_RESOLUTION) -> Path:
    """Write ``report.html`` into a finished run folder and return its path.
    Raises RunFolderError (one line) for a folder that is not a finished run."""
    run = load_run(folder_path)
    try:
        text = build_report(run, atlas_resolution)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:  # a hand-edited or damaged folder
        raise RunFolderError(f"{run.path}: unexpected content in the run's files ({type(exc).__name__}: {exc})") from None
    out = _target(run.path)
    atomic_write_text(out, text)
    return out
