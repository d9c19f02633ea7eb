"""The physical quantities of a described mechanism, checked per design: a
mass or an inertia is not negative, the platform's inertia matrix is positive
semi-definite, a rod ``count`` is a whole number from 1 to :data:`MAX_COUNT`,
a rod's or crank's ``centre`` is a fraction in [0, 1], a strut part's
``centre`` and a rod's ``width`` are not negative lengths, and gravity lies in
[0, :data:`MAX_GRAVITY`] m/s^2.

:func:`problems` gives, per quantity, the designs (a boolean array of the
design shape) where it is invalid; the loader checks the named designs and
the corners of the bounds with :func:`first_problem`, and an evaluation
makes every design :func:`invalid` marks infeasible (its indices not finite).
"""
from __future__ import annotations

import numpy as np

from .constants import Constants
from .spec import Description

__all__ = ["MAX_COUNT", "MAX_GRAVITY", "problems", "invalid", "first_problem"]

#: most rods one leg may stand for (a parallelogram is 2; a few more rods in parallel are plausible)
MAX_COUNT = 100
#: largest gravity a description may give, m/s^2 (about 100 g)
MAX_GRAVITY = 1000.0

#: body key -> (rule, what is expected)
_RULES = {
    "slider_mass": ("nonneg", "a mass >= 0 kg"), "crank_mass": ("nonneg", "a mass >= 0 kg"),
    "rod_mass": ("nonneg", "a mass >= 0 kg"), "lower_mass": ("nonneg", "a mass >= 0 kg"),
    "upper_mass": ("nonneg", "a mass >= 0 kg"),
    "crank_inertia": ("nonneg", "an inertia >= 0 kg m^2"), "rod_inertia": ("nonneg", "an inertia >= 0 kg m^2"),
    "lower_inertia": ("nonneg", "an inertia >= 0 kg m^2"), "upper_inertia": ("nonneg", "an inertia >= 0 kg m^2"),
    "rod_count": ("count", f"a whole number of rods from 1 to {MAX_COUNT}"),
    "rod_centre": ("fraction", "a fraction of the rod in [0, 1]"),
    "crank_centre": ("fraction", "a fraction of the crank in [0, 1]"),
    "lower_centre": ("nonneg", "a distance >= 0 m"), "upper_centre": ("nonneg", "a distance >= 0 m"),
    "rod_width": ("nonneg", "a width >= 0 m"),
}


def _bad(rule: str, v: np.ndarray) -> np.ndarray:
    """Where v breaks the rule (the caller holds numpy's errors off)."""
    if rule == "nonneg":
        return ~(v >= 0)
    if rule == "fraction":
        return ~((v >= 0) & (v <= 1))
    if rule == "count":
        return ~((v >= 1) & (v <= MAX_COUNT) & (v == np.floor(v)))
    return ~((v >= 0) & (v <= MAX_GRAVITY))          # gravity


def problems(desc: Description, C: Constants):
    """[(key path, what is expected, values, bad)]: every physical quantity
    the description gives, its values (the design shape) and where it is invalid."""
    with np.errstate(all="ignore"):     # once: an evaluation asks for every design it makes
        return _problems(desc, C)


def _problems(desc: Description, C: Constants):
    out = []
    if desc.platform.mass is not None:
        m = np.asarray(C.m_platform, dtype=float)
        out.append(("mechanism.platform.mass", "a mass >= 0 kg", m, _bad("nonneg", m)))
        I = np.asarray(C.I_platform, dtype=float)
        ok = np.all(np.isfinite(I), axis=(-1, -2))
        lam = np.linalg.eigvalsh(np.where(ok[..., None, None], I, 0.0))
        scale = np.max(np.abs(lam), axis=-1)
        low = lam[..., 0]
        bad = ~ok | (low < -1e-12 * scale)
        out.append(("mechanism.platform.inertia", "a positive semi-definite inertia (kg m^2)", low, bad))
    g = np.asarray(C.g, dtype=float)
    out.append(("mechanism.gravity", f"a gravity in [0, {MAX_GRAVITY:g}] m/s^2", g, _bad("gravity", g)))
    for i, leg in enumerate(desc.legs):
        for key in leg.bodies:
            if key not in _RULES:
                continue
            rule, what = _RULES[key]
            part, name = key.split("_", 1)
            v = np.asarray(C.body[key][..., i], dtype=float)
            out.append((f"{leg.path}.{part}.{name}", what, v, _bad(rule, v)))
    return out


def invalid(desc: Description, C: Constants) -> np.ndarray:
    """Designs (the design shape) where some physical quantity is invalid."""
    bad = np.zeros(C.shape, dtype=bool)
    for _, _, _, b in problems(desc, C):
        bad = bad | b
    return bad


def first_problem(desc: Description, C: Constants) -> tuple[str, str] | None:
    """(key path, message) of the first invalid quantity of one design, else None."""
    for path, what, v, b in problems(desc, C):
        if np.any(b):
            x = float(np.ravel(v)[np.flatnonzero(np.ravel(b))[0]]) if np.size(v) > 1 else float(np.ravel(v)[0])
            if path.endswith("inertia") and path.startswith("mechanism.platform"):
                return path, f"expected {what}, got a smallest principal value of {x:.6g}"
            return path, f"expected {what}, got {x:.6g}"
    return None
