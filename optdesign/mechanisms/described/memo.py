"""What a described class keeps of the designs it evaluated last: their
constants (:mod:`.constants`) and the engine's packing of them
(:mod:`.packing`), keyed by the class and its parameters' values (an
optimizer makes a new mechanism for every design it visits, and visits many
twice: a polish's line search, the worst-case search per design)."""
from __future__ import annotations

import math

import numpy as np

__all__ = ["CONSTANTS", "PACKS", "PACK_DESIGNS", "pack_key", "params_key"]


class _Recent:
    """The last ``size`` values by key (first in, first out; no locking: a
    process's evaluations run on one thread)."""

    def __init__(self, size: int):
        self.size = size
        self.data: dict = {}

    def get(self, key):
        return self.data.get(key)

    def put(self, key, value) -> None:
        if len(self.data) >= self.size:
            self.data.pop(next(iter(self.data)))
        self.data[key] = value


#: constants of the designs evaluated last (any described class; keyed by its name and parameters)
CONSTANTS = _Recent(512)
#: the engine's packing of the same (optdesign.mechanisms.described.packing), of at most
#: PACK_DESIGNS designs (the polish's and the search's populations, which are evaluated again;
#: 512 packings of a GA's thousands of designs would hold gigabytes)
PACKS = _Recent(512)
PACK_DESIGNS = 64


def pack_key(mech) -> tuple:
    """The designs of ``mech`` as the engine's packing sees them: each
    parameter's value in every design (broadcast over the designs, whose
    shape (D, 1) counts as (D,)), so that (D, 1) and (D,) parameters, and a
    fixed value given once or per design, key alike (an evaluation's
    mechanism has the one, the worst-case search's the other); the packing
    of a design depends on its own values only."""
    key = mech.__dict__.get("_pack_key")
    if key is None:
        arrays = {k: np.asarray(v, dtype=float) for k, v in mech.params.items()}
        shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
        if len(shape) == 2 and shape[1] == 1:
            shape = shape[:1]
        if len(shape) > 1:                  # not a packing's designs: the parameters as they are
            return params_key(mech)
        flat = {k: a[:, 0] if a.ndim == 2 else a for k, a in arrays.items()}     # (D, 1) or (1, 1) as (D,)
        items = tuple((k, _bytes_as(a, shape)) for k, a in sorted(flat.items()))
        key = mech.__dict__["_pack_key"] = (type(mech).name, "pack", shape, items)
    return key


def params_key(mech) -> tuple:
    """The parameters' values of ``mech`` (class, names, shapes and bytes):
    equal keys, equal constants; computed once per mechanism."""
    key = mech.__dict__.get("_params_key")
    if key is None:
        items = []
        for k in sorted(mech.params):
            a = np.asarray(mech.params[k], dtype=float)
            items.append((k, a.shape, a.tobytes()))
        key = mech.__dict__["_params_key"] = (type(mech).name, tuple(items))
    return key


def _bytes_as(a: np.ndarray, shape: tuple) -> bytes:
    """The bytes of ``a`` broadcast to ``shape`` (a value given once: its bytes
    repeated, as the broadcast array's are)."""
    if a.shape == shape:
        return a.tobytes()
    if a.size == 1:
        return a.tobytes() * math.prod(shape)
    return np.broadcast_to(a, shape).tobytes()
