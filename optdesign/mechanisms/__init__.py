"""Mechanism registry.

>>> from optdesign.mechanisms import get
>>> mech = get("p4s")(r_a=0.25, r_b=0.67, L=0.38, d=0.12, phi=0.5236)

Each mechanism module defines one :class:`~optdesign.mechanisms.base.Mechanism`
subclass and registers it with :func:`register`.  Adding a mechanism is one
module here plus one line in ``_MODULES``.
"""
from __future__ import annotations

import importlib

from .base import Mechanism

_REGISTRY: dict[str, type[Mechanism]] = {}
# name -> module that defines it (imported lazily so a broken optional module
# never stops the others from loading)
_MODULES = {
    "p4s": "optdesign.mechanisms.p4s",
    "ups_upr_s": "optdesign.mechanisms.ups_upr_s",
    "cpr_rrr": "optdesign.mechanisms.cpr_rrr",
    "sps_s": "optdesign.mechanisms.sps_s",
}


def register(cls: type[Mechanism]) -> type[Mechanism]:
    """Class decorator: make a mechanism available under ``cls.name``."""
    _REGISTRY[cls.name] = cls
    return cls


#: mechanisms built from descriptions in configs (optdesign.mechanisms.described);
#: found by get(), not listed by available()
_DESCRIBED: dict[str, type[Mechanism]] = {}


class DescriptionError(ValueError):
    """A mistake in a mechanism description: ``path`` (the config key path,
    e.g. ``mechanism.legs[0].rod``) and a one-line ``message``."""

    def __init__(self, path: str, message: str):
        self.path = path
        self.message = message
        super().__init__(f"{path}: {message}")


def register_described(cls: type[Mechanism]) -> type[Mechanism]:
    """Make a described mechanism's class available under ``cls.name``."""
    _DESCRIBED[cls.name] = cls
    return cls


def describe(raw, label: str | None = None) -> type[Mechanism]:
    """The class of a mechanism described as data (a config's ``mechanism:``
    mapping, see docs/mechanisms-as-data.md), registered under a name derived
    from its content.  Raises :class:`DescriptionError` naming the key."""
    return importlib.import_module("optdesign.mechanisms.described").register_description(raw, label=label)


def available() -> list[str]:
    """Names of the mechanisms that can be built."""
    names = []
    for name, mod in _MODULES.items():
        if name in _REGISTRY:
            names.append(name)
            continue
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as exc:
            if exc.name == mod:
                continue
            raise
        if name in _REGISTRY:
            names.append(name)
    return names + [n for n in _REGISTRY if n not in names]


def get(name: str) -> type[Mechanism]:
    """The mechanism class registered under ``name``."""
    if name in _DESCRIBED:
        return _DESCRIBED[name]
    if name not in _REGISTRY and name in _MODULES:
        try:
            importlib.import_module(_MODULES[name])
        except ModuleNotFoundError as exc:
            if exc.name != _MODULES[name]:
                raise
    if name not in _REGISTRY:
        raise KeyError(f"unknown mechanism {name!r}; available: {', '.join(available())}")
    return _REGISTRY[name]


def symbolic_model(name: str):
    """The builder of a registered mechanism's CasADi model (the module-level
    ``symbolic_model`` of the module that defines it, see optdesign.symbolic),
    or None: described mechanisms and mechanisms without one."""
    if name in _DESCRIBED or name not in _MODULES:
        return None
    get(name)
    return getattr(importlib.import_module(_MODULES[name]), "symbolic_model", None)


__all__ = ["Mechanism", "DescriptionError", "register", "register_described", "describe", "available", "get",
           "symbolic_model"]
