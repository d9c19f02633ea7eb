"""Interval arithmetic over numpy arrays (outward rounding), interval
forward-mode derivatives for mean-value forms, and rigorous bounds of
condition numbers of interval matrices.  A plain helper: it imports no other
part of the package, so every layer may use it (the mechanisms' enclosures,
the certificates)."""
