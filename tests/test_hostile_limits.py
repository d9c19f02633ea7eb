"""Resource limits: one limit on workspace points however the workspace is
given (step, points_per_axis, cylinder, random points), and on points x
designs per evaluation call, checked before anything is allocated."""
from __future__ import annotations

import copy
import math
import time
import tracemalloc

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import CONFIGS, DATA, small_data
from hostile_helpers import Cases, files_under, run_case, sandbox
from optdesign.config import ConfigError, load_config, parse_config, yamlsafe
from optdesign.evaluate import Evaluator, evaluate
from optdesign.workspace import MAX_POINTS, WorkspaceTooLarge, sample

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])
#: a config of each pose kind: lengths (p4s 3 axes, cpr_rrr 2), angles (sps_s), plain numbers (ups_upr_s)
BASES = {name: yaml.safe_load((CONFIGS / name).read_text())
         for name in ("p4s_paper.yaml", "cpr_rrr.yaml", "sps_s.yaml", "ups_upr_s.yaml")}
#: the poses of each, and their scale (the workspace's unit)
AXES = {"p4s_paper.yaml": ("x", "y", "z"), "cpr_rrr.yaml": ("x", "y"), "sps_s.yaml": ("psi", "theta", "phi"),
        "ups_upr_s.yaml": ("s_theta", "s_psi")}


@st.composite
def workspaces(draw):
    """(config name, workspace mapping)."""
    name = draw(st.sampled_from(sorted(BASES)))
    axes = AXES[name]
    cylinder = len(axes) == 3 and draw(st.booleans())
    ws = {"type": "cylinder" if cylinder else "box", "axes": {}}
    if name == "sps_s.yaml":
        ws["unit"] = "deg"
    for a in (axes[2:] if cylinder else axes):
        lo = draw(st.floats(-1.0, 1.0, allow_subnormal=False))
        width = draw(st.sampled_from([0.0, 1e-6, 0.01, 0.1, 1.0, 100.0]))
        ws["axes"][a] = lo if width == 0 else [lo, lo + width]
    if cylinder:
        ws["radius"] = draw(st.sampled_from([1e-3, 0.05, 1.0, 1e3]))
    how = draw(st.sampled_from(["step", "step", "points_per_axis", "both", "points", "points+step"]))
    if how in ("step", "both", "points+step"):
        ws["step"] = draw(st.sampled_from([1e-9, 1e-6, 1e-4, 1e-3, 0.01, 0.05, 0.3, 5e-324]))
    if how in ("points_per_axis", "both"):
        ws["points_per_axis"] = draw(st.sampled_from([1, 2, 7, 100, 3163, 10 ** 4, 10 ** 5, 10 ** 9]))
    if how.startswith("points") and how != "points_per_axis":
        ws["sampling"] = draw(st.sampled_from(["sobol", "halton", "lhs", "random"]))
        ws["points"] = draw(st.sampled_from([1, 100, 10 ** 5, MAX_POINTS, MAX_POINTS + 1, 10 ** 12]))
    if draw(st.booleans()):
        ws["seed"] = draw(st.sampled_from([0, 7, 2 ** 32 - 1, 2 ** 32, 10 ** 30]))
    return name, ws


def _count(ws: dict, scale: float) -> int:
    """The points of a grid, counted by hand (the spec: per free axis floor(width / step) + 1,
    or points_per_axis; a cylinder's square before the disc is cut)."""
    def n(lo, hi):
        if hi == lo:
            return 1
        if "step" in ws:
            r = (hi - lo) / (ws["step"] * scale) + 1e-9
            return int(math.floor(r)) + 1 if math.isfinite(r) else 10 ** 30
        return ws["points_per_axis"]

    ranges = [(v * scale, v * scale) if not isinstance(v, list) else (v[0] * scale, v[1] * scale)
              for v in ws["axes"].values()]
    total = math.prod(n(lo, hi) for lo, hi in ranges)
    if ws["type"] == "cylinder":
        side = n(-ws["radius"] * scale, ws["radius"] * scale)
        total *= side * side
    return total


