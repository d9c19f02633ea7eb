"""optdesign: dimensional optimization of parallel mechanisms.

The Python API (``docs/python-api.md``)::

    import optdesign as od
    cfg = od.load_config("configs/p4s_paper.yaml")        # or od.config_from_dict({...})
    ev = od.evaluate(cfg, [cfg.design("before"), cfg.design("after")])
    mech = od.build(cfg, "after")                        # a Mechanism: inverse, forward, jacobian, ...
    f = od.Evaluator.from_config(cfg)                    # design vectors -> indices and constraints

The names below are imported on first use, so ``import optdesign`` stays cheap.
"""
import sys as _sys
import types as _types
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("optdesign")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

#: public name -> module that defines it
_EXPORTS = {
    "load_config": "optdesign.config", "parse_config": "optdesign.config", "config_from_dict": "optdesign.config",
    "Config": "optdesign.config", "ConfigError": "optdesign.config",
    "evaluate": "optdesign.evaluate", "evaluate_named": "optdesign.evaluate", "Evaluator": "optdesign.evaluate",
    "build": "optdesign.evaluate", "workspace_of": "optdesign.evaluate",
    "Mechanism": "optdesign.mechanisms", "get_mechanism": "optdesign.mechanisms",
    "available_mechanisms": "optdesign.mechanisms",
}
_RENAMED = {"get_mechanism": "get", "available_mechanisms": "available"}

__all__ = ["__version__", *_EXPORTS]


class _Package(_types.ModuleType):
    """The package's module: an export that shares its name with a submodule
    (``evaluate``) stays the export when the submodule is imported (the import
    system binds ``optdesign.evaluate`` on the package; the module stays in
    ``sys.modules`` and ``from optdesign.evaluate import ...`` works as ever)."""

    def __setattr__(self, name, value):
        if (name in _EXPORTS and isinstance(value, _types.ModuleType)
                and value.__name__ == f"{__name__}.{name}"):
            value = getattr(value, _RENAMED.get(name, name))
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package


def __getattr__(name):
    if name in _EXPORTS:
        obj = getattr(import_module(_EXPORTS[name]), _RENAMED.get(name, name))
        globals()[name] = obj
        return obj
    raise AttributeError(f"module 'optdesign' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
