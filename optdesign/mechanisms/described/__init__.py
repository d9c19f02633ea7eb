"""Mechanisms described as data: legs, joints and dimensions in the config.

A config's ``mechanism:`` may be a mapping instead of a registered name::

    mechanism:
      parameters: {R_b: length, R_p: length, m_platform: {kind: mass, default: 10}}
      pose: {type: spatial, home: {z: 0.7}}
      platform: {mass: m_platform}
      legs:
        - kind: strut
          actuator: l
          pattern: {angles: [0, 120, 240], unit: deg, split: {base: 0.5, platform: 1.7}}
          base: [R_b, 0, 0]
          platform: [R_p, 0, 0]

:func:`register_description` (reached through ``optdesign.mechanisms.describe``)
validates it (:mod:`.schema`), builds a :class:`~.mechanism.DescribedMechanism`
subclass (:func:`.mechanism.make_class`) and registers it under a name derived
from the description's content.  The class pickles as its description (a
config sent to a worker process rebuilds it there).  Kinematics, Jacobian,
dynamics and the compiled path are derived once per leg kind and pose type;
see docs/mechanisms-as-data.md.
"""
from __future__ import annotations

import copyreg
import hashlib
import json
from typing import Any, Mapping

from .. import DescriptionError
from .schema import Description, parse_description

__all__ = ["DescriptionError", "Description", "register_description", "build_class", "parse_description"]

#: bounds on the size of a description (nodes of the YAML tree, nesting depth)
MAX_NODES = 20_000
MAX_DEPTH = 24


def _measure(v: Any, path: str, depth: int, count: list) -> None:
    count[0] += 1
    if count[0] > MAX_NODES:
        raise DescriptionError(path, f"description too large (more than {MAX_NODES} entries)")
    if depth > MAX_DEPTH:
        raise DescriptionError(path, f"description nested deeper than {MAX_DEPTH} levels")
    if isinstance(v, Mapping):
        for k, x in v.items():
            _measure(x, f"{path}.{k}", depth + 1, count)
    elif isinstance(v, (list, tuple)):
        for i, x in enumerate(v):
            _measure(x, f"{path}[{i}]", depth + 1, count)


def _canonical(raw: Any) -> str:
    return json.dumps(raw, sort_keys=True, separators=(",", ":"), default=repr)


def build_class(raw: Any, label: str | None = None, path: str = "mechanism"):
    """The Mechanism subclass of a description (not registered)."""
    from .mechanism import make_class

    _measure(raw, path, 0, [0])
    desc: Description = parse_description(raw, path, label)
    digest = hashlib.sha256(_canonical(raw).encode()).hexdigest()[:12]
    cls = make_class(desc, f"{desc.label}@{digest}")
    cls.raw_description = (raw, label, path)
    return cls


def register_description(raw: Any, label: str | None = None, path: str = "mechanism"):
    """Validate a description, register its class (optdesign.mechanisms.get finds
    it by name) and return the class.  Raises DescriptionError (key path, message)."""
    from .. import register_described

    return register_described(build_class(raw, label, path))


def _rebuild(raw, label, path):
    return register_description(raw, label, path)


def _reduce(cls):
    return (_rebuild, cls.raw_description)


def _install_pickling():
    from .mechanism import DescribedMeta

    copyreg.pickle(DescribedMeta, _reduce)


_install_pickling()
