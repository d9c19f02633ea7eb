"""Interval certificates of designs over the continuous workspace W
(docs/certificates.md): a branch and bound over boxes of W proves that every
pose of W is reachable and that the local constraints hold there, or finds a
witness pose that breaks one, or reports the share of W proved within a
budget of box evaluations.

Plain pieces in, no config: a mechanism instance, W's bounds (SI), the
singularity limit, the isotropy convention and optional stroke limits.
"""
from __future__ import annotations

__all__: list[str] = []
