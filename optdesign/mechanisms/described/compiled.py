"""The compiled path of described mechanisms (numba): see _kernels.py."""
from __future__ import annotations


def global_statistics(mech, requests, X, want_max_cond=False):
    return None
