"""The outward rounding of :mod:`optdesign.intervals.interval`, compiled: one
double up or down from each element of a large array, bit for bit what
``np.nextafter`` gives (numpy calls libm's nextafter per element, about 5 ns;
this steps the bits, about 1 ns).  Loaded through
:class:`optdesign.fast.KernelModule`: without numba, or with the compiled
paths switched off, np.nextafter runs instead."""
from __future__ import annotations

import numpy as np
from numba import njit

from ..fast._jit import NJIT

_SIGNED_ZERO = -9223372036854775808          # -0.0's bits read as an int64
_EXPONENT = 0x7FF0000000000000
_MANTISSA = 0x000FFFFFFFFFFFFF


@njit(**NJIT)
def steps(a, one):
    """The doubles next to the contiguous 1-d float array ``a`` toward +inf
    (``one`` = 1) or -inf (``one`` = -1).  A double's bits read as an int64
    grow with its magnitude for a positive double and fall with it for a
    negative one, so the step is ``+one`` for a positive and ``-one`` for a
    negative double; a signed zero steps to the smallest subnormal of the
    step's sign, an infinity in the step's direction stays, NaN is libm's."""
    b = a.view(np.int64)
    out = np.empty_like(b)
    toward = np.inf * one
    for i in range(b.size):
        x = b[i]
        if x == 0 or x == _SIGNED_ZERO:
            out[i] = one if one > 0 else _SIGNED_ZERO + 1
        elif (x & _EXPONENT) == _EXPONENT and (x & _MANTISSA) != 0:      # NaN
            out[i] = np.array([np.nextafter(a[i], toward)]).view(np.int64)[0]
        elif (x & _EXPONENT) == _EXPONENT and (x > 0) == (one > 0):      # inf, stepping outward
            out[i] = x
        elif x > 0:
            out[i] = x + one
        else:
            out[i] = x - one
    return out.view(np.float64)
