"""What the reports read back from a run folder beside its data files: the
config it was run with, and the keys and labels of a run of a batch (the
hash of its resolved config, its swept values), which batch planning writes
into the manifest and the batch summary reads back."""
from __future__ import annotations

import hashlib
import json
import os
from typing import Any

from ..config import Config, parse_config
from ..runs import RunFolder

__all__ = ["config_of_folder", "config_key", "sweep_label"]


def config_of_folder(path: str | os.PathLike) -> Config:
    """The config a run folder was run with (its config.yaml, the safe loader)."""
    folder = RunFolder(path)
    cfg = parse_config(folder.config_text(), source=str(folder.path / "config.yaml"), run_folder=True)
    name = folder.read_manifest(strict=False).get("config_name")
    if isinstance(name, str) and name:
        cfg.name = name
    return cfg


def config_key(config_text: str) -> str:
    """A short hash of a resolved config's text (the same for every seed)."""
    return hashlib.sha256(config_text.encode("utf-8")).hexdigest()[:12]


def _label(dotted: str, value: Any) -> str:
    """A short label for one swept value: ``m_platform=6``, ``x=-0.05..0.05``."""
    last = dotted.split(".")[-1]
    if isinstance(value, (list, tuple)) and len(value) == 2 and all(isinstance(v, (int, float)) for v in value):
        return f"{last}={value[0]:g}..{value[1]:g}"
    if isinstance(value, float):
        return f"{last}={value:g}"
    if isinstance(value, (dict, list)):
        text = json.dumps(value, separators=(',', ':'))
    else:
        text = str(value)
    if not text.isprintable():          # one line whatever the value (the label heads a YAML file)
        text = text.encode("unicode_escape").decode("ascii")
    return f"{last}={text[:80] + '...' if len(text) > 80 else text}"


def sweep_label(sweep: dict | None) -> str:
    """The swept values of one run as a label: ``m_platform=6, x=-0.05..0.05``."""
    return ", ".join(_label(k, v) for k, v in (sweep or {}).items())
