"""The interactive HTML report (optdesign.report.html, `optdesign report`,
`optdesign compare`): what the page says, that it needs no network, that the
atlas follows the workspace's true shape, and that it renders in a real
browser (headless Chromium)."""
from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml

from cli_helpers import run_cli_in
from conftest import small_data

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).parent / "data"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


# --------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def noref_run(tmp_path_factory):
    """A small finished run of a config without `reference:` (with an extra
    objective, so that its fronts have a real trade-off)."""
    from optdesign.config import load_config
    from optdesign.runner import start_run

    d = yaml.safe_load((DATA / "p4s_tradeoff_small.yaml").read_text())
    d.pop("reference")
    d["name"] = "tradeoff_noref"
    d["optimizer"]["checkpoint_interval"] = 0
    base = tmp_path_factory.mktemp("noref")
    cfg_path = base / "tradeoff_noref.yaml"
    cfg_path.write_text(yaml.safe_dump(d, sort_keys=False))
    res = start_run(load_config(cfg_path), out=base / "runs", name="tradeoff_noref", exact_name=True, jobs=1)
    return res.folder.path


@pytest.fixture(scope="module")
def two_objective_run(tmp_path_factory):
    """A small finished run with two indices (its fronts are two-objective)."""
    from optdesign.config import load_config
    from optdesign.runner import start_run

    d = small_data()
    d.pop("reference")
    d["name"] = "two_objectives"
    d["indices"] = {"dynamic": {}, "stiffness": {}}
    d["optimizer"]["pareto"]["algorithms"] = ["nsga2"]
    base = tmp_path_factory.mktemp("two")
    cfg_path = base / "two_objectives.yaml"
    cfg_path.write_text(yaml.safe_dump(d, sort_keys=False))
    res = start_run(load_config(cfg_path), out=base / "runs", name="two_objectives", exact_name=True, jobs=1)
    return res.folder.path


@pytest.fixture(scope="module")
def noref_report(noref_run):
    from optdesign.report.html import write_report_html

    return write_report_html(noref_run)


@pytest.fixture(scope="module")
def repro_copy(tmp_path_factory):
    """The committed reproduction (a config with `reference:`, fronts of one design)."""
    dst = tmp_path_factory.mktemp("repro") / "p4s_paper-reproduction"
    shutil.copytree(ROOT / "runs" / "p4s_paper-reproduction", dst)
    return dst


# --------------------------------------------------------------------------- helpers
def _plotly_js() -> str:
    from plotly.offline import get_plotlyjs

    return get_plotlyjs()


def _figures(html: str) -> list[tuple[list, dict]]:
    """(data, layout) of every Plotly.newPlot call in the page, decoded from its JSON."""
    dec = json.JSONDecoder()
    out = []
    for m in re.finditer(r'Plotly\.newPlot\(\s*"[^"]+",\s*', html):
        data, end = dec.raw_decode(html, m.end())
        rest = html[end:].lstrip()
        assert rest.startswith(",")
        layout, _ = dec.raw_decode(rest[1:].lstrip())
        out.append((data, layout))
    return out


def _values(v) -> np.ndarray:
    """A plotly array: a list, or a typed array {dtype, bdata (base64)}."""
    if isinstance(v, dict) and "bdata" in v:
        return np.frombuffer(base64.b64decode(v["bdata"]), dtype=np.dtype(v["dtype"])).astype(float)
    return np.asarray(v, dtype=float)


def _strings(obj, key=None):
    """Every string a reader can see in a figure (plotly's enumerated settings
    such as xref: "paper" and the typed arrays' base64 left out)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            if k in ("xref", "yref", "bdata", "dtype", "type", "mode", "dragmode", "hovermode", "side", "anchor",
                     "coloring", "constrain", "symbol", "colorscale", "labelside"):
                continue
            yield from _strings(v, k)
    elif isinstance(obj, list):
        for v in obj:
            yield from _strings(v, key)
    elif isinstance(obj, str):
        yield obj


def _visible_text(html: str) -> str:
    """The page's text outside scripts and styles, plus every string in its figures."""
    body = re.sub(r"<script\b.*?</script>", " ", html, flags=re.S)
    body = re.sub(r"<style\b.*?</style>", " ", body, flags=re.S)
    figs = " ".join(s for data, layout in _figures(html) for s in _strings([data, layout]))
    return body + " " + figs


