"""The AD route's CasADi function compiled to machine code against CasADi's virtual machine, per call.

For each config with an AD route (the mechanism has a CasADi model), the
function of ``optdesign.gradients.casadi_fn`` mapped over N poses, as the
polish calls it: ms per call on CasADi's virtual machine and as the compiled
library of ``optdesign.gradients.casadi_c`` (compiled into a temporary cache
folder, its compile time printed), their ratio, and whether the outputs are
the same bits.  Inputs: the workspace's points of 4 random designs of the box
(the designs' inverse kinematics for q), repeated to N.

    python benchmarks/bench_casadi_c.py [--configs p4s_paper,sps_s_opt,ups_upr_s_opt,cpr_rrr_opt]
                                        [--points 1,64,512] [--repeat 7]

The machine may be shared: the load is printed; the ratios are the point.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _inputs(ev, model, n):
    rng = np.random.default_rng(1)
    X = ev.xl + (ev.xu - ev.xl) * rng.random((4, len(ev.free)))
    designs = ev.designs(X)
    mech = ev.mechanism(**{**ev.fixed, **{k: v[:, None] for k, v in designs.items()}})
    P = ev.workspace.X
    with np.errstate(all="ignore"):
        st = mech.state(P)
    from optdesign.gradients.casadi_fn import arguments

    D, N = len(X), len(P)
    x, q, p = arguments(P, np.broadcast_to(st.q, (D, N, model.n_act)), mech.params, model.param_names)
    idx = np.arange(n) % (D * N)
    return [np.ascontiguousarray(a[:, idx]) for a in (x, q, p)]


def _best(f, args, repeat):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(10):
            f(*args)
        best = min(best, (time.perf_counter() - t) / 10)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="bench_casadi_c", description=__doc__.splitlines()[0])
    ap.add_argument("--configs", default="p4s_paper,sps_s_opt,ups_upr_s_opt,cpr_rrr_opt")
    ap.add_argument("--points", default="1,64,512")
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as cache:
        os.environ["OPTDESIGN_CACHE_DIR"] = cache
        os.environ.pop("OPTDESIGN_CODEGEN", None)
        from optdesign.config import load_config
        from optdesign.evaluate import Evaluator
        from optdesign.gradients import casadi_c, casadi_fn
        from optdesign.mechanisms import symbolic_model

        if casadi_c.compiler() is None:
            print("no C compiler (CC, cc, gcc or clang): nothing to compare")
            return 1
        print(f"CasADi function per call: virtual machine against compiled, best of {a.repeat} x 10 "
              f"(load {' '.join(f'{x:.2f}' for x in os.getloadavg())})")
        for name in a.configs.split(","):
            ev = Evaluator.from_config(load_config(ROOT / "configs" / f"{name}.yaml"))
            got = casadi_fn.symbolic_function(ev.mechanism.name, symbolic_model(ev.mechanism.name), tuple(ev.free))
            if got is None:
                print(f"  {name}: no AD route")
                continue
            fn, model = got
            t = time.perf_counter()
            ext = casadi_c.compiled(fn)
            compile_s = time.perf_counter() - t
            if ext is fn:
                print(f"  {name}: not compiled (the virtual machine runs)")
                continue
            print(f"  {name} ({fn.n_instructions()} operations; compiled in {compile_s:.2f} s):")
            for n in (int(s) for s in a.points.split(",")):
                args = _inputs(ev, model, n)
                vm, cm = fn.map(n), ext.map(n)
                with np.errstate(all="ignore"):
                    same = all(np.array_equal(np.asarray(u), np.asarray(v), equal_nan=True)
                               for u, v in zip(vm(*args), cm(*args)))
                t_vm, t_c = _best(vm, args, a.repeat), _best(cm, args, a.repeat)
                print(f"    {n:5d} poses: virtual machine {t_vm * 1e3:8.3f} ms, compiled {t_c * 1e3:8.3f} ms, "
                      f"ratio {t_c / t_vm:5.2f}; {'the same bits' if same else 'DIFFERENT BITS'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
