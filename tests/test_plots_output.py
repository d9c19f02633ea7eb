"""Issue 20, "Output a user reads": the figures a user looks at (convergence.png,
pareto.png, summary.png, compare.html, the plotly toolbar)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REPRO = ROOT / "runs" / "p4s_paper-reproduction"


def _hist(best, mean):
    return [{"generation": str(g + 1), "best_objective": str(b), "mean_objective": str(m)}
            for g, (b, m) in enumerate(zip(best, mean))]


# ---------------------------------------------------------------- convergence.png
def test_convergence_is_on_a_log_axis_not_flat_at_zero():
    import matplotlib.pyplot as plt

    from optdesign.report.png import convergence_figure

    best = [0.3 * 10.0 ** -k for k in range(8)]          # falls by decades: flat at 0 on a linear axis
    fig = convergence_figure("c", _hist(best, [3 * b for b in best]))
    try:
        ax = fig.axes[0]
        assert ax.get_yscale() == "log"
        lo, hi = ax.get_ylim()
        assert lo <= min(best) and hi >= 0.9                # every generation in view
        assert "log" in ax.get_ylabel()  # the axis says it
    finally:
        plt.close(fig)


def test_convergence_with_round_off_zeros_is_symlog_and_says_so():
    import matplotlib.pyplot as plt

    from optdesign.report.png import convergence_figure

    best = [0.2, 1e-3, 1e-5, 3e-17, 0.0]
    fig = convergence_figure("c", _hist(best, [0.5, 0.1, 1e-2, 1e-4, 1e-6]))
    try:
        ax = fig.axes[0]
        assert ax.get_yscale() == "symlog"
        assert ax.yaxis.get_transform().linthresh <= 1e-5 / 10 * 1.0001   # the smallest real f is on the log part
        assert "round-off" in ax.get_title()
    finally:
        plt.close(fig)


def test_no_decade_label_sits_on_the_zero_of_a_symlog_axis():
    """Best values at 0 and means falling to 1e-5 (the reproduction's weighted
    sum): the linear band below the smallest value holds no tick but 0, whose
    label a decade tick there (1e-7) would overlap; the band's edge keeps its own."""
    import matplotlib.pyplot as plt

    from optdesign.report.png import convergence_figure

    mean = [0.7, 1e-1, 1e-2, 1e-3, 1e-4, 2e-5, 1.5e-5, 9e-6]
    fig = convergence_figure("c", _hist([0.0] * len(mean), mean))
    try:
        ax = fig.axes[0]
        lin = ax.yaxis.get_transform().linthresh
        lo, hi = ax.get_ylim()
        ticks = [t for t in ax.get_yticks() if lo <= t <= hi]
        assert 0.0 in ticks and all(t == 0 or abs(t) >= lin * (1 - 1e-9) for t in ticks), (ticks, lin)
    finally:
        plt.close(fig)


# ---------------------------------------------------------------- pareto.png
def test_pareto_markers_are_not_cut_at_the_frame():
    import matplotlib.pyplot as plt
    from matplotlib.collections import PathCollection

    from optdesign.report.png import pareto_figure
    from optdesign.report.folders import config_of_folder

    cfg = config_of_folder(REPRO)
    results = json.loads((REPRO / "results.json").read_text())
    stages = {p.name: json.loads((p / "result.json").read_text()) for p in (REPRO / "stages").iterdir()}
    fig = pareto_figure(cfg.units(), results, stages)
    try:
        marks = [c for ax in fig.axes for c in ax.collections if isinstance(c, PathCollection)]
        assert marks
        assert all(not c.get_clip_on() for c in marks), [c.get_label() for c in marks if c.get_clip_on()]
    finally:
        plt.close(fig)


