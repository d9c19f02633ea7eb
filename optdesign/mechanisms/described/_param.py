"""The fields of a parameter declaration (``Param`` of optdesign/mechanisms/params.py),
for trees where that table does not exist yet."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Param:
    name: str
    kind: str
    default: Any = None
    design: bool = False
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: Any = None
    integer: bool = False
    doc: str = ""