# --------------------------------------------------------------------------- content
@pytest.mark.slow
def test_self_contained_and_offline(noref_report):
    html = noref_report.read_text()
    js = _plotly_js()
    assert html.count(js) == 1, "plotly.js must be embedded exactly once"
    rest = html.replace(js, "")
    assert not re.search(r"<script[^>]*\bsrc\s*=", rest, re.I)
    assert not re.search(r"<link\b", rest, re.I)
    # nothing outside plotly.js's own code names a URL at all
    assert not re.search(r"https?://", rest, re.I)
    assert "default-src 'none'" in rest  # the content-security policy forbids any fetch
    size = len(html.encode())
    assert len(js) < size < len(js) + 1_500_000, f"page {size / 1e6:.1f} MB"


def test_no_paper_wording_without_reference(noref_report):
    text = _visible_text(noref_report.read_text()).lower()
    assert "paper" not in text
    assert "eq." not in text and not re.search(r"\beq\s*\d", text)
    assert "(reference)" not in text


def test_reference_columns_only_with_reference(repro_copy):
    from optdesign.report.html import write_report_html

    text = _visible_text(write_report_html(repro_copy).read_text())
    assert "before (reference)" in text and "rel. diff" in text
    assert "29.921" in text  # the reference value of the config, as given


def test_units_in_labels_and_degrees(noref_run, noref_report):
    html = noref_report.read_text()
    text = _visible_text(html)
    for lab in ("r_a [m]", "phi [deg]", "dynamic [kg]", "stiffness [N/m]", "isotropy [–]", "base_radius [m]",
                "x [m]", "y [m]", "generation"):
        assert lab in text, lab
    res = json.loads((noref_run / "results.json").read_text())
    deg = np.degrees(res["optimum"]["phi"])
    from optdesign.report.html.figures import fmt

    assert f"<b>{fmt(deg)}</b>" in html  # the optimum's phi in the table, in degrees
    assert 25 <= deg <= 45
    # every cartesian plot names its y axis, every figure an x axis; every colorbar has a title
    for data, layout in _figures(html):
        if not data or data[0].get("type") in ("splom", "parcoords"):
            continue
        if all(tr.get("type") in ("scatter3d", "mesh3d", "surface") for tr in data):  # a 3-D scene names its three axes
            scene = layout.get("scene", {})
            for a in ("xaxis", "yaxis", "zaxis"):
                assert ((scene.get(a) or {}).get("title") or {}).get("text"), (layout.get("title"), a)
            continue
        for tr in data:
            ax = layout.get("yaxis" + tr.get("yaxis", "y")[1:], {})
            assert (ax.get("title") or {}).get("text"), layout.get("title")
            if tr.get("type") == "contour":
                assert tr["colorbar"]["title"]["text"].endswith("]")
        assert any((v.get("title") or {}).get("text") for k, v in layout.items() if re.fullmatch(r"xaxis\d*", k))


def test_maximized_index_shown_as_itself(noref_run, noref_report):
    from optdesign.report.html.rundata import load_run

    run = load_run(noref_run)
    front = run.fronts["pareto_nsga2"]
    assert front.size >= 3
    # flipped back from the CSV's objective_-stiffness, equal to the raw index column
    np.testing.assert_allclose(front.objectives["stiffness"], front.indices["stiffness"], rtol=1e-12)
    assert np.all(front.objectives["stiffness"] > 0)
    html = noref_report.read_text()
    assert "-stiffness" not in _visible_text(html)
    sploms = [tr for data, _ in _figures(html) for tr in data if tr.get("type") == "splom"]
    dim = next(d for d in sploms[0]["dimensions"] if d["label"].startswith("stiffness"))
    np.testing.assert_allclose(np.sort(_values(dim["values"])), np.sort(front.indices["stiffness"]), rtol=1e-12)
    pc = [tr for data, _ in _figures(html) for tr in data if tr.get("type") == "parcoords"][0]
    dim = next(d for d in pc["dimensions"] if d["label"].startswith("stiffness"))
    assert np.all(_values(dim["values"]) > 0) and "max" in dim["label"]
    # hover text names the design's parameters in the config's units
    assert "phi = " in sploms[0]["text"][0] and " deg" in sploms[0]["text"][0]