# ---------------------------------------------------------------- summary.png
def test_summary_labels_each_mechanisms_stiffness_with_its_own_unit(tmp_path):
    """A summary over runs of several mechanisms: the 3-P(4S)'s stiffness is
    N/m (translations), the 3-SPS-S's N m/rad (rotations); one label for both
    taken from the first run was wrong for the other."""
    from optdesign.report.summary import _quantity_labels
    from optdesign.config import load_config
    from optdesign.runner import config_text
    from optdesign.runs import RunFolder, run_key

    rows = []
    for i, name in enumerate(["configs/sps_s_opt.yaml", "tests/data/p4s_tiny.yaml"]):
        cfg = load_config(ROOT / name)
        text = config_text(cfg)
        f = RunFolder.create(tmp_path, cfg.name, text, 1, run_key(text, 1))
        rows.append({"folder": str(f.path), "config": cfg.name, "config_key": str(i)})
    lab = _quantity_labels(rows, ["stiffness", "dexterity"])["stiffness"]
    assert "N/m: tiny" in lab and "N m/rad: " in lab, lab
    assert _quantity_labels(rows[1:], ["stiffness"])["stiffness"] == "stiffness [N/m]"


# ---------------------------------------------------------------- compare.html and the plotly toolbar
@pytest.fixture(scope="module")
def two_runs():
    from optdesign.report.html.compare import _labels
    from optdesign.report.html.rundata import load_run

    r = load_run(REPRO)
    r.path = r.path.with_name("a-long-run-name-s12345-20261203-084403-160c")   # names as long as real ones
    return [r, r], _labels([r, r])


def test_compare_legends_one_entry_per_line_below_the_plot(two_runs):
    from optdesign.report.html.compare import LEGEND_ROW, _convergence_figure, _fronts_figure

    runs, labels = two_runs
    fronts, _ = _fronts_figure(runs, labels)
    conv = _convergence_figure(runs, labels)
    for fig in (fronts, conv):
        lg = fig.layout["legend"]
        # side by side (orientation h, fixed entry widths) the long names overlapped and were cut
        assert lg["orientation"] == "v" and "entrywidth" not in lg
        assert lg["yref"] == "container" and lg["yanchor"] == "bottom" and lg["y"] == 0
        n = sum(1 for d in fig.data if d.get("showlegend") is not False)
        assert fig.layout["margin"]["b"] >= LEGEND_ROW * n + 40   # room for every entry under the axes' titles
    assert conv.layout["yaxis"]["type"] == "log"                 # best f falls towards 0


def test_figure_titles_sit_below_the_plotly_toolbar(two_runs):
    from optdesign.report.html.compare import _fronts_figure
    from optdesign.report.html.page import MODEBAR_PX, Page

    fig, _ = _fronts_figure(*two_runs)
    top, height = fig.layout["margin"]["t"], fig.layout["height"]
    Page("t").figure(fig)
    t = fig.layout["title"]
    assert t["yref"] == "container" and t["yanchor"] == "top" and t["y"] == 1.0 and t["pad"]["t"] >= MODEBAR_PX >= 30
    assert fig.layout["margin"]["t"] == top + MODEBAR_PX and fig.layout["height"] == height + MODEBAR_PX
    Page("t").figure(fig)                                  # once only
    assert fig.layout["margin"]["t"] == top + MODEBAR_PX


def test_convergence_with_positive_round_off_is_symlog_so_the_best_line_is_drawn():
    """A best f of 5e-18 (round-off, shown as 0) with every value positive:
    a log axis would leave the best line's zeros undrawn; symlog draws them."""
    import matplotlib.pyplot as plt

    from optdesign.report.png import convergence_figure

    best = [0.2, 1e-3, 5.4e-18, 5.4e-18]
    fig = convergence_figure("c", _hist(best, [0.5, 0.1, 1e-2, 1e-4]))
    try:
        ax = fig.axes[0]
        assert ax.get_yscale() == "symlog" and "round-off" in ax.get_title()
        y = ax.lines[0].get_ydata()
        assert y[-1] == 0.0 and ax.get_ylim()[0] <= 0.0
    finally:
        plt.close(fig)