@pytest.mark.slow
def test_one_limit_on_workspace_points():
    cases = Cases()

    @settings(max_examples=250, **SETTINGS)
    @given(case=workspaces())
    def check(case):
        cases()
        name, ws = case
        data = copy.deepcopy(BASES[name])
        data["workspace"] = ws
        text = yamlsafe.dump(data, sort_keys=False)
        scale = math.pi / 180 if ws.get("unit") == "deg" else 1.0
        tracemalloc.start()
        t0 = time.process_time()     # CPU seconds: the bound holds however busy the machine is
        try:
            cfg = parse_config(text, "c.yaml")
            err = None
        except ConfigError as exc:
            err = exc
        elapsed = time.process_time() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert elapsed < 2 and peak < 30e6, (ws, elapsed, peak)        # nothing proportional to the points
        grid = "points" not in ws
        # the first mistake the loader meets, in its order
        if "step" in ws and "points_per_axis" in ws:
            want = "workspace.points_per_axis"
        elif not grid and "step" in ws:
            want = "workspace.step"
        elif ws.get("points_per_axis", 0) > MAX_POINTS:
            want = "workspace.points_per_axis"
        elif "step" in ws and (ws["step"] * scale == 0 or ws["step"] < 1e-12):   # a positive value below 1e-12 is refused
            want = "workspace.step"
        elif not grid and ws["points"] > MAX_POINTS:
            want = "workspace.points"
        elif ws.get("seed", 0) > 2 ** 32 - 1:
            want = "workspace.seed"
        else:
            want = None
        if want is not None:
            assert err is not None and err.path == want, (ws, err)
            return
        if not grid:
            assert err is None, (ws, err)
            return
        n = _count(ws, scale)
        if n > MAX_POINTS:
            key = "workspace.step" if "step" in ws else "workspace.points_per_axis"
            assert err is not None and err.path == key, (ws, n, err)
            assert "grid points; expected at most 10,000,000" in err.message
            return
        assert err is None, (ws, n, err)
        if n <= 50_000:     # the points the workspace really has
            got = sample(cfg.workspace, cfg.mechanism_class.pose_names).n
            assert got == n if ws["type"] == "box" else got <= n, (ws, got, n)

    check()
    assert cases.n >= 250


def test_points_times_population_before_a_run():
    """N points x the largest population past the limit: refused by `run`
    before a run folder is made (one line naming the population)."""
    cases = Cases()

    @settings(max_examples=60, **SETTINGS)
    @given(step=st.sampled_from([0.025, 0.01, 0.001, 0.0004, 0.0001]), pop=st.sampled_from([4, 16, 50, 1000, 100_000]),
           ppop=st.sampled_from([4, 60, 5000, 100_000]), pareto=st.booleans())
    def check(step, pop, ppop, pareto):
        cases()
        data = small_data()
        data["workspace"]["step"] = step
        data["optimizer"].update(population=pop, elites=2)
        data["optimizer"]["pareto"]["population"] = ppop
        n = (int(math.floor(0.1 / step + 1e-9)) + 1) ** 2
        worst, key = max((pop, "optimizer.population"), (ppop if pareto else 0, "optimizer.pareto.population"))
        with sandbox() as (work, outside):
            (work / "c.yaml").write_text(yamlsafe.dump(data, sort_keys=False))
            cfg = load_config(work / "c.yaml")
            if n * worst > MAX_POINTS:
                argv = ["run", "c.yaml", "--quiet"] + ([] if pareto else ["--no-pareto"])
                run_case(work, outside, argv, f"{n} x {worst}", file="c.yaml", key=f"{key}: ", allowed=(2,))
                assert files_under(work) == {"c.yaml"}
            else:
                cfg.check_optimizable(pareto=pareto)

    check()
    assert cases.n >= 60


def test_evaluation_calls_are_bounded():
    cfg = load_config(DATA / "p4s_small.yaml")
    ws = sample(cfg.workspace, ("x", "y", "z"))
    D = MAX_POINTS // ws.n + 1
    tracemalloc.start()
    with pytest.raises(ConfigError, match="workspace: .* evaluations in one call; at most 10,000,000"):
        evaluate(cfg, {"r_a": np.full(D, 0.25)}, ws)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 100 * D and peak < 4 * D * ws.n      # the designs' own arrays, not a float per point and design
    ev = Evaluator.from_config(cfg, ws)
    with pytest.raises(WorkspaceTooLarge):
        ev(np.tile([[0.25, 0.67, 0.5]], (D, 1)))
    assert ev(np.tile([[0.25, 0.67, 0.5]], (3, 1)))["values"]["dynamic"].shape == (3,)


# (label, workspace edits, key)
LIMIT_CASES = [
    ("points_per_axis 10^4 on 2 free axes", {"points_per_axis": 10_000}, "workspace.points_per_axis"),
    ("points_per_axis beyond the limit", {"points_per_axis": 10 ** 9}, "workspace.points_per_axis"),
    ("step 1e-9", {"step": 1e-9}, "workspace.step"),
    ("step 5e-324", {"step": 5e-324}, "workspace.step"),
    ("a z range with a fine step", {"step": 1e-4, "axes": {"x": [-0.05, 0.05], "y": [-0.05, 0.05], "z": [0.5, 0.6]}},
     "workspace.step"),
    ("10^8 random points", {"sampling": "random", "points": 10 ** 8}, "workspace.points"),
    ("10^30 as the seed", {"sampling": "sobol", "points": 64, "seed": 10 ** 30}, "workspace.seed"),
    ("a huge cylinder", {"type": "cylinder", "radius": 1e3, "axes": {"z": 0.57}}, "workspace.step"),
    ("step and points_per_axis", {"points_per_axis": 5}, "workspace.points_per_axis"),
    ("points on a grid", {"points": 100}, "workspace.points"),
]


@pytest.mark.parametrize("command", [["validate-config"], ["evaluate"], ["atlas", "--no-plots"], ["run", "--quiet"]],
                         ids=lambda c: c[0])
@pytest.mark.parametrize("label", [c[0] for c in LIMIT_CASES])
def test_limits_through_the_commands(label, command):
    _, edits, key = next(c for c in LIMIT_CASES if c[0] == label)
    data = small_data()
    ws = data["workspace"]
    if "step" in edits or "sampling" in edits or label.startswith("points_per_axis") and "step and" not in label:
        ws.pop("step")
    ws.update(edits)
    with sandbox() as (work, outside):
        (work / "c.yaml").write_text(yamlsafe.dump(data, sort_keys=False))
        t0 = time.process_time()
        run_case(work, outside, command + ["c.yaml"], label, file="c.yaml", key=f"{key}: ", allowed=(2,))
        assert time.process_time() - t0 < 5
        assert files_under(work) == {"c.yaml"}


@pytest.mark.parametrize("body, argv, key", [
    ("seeds: 100000\nsweep: {parameters.m_platform: [4.0, 5.0]}\n", [], "b.yaml: seeds: "),
    ("sweep: {parameters.m_platform: [4.0, 5.0]}\n", ["--seeds", "60000"], "b.yaml: seeds: "),
    ("sweep: {parameters.m_platform: " + str(list(range(1, 102))) + ", parameters.g: " + str(list(range(1, 101)))
     + "}\n", [], "b.yaml: sweep: grid gives 10100 combinations"),
], ids=["file seeds", "--seeds", "combinations"])
def test_batch_sizes_are_bounded(body, argv, key):
    """At most 100,000 runs (and 10,000 sweep combinations) per batch, refused before any task is made."""
    with sandbox() as (work, outside):
        (work / "b.yaml").write_text(f"base: {DATA / 'batch_small.yaml'}\n" + body)
        t0 = time.process_time()
        run_case(work, outside, ["batch", "b.yaml", "--dry-run"] + argv, key, key=key, allowed=(2,))
        assert time.process_time() - t0 < 30
        assert files_under(work) == {"b.yaml"}