def test_one_point_front_is_drawn_and_titled(repro_copy):
    from optdesign.report.html import write_report_html

    html = write_report_html(repro_copy).read_text()
    figs = _figures(html)
    sploms = [(data, layout) for data, layout in figs if data and data[0].get("type") == "splom"]
    assert len(sploms) == 2
    for data, layout in sploms:
        assert "collapsed to ONE design" in layout["title"]["text"]
        front = data[0]
        assert len(_values(front["dimensions"][0]["values"])) == 1
        assert front["marker"]["size"] >= 12


def test_atlas_clipped_to_the_cylinder_and_finer_than_the_sample():
    """The atlas of a cylinder workspace covers its disc only: its mean over the
    drawn points matches the global index over a quasi-random sample of the
    disc (a different sampling), while the bounding square's differs by 1-3 %."""
    from optdesign.config import parse_config
    from optdesign.evaluate import DesignModel, evaluate
    from optdesign.report.html.atlas import atlas_map

    d = small_data()
    d["workspace"] = {"type": "cylinder", "radius": 0.04, "axes": {"z": 0.57}, "sampling": "sobol", "points": 8192,
                      "seed": 5}
    cfg = parse_config(yaml.safe_dump(d))
    design = cfg.initial_design()
    m = atlas_map(DesignModel.from_config(cfg), cfg.units(), cfg.workspace, design, 81)
    assert m.shape == "disc" and m.outline is not None
    np.testing.assert_allclose(np.hypot(*m.outline), 0.04, rtol=1e-12)
    A, B = np.meshgrid(*m.coords)
    drawn = np.isfinite(m.values["dynamic"])
    assert np.all(np.hypot(A[drawn], B[drawn]) <= 0.04 * (1 + 1e-9))
    assert abs(drawn.sum() / drawn.size - np.pi / 4) < 0.02
    ev = evaluate(cfg, [design])
    for k in cfg.indices:
        g = ev.summary[k]["mean"][0]
        assert abs(np.nanmean(m.values[k]) / g - 1) < 1e-3, k
    square = dict(d, workspace={"type": "box", "axes": {"x": [-0.04, 0.04], "y": [-0.04, 0.04], "z": 0.57},
                                "sampling": "grid", "points_per_axis": 81})
    sq = evaluate(parse_config(yaml.safe_dump(square)), [design]).summary["stiffness"]["mean"][0]
    assert abs(sq / ev.summary["stiffness"]["mean"][0] - 1) > 1e-2  # the check above can fail


def test_atlas_of_a_3d_workspace_is_a_named_centre_slice():
    from optdesign.config import load_config
    from optdesign.evaluate import DesignModel
    from optdesign.report.html.atlas import atlas_map

    cfg = load_config(ROOT / "configs" / "sps_s_opt.yaml")
    m = atlas_map(DesignModel.from_config(cfg), cfg.units(), cfg.workspace, cfg.initial_design(), 31)
    assert m.axes == ["psi", "theta"] and m.units == ["deg", "deg"]
    assert m.cut.startswith("phi = 0 deg")
    np.testing.assert_allclose(m.coords[0][[0, -1]], [-10, 10])
    assert len(m.coords[0]) == 31 > cfg.workspace.points_per_axis


