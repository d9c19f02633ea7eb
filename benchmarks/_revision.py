"""Kernel files of an earlier git revision, loaded as modules, for the A/B
benchmarks (bench_before_after.py, bench_fk.py, bench_kernel_ab.py)."""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: where each kernel module lives: under the 3-P(4S)'s package since the
#: restructuring, in optdesign/fast/ before it
_PATHS = {"_p4s_kernels": ("optdesign/mechanisms/p4s/kernels.py", "optdesign/fast/_p4s_kernels.py"),
          "_fk_kernels": ("optdesign/mechanisms/p4s/fk_kernels.py", "optdesign/fast/_fk_kernels.py")}


def _source(rev: str, name: str) -> str | None:
    for path in _PATHS.get(name, (f"optdesign/fast/{name}.py",)):
        res = subprocess.run(["git", "-C", ROOT, "show", f"{rev}:{path}"], capture_output=True, text=True)
        if res.returncode == 0:
            return res.stdout
    return None


def kernel_module(rev: str, name: str = "_p4s_kernels", directory: str | None = None):
    """The kernel module ``name`` (``_p4s_kernels``: the local-index kernels,
    ``_fk_kernels``: forward kinematics) of revision ``rev`` as a module (its
    relative imports made absolute), or None if that revision has no such file.

    The file is written to ``directory`` (default: a directory per revision in
    the temp dir, kept between runs and rewritten only when the source changed,
    so that numba's cache of the old kernels survives) and registered in
    ``sys.modules`` (numba's cache finds a function's environment by module name).
    """
    src = _source(rev, name)
    if src is None:
        return None
    src = (src.replace("from ...fast.", "from optdesign.fast.")
           .replace("from ...formulas import", "from optdesign.formulas import")
           .replace("from .model import", "from optdesign.mechanisms.p4s.model import")
           .replace("from .geometry import", "from optdesign.mechanisms.p4s.geometry import")
           .replace("from ..", "from optdesign.")
           .replace("from . import", "from optdesign.fast import")
           .replace("from ._", "from optdesign.fast._"))
    d = directory or os.path.join(tempfile.gettempdir(), f"optdesign_rev_{rev}")
    os.makedirs(d, exist_ok=True)
    path = os.path.join(d, f"old{name}.py")
    if not os.path.exists(path) or open(path).read() != src:
        with open(path, "w") as f:
            f.write(src)
    modname = f"old{name}_{rev}"
    spec = importlib.util.spec_from_file_location(modname, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[modname] = mod
    spec.loader.exec_module(mod)
    return mod
