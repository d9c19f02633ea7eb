"""The digest a kernel file records of the other files compiled into it:
numba's cache watches only the file that defines a cached function, so each
kernel file (``kernels.py``, ``chain_kernels.py``) keeps the digest of its
other sources and compiles without the cache (with a warning) until it is
updated; the engine's tests check the recorded values."""
from __future__ import annotations

import hashlib
from pathlib import Path

__all__ = ["sources_digest"]


def sources_digest(sources) -> str:
    """sha256 (first 16 hex digits) of the files ``sources`` (paths relative to the package)."""
    h = hashlib.sha256()
    top = Path(__file__).parents[1]
    for rel in sources:
        h.update((top / rel).read_bytes())
    return h.hexdigest()[:16]
