"""YAML configuration: parsing and validation into typed, plain objects (SI).

* :mod:`.keys` — the key table: every key's type, default, unit, doc and
  constraint, from which the allowed keys, the spec dataclasses, the checks
  and the key tables of docs/config.md (:mod:`.keydocs`) are made;
* :mod:`.reader` — :class:`ConfigError` and typed access with key-path errors
  (the package's one validation toolkit, :mod:`optdesign.checking`);
* :mod:`.schema` — the validated objects (:class:`Config`, :class:`DesignVariable`, ...);
* :mod:`.loader` — :func:`load_config` (a file), :func:`parse_config` (a text),
  :func:`config_from_dict` (a mapping, e.g. built in Python);
* :mod:`.sections` — the workspace and optimizer sections; :mod:`.checks` the checks section.
"""
from ..workspace import WorkspaceSpec
from .loader import from_mapping, load_config, parse_config
from .reader import ConfigError
from .schema import Config, DesignVariable, IndexSpec, OptimizerSpec


def config_from_dict(data: dict, source: str = "<dict>") -> Config:
    """A validated Config from a mapping with the keys of a config file."""
    return from_mapping(data, source)


__all__ = ["ConfigError", "Config", "DesignVariable", "WorkspaceSpec", "IndexSpec", "OptimizerSpec",
           "load_config", "parse_config", "config_from_dict"]
