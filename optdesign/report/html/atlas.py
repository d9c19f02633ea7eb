"""The atlas of the report: :mod:`optdesign.report.atlas` (one grid of its own for the
PNGs, the CSV and the page)."""
from ..atlas import DEFAULT_RESOLUTION, AtlasMap, atlas_map

__all__ = ["AtlasMap", "atlas_map", "DEFAULT_RESOLUTION"]