# --------------------------------------------------------------------------- the figures' JSON
def _same_as_plotly(fig) -> None:
    """plotly's own figure object, built from fig's traces, layout and frames
    (every property checked, a named colour scale spelled out, a number array
    kept as an array), gives the page the same JSON as fig itself."""
    import plotly.graph_objects as go
    from plotly.io.json import to_json_plotly

    theirs = go.Figure(dict(data=fig.data, layout=fig.layout, frames=fig.frames or [])).to_dict()
    ours = fig.to_dict()
    for part in ("data", "layout", "frames"):
        assert json.loads(to_json_plotly(ours.get(part, []))) == json.loads(to_json_plotly(theirs.get(part, []))), part


@pytest.mark.parametrize("rows, cols, titles, vs", [(1, 2, ["a", "b"], 0.1), (2, 2, ["a", "b", "c"], 0.12),
                                                  (3, 3, list("abcdefg"), 0.12), (4, 3, list("abcdefghij"), 0.12),
                                                  (2, 4, ["a", "", "c", "d", "e"], 0.18)])
def test_subplot_grids_are_make_subplots_own(rows, cols, titles, vs):
    """plot.subplots: the axes' domains and anchors and the titles' places of
    plotly's make_subplots, number for number (the grids the report draws:
    up to 10 single-objective panels in 3 columns, fronts' panels in 4)."""
    from plotly.subplots import make_subplots

    from optdesign.report.html.plot import subplots

    theirs = make_subplots(rows=rows, cols=cols, subplot_titles=titles, horizontal_spacing=0.1,
                           vertical_spacing=vs).to_dict()["layout"]
    theirs.pop("template")
    ours = subplots(rows, cols, titles, horizontal_spacing=0.1, vertical_spacing=vs)
    assert ours.layout == theirs
    fig = make_subplots(rows=rows, cols=cols, horizontal_spacing=0.1, vertical_spacing=vs)
    fig.add_scatter(x=[0], y=[0], row=rows, col=cols)          # the last panel's axes
    trace = ours.add_trace({"type": "scatter"}, row=rows, col=cols).data[0]
    assert (trace["xaxis"], trace["yaxis"]) == (fig.data[0].xaxis, fig.data[0].yaxis)


def test_every_figure_of_the_pages_is_what_plotly_makes_of_it(noref_run, two_objective_run, repro_copy, monkeypatch):
    """The reports and the comparison page build their figures as plain data
    (optdesign.report.html.plot); each is the figure plotly's checked objects
    make of it, so no property is misspelt (plotly refuses one it does not
    know) or in a form plotly.js does not read."""
    from optdesign.report.html import page as page_mod
    from optdesign.report.html.compare import build_compare
    from optdesign.report.html.report import build_report, load_run

    got = []
    real = page_mod.Page.figure
    monkeypatch.setattr(page_mod.Page, "figure",
                        lambda self, fig, cls="fig": (got.append(fig), real(self, fig, cls))[1])
    runs = [load_run(f) for f in (noref_run, two_objective_run, repro_copy)]
    for run in runs:
        build_report(run)
    build_compare(runs)
    kinds = {t["type"] for f in got for t in f.data}
    assert {"scatter", "splom", "parcoords", "scatter3d", "mesh3d", "surface", "contour"} <= kinds, kinds
    assert any(f.frames for f in got)
    for fig in got:
        _same_as_plotly(fig)


@pytest.mark.parametrize("name", ["delta_opt.yaml", "gough_stewart_opt.yaml", "cpr_rrr_opt.yaml", "upu3_opt.yaml"])
def test_the_views_of_other_mechanisms_are_what_plotly_makes_of_them(name):
    """The same for the 3-D drawing, the workspace view and the atlases of
    mechanisms with other workspaces (3-D, 6-D, planar, a chain)."""
    from optdesign.config import load_config
    from optdesign.evaluate import DesignModel
    from optdesign.report.html.atlas import atlas_map
    from optdesign.report.html.figures import atlas_figures
    from optdesign.report.html.rundata import RunData
    from optdesign.report.html.views import mechanism_figure, workspace_figure

    cfg = load_config(ROOT / "configs" / name)
    d = cfg.initial_design()
    run = RunData.of(Path("."), {}, {"optimum": d}, cfg)
    figs = [mechanism_figure(run, d, "t"), workspace_figure(run, d)]
    amap = atlas_map(DesignModel.from_config(cfg), cfg.units(), cfg.workspace, d, 21)
    figs += atlas_figures(run, amap) if amap is not None else []
    assert sum(f is not None for f in figs) >= 2
    for fig in figs:
        if fig is not None:
            _same_as_plotly(fig)


