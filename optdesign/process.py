"""Settings of a process that is optdesign's own: the command's process and a
run's stage workers (not a caller's Python process that calls into the package).

CPython's cyclic garbage collector examines its youngest generation every 700
net allocations of container objects by default, and promotes what survives;
a command imports numba, scipy, pymoo, matplotlib and plotly (hundreds of
thousands of objects, all of them surviving) and then runs an optimizer that
creates many short-lived objects, so the collector runs thousands of times
and its older generations, scanned whole, hold every imported object.  With
the youngest generation examined every :data:`GC_THRESHOLD` allocations a
short run (``optdesign run`` of the tests' small configs) takes 6-10 % less
CPU (docs/performance.md).  The results do not depend on it: the
collector frees unreachable objects only.
"""
from __future__ import annotations

import gc

__all__ = ["GC_THRESHOLD", "tune_collector"]

#: net allocations between two collections of the youngest generation in optdesign's own processes
GC_THRESHOLD = 10_000


def tune_collector() -> None:
    """Raise the youngest generation's threshold to :data:`GC_THRESHOLD` (the
    older generations' as they are); nothing where the collector is off or
    already collects less often."""
    first, *rest = gc.get_threshold()
    if 0 < first < GC_THRESHOLD:
        gc.set_threshold(GC_THRESHOLD, *rest)
