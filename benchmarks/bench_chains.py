"""Points per second of evaluate() on chain mechanisms (numpy path) against a hand-written numpy path.

The UPS+UPR+S as data (configs/ups_upr_s_legs.yaml) and its module
(configs/ups_upr_s.yaml with ``model: rigid``) on the same designs and poses,
their ratio, and the 3-PRS (configs/prs3.yaml) beside them.

    python benchmarks/bench_chains.py [--designs 16] [--points 512] [--repeat 5] [--square 0.5]

Each repeat draws new designs (uniform in the ``_opt`` configs' boxes) and
poses (uniform in the workspace box; the UPS+UPR+S's square ``[-s, s]^2``,
``--square``, 0.5 the singularity-free square of configs/ups_upr_s_opt.yaml)
and evaluates every case on them in turn (interleaved), so a memory of earlier
parameter sets does not help; the best wall and CPU (process) times of the
repeats count.  A first call of each case is not timed.  The machine is
shared: the load is printed before and after.  The UPS+UPR+S's two paths
must give the same means (their largest relative difference is printed).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def load() -> str:
    return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())


def _config(name: str, **changes):
    from optdesign.config import config_from_dict

    data = yaml.safe_load((ROOT / "configs" / name).read_text())
    data.update(changes)
    data.pop("reference", None)
    return config_from_dict(data, name)


def _boxes(name: str) -> dict:
    """The SI bounds of the free design variables of an ``_opt`` config."""
    from optdesign.config import load_config

    cfg = load_config(ROOT / "configs" / name)
    return {k: dv.bounds for k, dv in cfg.design_variables.items() if dv.bounds is not None}


def _draw(rng, boxes, D, lo, hi, N):
    des = {k: rng.uniform(a, b, D) for k, (a, b) in boxes.items()}
    X = lo + (hi - lo) * rng.random((N, len(lo)))
    return des, X


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--designs", type=int, default=16)
    ap.add_argument("--points", type=int, default=512)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--square", type=float, default=0.5, help="the UPS+UPR+S's poses in [-s, s]^2")
    a = ap.parse_args(argv)
    from optdesign.evaluate import evaluate, workspace_of
    from optdesign.workspace import Workspace

    s = a.square
    square = {"type": "box", "axes": {"s_theta": [-s, s], "s_psi": [-s, s]}, "sampling": "grid",
              "points_per_axis": 3}
    hand = _config("ups_upr_s.yaml", parameters={"model": "rigid"}, workspace=square)
    legs = _config("ups_upr_s_legs.yaml", workspace=square)
    prs = _config("prs3.yaml")
    prs_kin = _config("prs3.yaml", indices={k: v for k, v in yaml.safe_load(
        (ROOT / "configs" / "prs3.yaml").read_text())["indices"].items() if k != "dynamic"})
    ups_box, prs_box = _boxes("ups_upr_s_opt.yaml"), _boxes("prs3_opt.yaml")
    wprs = workspace_of(prs)
    plo, phi = wprs.X.min(axis=0), wprs.X.max(axis=0)
    ulo, uhi = np.array([-s, -s]), np.array([s, s])
    cases = [("UPS+UPR+S module (model: rigid), numpy", hand, "ups"),
             ("UPS+UPR+S as data (ups_upr_s_legs.yaml)", legs, "ups"),
             ("3-PRS (prs3.yaml: isotropy, dexterity, stiffness)", prs_kin, "prs"),
             ("3-PRS (prs3.yaml: the same and dynamic)", prs, "prs")]
    D, N = a.designs, a.points
    print(f"evaluate() of {D} designs x {N} poses, best of {a.repeat} interleaved repeats, new designs and poses "
          f"each repeat ({load()})")
    wall, cpu = [np.inf] * len(cases), [np.inf] * len(cases)
    rng = np.random.default_rng(0)
    worst = 0.0
    reach = {}
    for r in range(a.repeat + 1):
        ups = _draw(rng, ups_box, D, ulo, uhi, N)
        pr = _draw(rng, prs_box, D, plo, phi, N)
        got = {}
        for i, (name, cfg, kind) in enumerate(cases):
            des, X = ups if kind == "ups" else pr
            ws = Workspace(spec=cfg.workspace, names=cfg.mechanism_class.pose_names, X=X)
            t, c = time.perf_counter(), time.process_time()
            ev = evaluate(cfg, des, ws, errors=False)
            if r:
                wall[i] = min(wall[i], time.perf_counter() - t)
                cpu[i] = min(cpu[i], time.process_time() - c)
            got[i] = ev
            reach[i] = float(np.mean(ev.reachable))
        for k in hand.indices:
            m0, m1 = got[0].summary[k]["mean"], got[1].summary[k]["mean"]
            ok = np.isfinite(m0) & np.isfinite(m1)
            if ok.any():
                worst = max(worst, float(np.max(np.abs(m1[ok] - m0[ok]) / np.abs(m0[ok]))))
    n = D * N
    for i, (name, _, _) in enumerate(cases):
        ratio = "" if i == 0 else f", {wall[i] / wall[0]:6.1f}x the module's time (CPU {cpu[i] / cpu[0]:6.1f}x)"
        print(f"   {name:52s} {n / wall[i]:9.0f} points/s (CPU {n / cpu[i]:9.0f}), reachable {reach[i]:.3f}{ratio}")
    print(f"   the UPS+UPR+S's two paths: largest relative difference of the means {worst:.1e}")
    print(f"   ({load()})")


if __name__ == "__main__":
    main()