def test_the_views_of_a_segment_workspace_are_what_plotly_makes_of_them():
    """The same for a W along one axis (the atlas is a line plot)."""
    from optdesign.config import parse_config
    from optdesign.evaluate import DesignModel
    from optdesign.report.html.atlas import atlas_map
    from optdesign.report.html.figures import atlas_figures
    from optdesign.report.html.rundata import RunData
    from optdesign.report.html.views import mechanism_figure, workspace_figure

    d = small_data()
    d["workspace"] = {"type": "box", "axes": {"x": [-0.05, 0.05], "y": 0.0, "z": 0.57}, "sampling": "grid",
                      "step": 0.01}
    cfg = parse_config(yaml.safe_dump(d))
    des = cfg.initial_design()
    run = RunData.of(Path("."), {}, {"optimum": des}, cfg)
    amap = atlas_map(DesignModel.from_config(cfg), cfg.units(), cfg.workspace, des, 21)
    assert amap.shape == "segment"
    figs = atlas_figures(run, amap) + [mechanism_figure(run, des, "t"), workspace_figure(run, des)]
    assert all(f is not None for f in figs) and figs[0].data[0]["type"] == "scatter"
    for fig in figs:
        _same_as_plotly(fig)


# --------------------------------------------------------------------------- commands
def test_report_command_and_folders_that_are_not_finished_runs(noref_run, tmp_path):
    done = tmp_path / "done"
    shutil.copytree(noref_run, done)
    (done / "report.html").unlink(missing_ok=True)
    rc, out, err = run_cli_in(tmp_path, ["report", str(done), "--resolution", "21"])
    assert rc == 0 and "report.html" in out and (done / "report.html").is_file()
    running = tmp_path / "running"
    shutil.copytree(done, running)
    (running / "report.html").unlink()
    m = json.loads((running / "manifest.json").read_text())
    m["status"] = "interrupted"
    (running / "manifest.json").write_text(json.dumps(m))
    for folder, words in ((running, "not a finished run (status: interrupted)"), (tmp_path, "no manifest.json"),
                          (tmp_path / "nothing", "no such directory")):
        rc, out, err = run_cli_in(tmp_path, ["report", str(folder)])
        assert rc == 2 and words in err and err.count("\n") == 1, err
    assert not (running / "report.html").exists()


@pytest.mark.parametrize("damage", ["designs", "normalization", "optimum", "json", "config"])
def test_damaged_run_folder_is_one_line(noref_run, tmp_path, damage):
    folder = tmp_path / "run"
    shutil.copytree(noref_run, folder)
    p = folder / "results.json"
    r = json.loads(p.read_text())
    if damage == "designs":
        r["designs"]["before"]["global_indices"] = [1, 2]
    elif damage == "normalization":
        r["normalization"]["dynamic"]["min"] = "small"
    elif damage == "optimum":
        r["optimum"]["r_a"] = None
    p.write_text("{" if damage == "json" else json.dumps(r))
    if damage == "config":
        (folder / "config.yaml").write_text("mechanism: p4s\nworkspace: [\n")
    rc, out, err = run_cli_in(tmp_path, ["report", str(folder)])
    assert rc == 2 and err.count("\n") == 1 and "Traceback" not in err, err


def test_report_never_writes_through_a_symlink(noref_run, tmp_path):
    from optdesign.report.html import write_report_html

    folder = tmp_path / "run"
    shutil.copytree(noref_run, folder)
    outside = tmp_path / "outside.txt"
    outside.write_text("keep")
    (folder / "report.html").unlink(missing_ok=True)
    (folder / "report.html").symlink_to(outside)
    from optdesign.io import UnsafeDestination

    with pytest.raises(UnsafeDestination, match="symbolic link"):   # refused: neither followed nor replaced
        write_report_html(folder)
    assert (folder / "report.html").is_symlink() and outside.read_text() == "keep"
    rc, out, err = run_cli_in(tmp_path, ["report", str(folder)])
    assert rc == 2 and err.count("\n") == 1 and "report.html" in err and outside.read_text() == "keep"


