"""The compile-time choices of the engine's specialized tier for one mechanism
shape (:class:`KernelSpec`), and the numba arguments that carry them into the
kernels (:mod:`.kernels` reads them back inside its @overloads)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["KernelSpec", "size_of_type"]


@dataclass(frozen=True)
class KernelSpec:
    """The compile-time choices of the kernel for one mechanism shape.

    kinds: the kind of each pose column of J = G S (0..5 a twist component,
    CT_ROLL / CT_PITCH roll's / pitch's Euler column), one per leg, so n =
    len(kinds); rods: some leg has a rod (the K rows and delta terms of M_p);
    rot: the pose has angles (the frame data holds R)."""

    kinds: tuple[int, ...]
    rods: bool
    rot: bool

    def __post_init__(self):
        object.__setattr__(self, "kinds", tuple(int(k) for k in self.kinds))
        object.__setattr__(self, "rods", bool(self.rods))
        object.__setattr__(self, "rot", bool(self.rot))

    @property
    def n(self) -> int:
        return len(self.kinds)

    # ------------------------------------------------------------------ the call boundary
    # numba specializes a compiled function on the *types* of its arguments
    # only, so a choice the generated code depends on must be part of an
    # argument's type: the size n is the length of a tuple of zeros (``nt``),
    # the rest the field names of a record dtype (``cspec``: an array (1,)
    # whose fields k<i>_<kind>, rods_<0|1>, rot_<0|1> say them).  Both are
    # types numba dispatches on, caches and passes through the parallel loop
    # as they are (a numba type of the spec itself would need a typeof, a data
    # model and unboxing of its own).  Made here, read back here (an @overload
    # sees the types), nowhere else.
    def numba_args(self) -> tuple[tuple, np.ndarray]:
        """(nt, cspec): the arguments that carry this spec into the kernel."""
        fields = ([(f"k{i}_{k}", "u1") for i, k in enumerate(self.kinds)]
                  + [(f"rods_{int(self.rods)}", "u1"), (f"rot_{int(self.rot)}", "u1")])
        return (0,) * self.n, np.zeros(1, dtype=np.dtype(fields))

    @classmethod
    def of_type(cls, cspec_type) -> KernelSpec:
        """The spec from the numba type of ``cspec`` (inside an @overload)."""
        names = list(cspec_type.dtype.fields.keys())
        kinds = [int(nm.split("_")[1]) for nm in names if nm.startswith("k")]
        return cls(tuple(kinds), "rods_1" in names, "rot_1" in names)


def size_of_type(nt_type) -> int:   # the size n from the numba type of ``nt`` (a tuple of n zeros)
    return nt_type.count
