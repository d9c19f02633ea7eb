"""The AD route's CasADi function as machine code: CasADi's C code generation,
compiled once per machine by the machine's C compiler.

CasADi evaluates an SX function on its virtual machine, one operation at a
time; the same function written out as C and compiled runs 1.2-12x faster on
the mechanisms' functions (the larger the function, the larger the gain; the
3-P(4S)'s: about 7x at 512 poses, ``benchmarks/bench_casadi_c.py``).  The C code
performs the virtual machine's IEEE operations in the same order, and it is
compiled without fused multiply-add (``-ffp-contract=off``) or fast math, so it
gives the same bits.  After loading, one evaluation at a fixed input is
compared with the virtual machine's, bit for bit.

* The library is named by the sha256 of its C source, the compiler, the
  flags, CasADi's version and the platform: a changed function never loads a
  stale library.
* It is kept where numba keeps its cache: ``OPTDESIGN_CACHE_DIR`` if set, else
  this package's ``__pycache__`` if writable, else the user's cache folder
  (``$XDG_CACHE_HOME/optdesign`` or ``~/.cache/optdesign``).
* It is compiled under a temporary name and renamed: processes that compile
  the same function at once each leave a whole file.
* No compiler (``CC``, else ``cc``, ``gcc`` or ``clang`` on the PATH), a failed
  compile or load, or an evaluation that differs from the virtual machine's:
  the function stays on the virtual machine (the same results, slower).
  ``OPTDESIGN_CODEGEN=0``, or ``OPTDESIGN_FAST=0``, keeps it there.
"""
from __future__ import annotations

import hashlib
import os
import platform
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["ENV_VAR", "CACHE_VAR", "FLAGS", "compiled", "library", "cache_dir", "compiler", "same_bits"]

#: ``0`` (or false/off/no) keeps every CasADi function on the virtual machine
ENV_VAR = "OPTDESIGN_CODEGEN"
#: the folder of the compiled libraries (default: see the module docstring)
CACHE_VAR = "OPTDESIGN_CACHE_DIR"
#: the compiler's flags: IEEE operations as written (no contraction to fused multiply-add, no fast math)
FLAGS = ("-O1", "-ffp-contract=off", "-fno-fast-math", "-fPIC", "-shared")
#: the longest compile (s); past it the function stays on the virtual machine
TIMEOUT = 120.0

#: functions compiled (not loaded from the cache) in this process, by name (the tests read it)
compiles: list[str] = []


def _on() -> bool:
    from ..fast import enabled

    return enabled() and os.environ.get(ENV_VAR, "1").strip().lower() not in ("0", "false", "off", "no")


def compiler() -> list[str] | None:
    """The C compiler's command (``CC``, else the first of cc, gcc, clang on the PATH), or None."""
    cc = os.environ.get("CC", "").strip()
    if cc:
        cmd = shlex.split(cc)
        return cmd if shutil.which(cmd[0]) else None
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return [path]
    return None


def cache_dir() -> Path | None:
    """The folder of the compiled libraries (created), or None if none is writable."""
    env = os.environ.get(CACHE_VAR, "").strip()
    if env:
        candidates = [Path(env)]
    else:
        xdg = os.environ.get("XDG_CACHE_HOME", "").strip()
        user = Path(xdg) if xdg else Path.home() / ".cache"
        candidates = [Path(__file__).resolve().parent / "__pycache__", user / "optdesign"]
    for d in candidates:
        try:
            d.mkdir(parents=True, exist_ok=True, mode=0o700)
            if os.access(d, os.W_OK | os.X_OK):
                return d
        except OSError:
            continue
    return None


def _probe(fn) -> list[np.ndarray]:
    """A fixed input of fn's shape: distinct values in [0.2, 0.8] (well inside every mechanism's scale)."""
    out = []
    for i in range(fn.n_in()):
        k = fn.nnz_in(i)
        out.append(0.2 + 0.6 * ((np.arange(k) * 0.6180339887498949 + 0.1 * (i + 1)) % 1.0))
    return out


def same_bits(a, b) -> bool:
    """Whether the functions a and b give the same bits at :func:`_probe`'s input (their outputs' shapes too)."""
    if (a.n_in(), a.n_out()) != (b.n_in(), b.n_out()):
        return False
    if any(a.sparsity_in(i) != b.sparsity_in(i) for i in range(a.n_in())) or \
            any(a.sparsity_out(i) != b.sparsity_out(i) for i in range(a.n_out())):
        return False
    x = _probe(a)
    with np.errstate(all="ignore"):
        ra, rb = a(*x), b(*x)
    ra = ra if isinstance(ra, (list, tuple)) else [ra]
    rb = rb if isinstance(rb, (list, tuple)) else [rb]
    return all(np.array_equal(np.asarray(p, dtype=float), np.asarray(q, dtype=float), equal_nan=True)
               for p, q in zip(ra, rb))


def _load(name: str, path: Path, fn):
    import casadi as ca

    try:
        ext = ca.external(name, str(path))
    except Exception:  # noqa: BLE001 - a library CasADi cannot load: compiled again or the virtual machine
        return None
    return ext if same_bits(fn, ext) else None


def _build(source: str, cc: list[str], target: Path) -> bool:
    """Compile ``source`` into ``target`` (through a temporary file in its folder, then renamed)."""
    out = target.parent / f".{target.stem}-{os.getpid()}-{os.urandom(4).hex()}.so"
    try:
        with tempfile.TemporaryDirectory(prefix="optdesign-cg-") as tmp:
            src = Path(tmp) / "fn.c"
            src.write_text(source)
            p = subprocess.run(cc + list(FLAGS) + [str(src), "-o", str(out), "-lm"], capture_output=True,
                               timeout=TIMEOUT, stdin=subprocess.DEVNULL)
            if p.returncode != 0 or not out.exists():
                return False
            os.replace(out, target)
            return True
    except (OSError, subprocess.SubprocessError):
        return False
    finally:
        try:
            out.unlink()
        except OSError:
            pass


def library(fn) -> tuple[str, list[str], Path] | None:
    """(C source, compiler command, library path) of ``fn`` (the path need not
    exist yet), or None when it cannot be compiled here (switched off, no
    compiler, no writable folder, a function CasADi cannot write out as C)."""
    if not _on():
        return None
    cc = compiler()
    folder = cache_dir() if cc else None
    if folder is None:
        return None
    import casadi as ca

    try:
        gen = ca.CodeGenerator(f"{fn.name()}.c", {"with_header": False})
        gen.add(fn)
        source = gen.dump()
    except Exception:  # noqa: BLE001 - a function CasADi cannot write out as C stays on the virtual machine
        return None
    key = hashlib.sha256("\0".join([source, " ".join(cc), " ".join(FLAGS), ca.__version__, sys.platform,
                                    platform.machine()]).encode()).hexdigest()[:20]
    return source, cc, folder / f"casadi_{fn.name()}_{key}.so"


def compiled(fn):
    """``fn`` (a CasADi Function) as a compiled library when possible (see the
    module docstring), else ``fn`` itself.  The result has fn's name, inputs
    and outputs, and gives fn's bits."""
    got = library(fn)
    if got is None:
        return fn
    source, cc, target = got
    if target.exists():
        ext = _load(fn.name(), target, fn)
        if ext is not None:
            return ext
    if not _build(source, cc, target):
        return fn
    compiles.append(fn.name())
    ext = _load(fn.name(), target, fn)
    return fn if ext is None else ext
