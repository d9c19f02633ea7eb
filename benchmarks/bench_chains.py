"""Points per second of evaluate() on chain mechanisms, their numpy path and the engine's chain kernel, against a hand-written numpy path.

The UPS+UPR+S as data (configs/ups_upr_s_legs.yaml) and its module
(configs/ups_upr_s.yaml with ``model: rigid``) on the same designs and poses,
their ratio, and the 3-PRS (configs/prs3.yaml) beside them; each chain case
twice: on its numpy path (``OPTDESIGN_CHAIN_ENGINE=0``) and on the compiled
one (the chain kernel, optdesign/engine/chain_kernels.py), with the ratio of
their times.

    python benchmarks/bench_chains.py [--designs 16] [--points 512] [--repeat 5] [--square 0.5]

Each repeat draws new designs (uniform in the ``_opt`` configs' boxes) and
poses (uniform in the workspace box; the UPS+UPR+S's square ``[-s, s]^2``,
``--square``, 0.5 the singularity-free square of configs/ups_upr_s_opt.yaml)
and evaluates every case on them in turn (interleaved), so a memory of earlier
parameter sets does not help; the best wall and CPU (process) times of the
repeats count.  A first call of each case is not timed.  The machine is
shared: the load is printed before and after.  The UPS+UPR+S's two paths
must give the same means (their largest relative difference is printed),
and so must each chain case's two paths.
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
    from optdesign.mechanisms.described.chain_compiled import ENV_VAR
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
    # (name, config, poses, chain kernel on: None for the hand-written module, which has no chain legs)
    cases = [("UPS+UPR+S module (model: rigid), numpy", hand, "ups", None),
             ("UPS+UPR+S as data, numpy path", legs, "ups", False),
             ("UPS+UPR+S as data, compiled", legs, "ups", True),
             ("3-PRS (isotropy, dexterity, stiffness), numpy path", prs_kin, "prs", False),
             ("3-PRS (isotropy, dexterity, stiffness), compiled", prs_kin, "prs", True),
             ("3-PRS (the same and dynamic), numpy path", prs, "prs", False),
             ("3-PRS (the same and dynamic), compiled", prs, "prs", True)]
    D, N = a.designs, a.points
    print(f"evaluate() of {D} designs x {N} poses, best of {a.repeat} interleaved repeats, new designs and poses "
          f"each repeat, {_threads()} kernel threads ({load()})")
    wall, cpu = [np.inf] * len(cases), [np.inf] * len(cases)
    rng = np.random.default_rng(0)
    worst = same = 0.0
    first = None
    reach = {}
    for r in range(a.repeat + 1):
        ups = _draw(rng, ups_box, D, ulo, uhi, N)
        pr = _draw(rng, prs_box, D, plo, phi, N)
        got = {}
        for i, (name, cfg, kind, on) in enumerate(cases):
            des, X = ups if kind == "ups" else pr
            ws = Workspace(spec=cfg.workspace, names=cfg.mechanism_class.pose_names, X=X)
            os.environ[ENV_VAR] = "0" if on is False else "1"
            t, c = time.perf_counter(), time.process_time()
            ev = evaluate(cfg, des, ws, errors=False)
            if r:
                wall[i] = min(wall[i], time.perf_counter() - t)
                cpu[i] = min(cpu[i], time.process_time() - c)
            elif on and first is None:
                first = time.perf_counter() - t
            got[i] = ev
            reach[i] = float(np.mean(ev.reachable))
        worst = max(worst, _worst(got[0], got[1], hand.indices), _worst(got[0], got[2], hand.indices))
        for i in (2, 4, 6):
            same = max(same, _worst(got[i - 1], got[i], cases[i][1].indices))
    os.environ.pop(ENV_VAR, None)
    n = D * N
    for i, (name, _, kind, on) in enumerate(cases):
        ratio = f", {wall[i] / wall[0]:6.1f}x the module's time (CPU {cpu[i] / cpu[0]:6.1f}x)" if kind == "ups" and i else ""
        if on:
            ratio += f", {wall[i - 1] / wall[i]:5.1f}x faster than its numpy path (CPU {cpu[i - 1] / cpu[i]:5.1f}x)"
        print(f"   {name:52s} {n / wall[i]:9.0f} points/s (CPU {n / cpu[i]:9.0f}), reachable {reach[i]:.3f}{ratio}")
    print(f"   the UPS+UPR+S module against the chain paths: largest relative difference of the means {worst:.1e}")
    print(f"   each chain case's numpy path against its compiled path: largest relative difference {same:.1e}")
    print(f"   the chain kernel's first call in this process (its compile, or its load from numba's cache): "
          f"{first:.1f} s")
    print(f"   ({load()})")


def _threads() -> int:
    from optdesign.engine import workers

    return workers()


def _worst(a, b, names) -> float:
    """The largest relative difference of the means of two evaluations."""
    out = 0.0
    for k in names:
        m0, m1 = a.summary[k]["mean"], b.summary[k]["mean"]
        ok = np.isfinite(m0) & np.isfinite(m1)
        if ok.any():
            out = max(out, float(np.max(np.abs(m1[ok] - m0[ok]) / np.abs(m0[ok]))))
    return out


if __name__ == "__main__":
    main()
