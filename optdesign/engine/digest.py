"""Digests of the engine's sources, for numba's cache.

numba's cache watches only the file that defines a cached function, so:

* each kernel file (``kernels.py``, ``chain_kernels.py``) records the digest
  of its other sources and compiles without the cache (with a warning) until
  it is updated; the engine's tests check the recorded values;
* the engine's routines compiled into the kernels (:func:`leaf`) are cached
  too, so that every kernel that calls one, in any process, loads it instead
  of compiling it again; their cache files are named with the digest of every
  file of :data:`LEAF_SOURCES`, so an edit of any of them compiles them anew
  and a stale one is never loaded.
"""
from __future__ import annotations

import hashlib
from functools import lru_cache
from pathlib import Path

__all__ = ["sources_digest", "LEAF_SOURCES", "leaf", "keyed"]

#: the files whose code or numbers the engine's routines compile in (paths relative to the package)
LEAF_SOURCES = ("engine/kernels.py", "engine/legs.py", "engine/inverse.py", "engine/eigen.py", "engine/mass.py",
                "engine/layout.py", "engine/codegen.py", "engine/spec.py", "formulas.py", "fast/_jit.py",
                "engine/chain_kernels.py", "engine/chain_layout.py", "engine/chain_dense.py", "engine/chain_closure.py",
                "engine/chain_bodies.py")


def sources_digest(sources, top=None) -> str:
    """sha256 (first 16 hex digits) of the files ``sources`` (paths relative
    to ``top``, by default the package's folder)."""
    h = hashlib.sha256()
    top = Path(__file__).parents[1] if top is None else Path(top)
    for rel in sources:
        h.update((top / rel).read_bytes())
    return h.hexdigest()[:16]


@lru_cache(maxsize=1)
def leaf_key() -> str:
    """The digest of :data:`LEAF_SOURCES` that names the routines' cache files."""
    return sources_digest(LEAF_SOURCES)[:12]


def keyed(fn):
    """fn, its qualified name (which names numba's cache files of it) carrying :func:`leaf_key`."""
    if not fn.__qualname__.endswith(leaf_key()):
        fn.__qualname__ = f"{fn.__qualname__}__{leaf_key()}"
    return fn


def leaf(fn=None, **options):
    """``numba.extending.register_jitable`` (the kernels' options, updated by
    ``options``) with numba's cache on: compiled once per signature and
    machine, then loaded by every kernel that calls it (the kernels link its
    code and inline it as before, so the machine code they run is the same).
    Its qualified name, which names its cache files, carries
    :func:`leaf_key`."""
    if fn is None:
        return lambda f: leaf(f, **options)
    from numba.extending import register_jitable

    from ..fast._jit import JITABLE

    return register_jitable(**{**JITABLE, **options, "cache": True})(keyed(fn))
