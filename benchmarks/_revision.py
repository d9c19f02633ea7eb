"""Kernel files of an earlier git revision, loaded as modules, for the A/B
benchmarks (bench_before_after.py, bench_fk.py, bench_kernel_ab.py)."""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def kernel_module(rev: str, name: str = "_p4s_kernels", directory: str | None = None):
    """``optdesign/fast/<name>.py`` of revision ``rev`` as a module (its
    relative imports made absolute), or None if that revision has no such file.

    The file is written to ``directory`` (default: a directory per revision in
    the temp dir, kept between runs and rewritten only when the source changed,
    so that numba's cache of the old kernels survives) and registered in
    ``sys.modules`` (numba's cache finds a function's environment by module name).
    """
    res = subprocess.run(["git", "-C", ROOT, "show", f"{rev}:optdesign/fast/{name}.py"], capture_output=True,
                         text=True)
    if res.returncode != 0:
        return None
    src = (res.stdout.replace("from ..", "from optdesign.")
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
