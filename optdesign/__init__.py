"""optdesign: dimensional optimization of parallel mechanisms."""
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("optdesign")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = ["__version__"]
