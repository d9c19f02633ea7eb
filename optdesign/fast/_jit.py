"""What the compiled kernel modules share: numba's options and an explicit
fused multiply-add."""
from __future__ import annotations

from numba.core import types
from numba.extending import intrinsic

#: cached, numpy's error model (division by zero gives inf/NaN, no exception),
#: no fast-math: the kernels' results must not depend on the compiler's choices
NJIT = dict(cache=True, error_model="numpy", fastmath=False)


@intrinsic
def fma(typingctx, a, b, c):
    """a * b + c with one rounding (llvm.fma: one instruction where the CPU has FMA)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen
