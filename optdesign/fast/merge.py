"""Per-design statistics of a kernel, with the points it left to the numpy
path added: the one combination rule both compiled paths use."""
from __future__ import annotations

import numpy as np


def add_points(stats, counts, x, dd):
    """Statistics (sum, min, max, centred sum of squares) as four arrays (4, D)
    over ``counts`` (D,) points per design, with the values ``x`` (K,) of the
    designs ``dd`` (K,) added (Chan's pairwise update of the centred sum):
    the new (4, D) array.  Designs without points keep what they had."""
    D = counts.shape[0]
    nb = np.bincount(dd, minlength=D)
    n = counts + nb
    has_a, has_b = counts > 0, nb > 0
    with np.errstate(all="ignore"):
        sb = np.bincount(dd, weights=x, minlength=D)
        mb = sb / nb
        m2b = np.bincount(dd, weights=(x - mb[dd]) ** 2, minlength=D)
        lob = np.full(D, np.inf)
        np.minimum.at(lob, dd, x)
        hib = np.full(D, -np.inf)
        np.maximum.at(hib, dd, x)
        sa, loa, hia, m2a = stats
        delta = mb - sa / counts
        both = has_a & has_b
        return np.stack([np.where(both, sa + sb, np.where(has_b, sb, sa)),
                         np.where(both, np.minimum(loa, lob), np.where(has_b, lob, loa)),
                         np.where(both, np.maximum(hia, hib), np.where(has_b, hib, hia)),
                         np.where(both, m2a + m2b + delta * delta * counts * nb / n, np.where(has_b, m2b, m2a))])