def test_compare_overlays_fronts_and_writes_only_out(noref_run, repro_copy, tmp_path):
    before = {p: p.stat().st_mtime_ns for p in list(noref_run.rglob("*")) + list(repro_copy.rglob("*"))}
    out = tmp_path / "cmp.html"
    rc, so, err = run_cli_in(tmp_path, ["compare", str(noref_run), str(repro_copy), "--out", str(out)])
    assert rc == 0, err
    after = {p: p.stat().st_mtime_ns for p in list(noref_run.rglob("*")) + list(repro_copy.rglob("*"))}
    assert before == after
    html = out.read_text()
    sploms = [data for data, _ in _figures(html) if data and data[0].get("type") == "splom"]
    names = " ".join(tr["name"] for tr in sploms[0])
    assert "1: tradeoff_noref" in names and "2: p4s_paper-reproduction" in names
    assert html.count(_plotly_js()) == 1
    for bad, words in ((["--out", str(tmp_path / "x.json")], "ending in .html"),
                       (["--out", str(tmp_path / "no" / "x.html")], "no such folder")):
        rc, so, err = run_cli_in(tmp_path, ["compare", str(noref_run), str(repro_copy)] + bad)
        assert rc == 2 and words in err
    rc, so, err = run_cli_in(tmp_path, ["compare", str(noref_run), str(tmp_path)])
    assert rc == 2 and "not a run folder" in err


# --------------------------------------------------------------------------- browser
def _chromium(args: list[str], profile: Path) -> subprocess.CompletedProcess:
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={profile}",
             # the scatter matrix and parallel coordinates draw with WebGL: software rendering without a GPU
             "--enable-unsafe-swiftshader",
             "--hide-scrollbars", "--virtual-time-budget=15000", "--enable-logging=stderr", "--v=0"]
    return subprocess.run([CHROMIUM] + flags + args, capture_output=True, text=True, timeout=120)


@pytest.mark.slow
@pytest.mark.parametrize("which", ["four objectives", "two objectives"])
def test_report_renders_in_headless_chromium(which, request, tmp_path):
    if CHROMIUM is None:
        pytest.skip("chromium not found: the browser test of report.html needs it; install it with "
                    "`apt-get install -y chromium` (Debian; .ci/run does this)")
    from optdesign.report.html import write_report_html

    if which == "four objectives":
        noref_report = request.getfixturevalue("noref_report")
    else:  # a two-objective front is one scatter, not a one-panel matrix (which plotly.js cannot draw)
        noref_report = write_report_html(request.getfixturevalue("two_objective_run"))
    shot = tmp_path / "report.png"
    p = _chromium(["--window-size=1280,2000", f"--screenshot={shot}", "--dump-dom", noref_report.as_uri()],
                  tmp_path / "profile")
    dom = p.stdout
    expected = noref_report.read_text().count('class="plotly-graph-div"')
    assert expected >= 6
    # after the scripts ran: every figure became a plot with its SVG layers, and no script error
    assert dom.count('class="plotly-graph-div js-plotly-plot"') == expected, p.stderr[-2000:]
    assert f'data-figures-drawn="{expected}"' in dom
    assert 'data-errors="0"' in dom, re.findall(r'id="report-errors"[^>]*>([^<]*)', dom)
    assert dom.count('class="main-svg"') >= expected
    assert "gl-canvas" in dom  # the WebGL figures made their canvases
    console_errors = [ln for ln in p.stderr.splitlines() if "CONSOLE" in ln and ("Uncaught" in ln or "Error" in ln)
                      and "WebGL" not in ln and "GL Driver" not in ln]
    assert not console_errors, console_errors
    from PIL import Image

    img = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert img.shape[1] == 1280
    assert img.var() > 200 and (img < 200).mean() > 0.01, "blank screenshot"
