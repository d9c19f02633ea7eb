"""The batch-file schema: a base config, seeds and a sweep of dotted keys.

A **batch file** (YAML) names a base config, the seeds and a sweep (see
:func:`load_batch_file` and ``docs/scaling.md``); each combination of the
sweep gives one resolved config text, validated like a config file.  This
module only reads and checks files: it depends on :mod:`optdesign.config`'s
public API and on nothing that runs anything.
"""
from __future__ import annotations

import copy
import itertools
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..config import ConfigError, load_config, parse_config, yamlsafe
from ..config.reader import plain, shorten, suggest
from ..names import name_problem
from ..report.folders import sweep_label

__all__ = ["BatchFile", "is_batch_file", "load_batch_file"]

_BATCH_KEYS = {"base", "name", "seeds", "mode", "sweep", "set", "pareto"}
#: sections of a config a sweep (or ``set``) may change
_SWEEPABLE = {"parameters", "design_variables", "workspace", "indices", "optimizer"}
_MAX_COMBINATIONS = 10_000


def is_batch_file(path: str | os.PathLike) -> bool:
    """True if the YAML file is a batch file (a mapping with a ``base`` or ``sweep`` key)."""
    try:
        data, _ = yamlsafe.load_file(path)
    except ConfigError:  # not readable: let load_config report it
        return False
    return isinstance(data, dict) and ("base" in data or "sweep" in data)


@dataclass
class BatchFile:
    """A parsed batch file: one resolved config text per sweep combination."""

    source: str
    name: str
    seeds: list[int] | None
    pareto: bool
    combinations: list[tuple[str, str, dict]]   # (run name, resolved config text, swept values)


def _fail(source: str, path: str, message: str):
    raise ConfigError(source, path, message)


def _resolve_path(data: dict, dotted: str, source: str, where: str, base_src: str):
    """The mapping holding the last key of ``dotted`` in ``data``, and that key."""
    parts = dotted.split(".")
    if any(p == "" for p in parts):
        _fail(source, where, f"expected a dotted key such as parameters.m_platform, got {shorten(dotted)}")
    if parts[0] not in _SWEEPABLE:
        _fail(source, where, f"can only change keys under {', '.join(sorted(_SWEEPABLE))}; got "
                             f"{shorten(parts[0])}{suggest(parts[0], _SWEEPABLE)}")
    if len(parts) < 2:
        _fail(source, where, f"expected a key inside {parts[0]} (such as {parts[0]}.<name>), not the whole section")
    if parts[:2] == ["optimizer", "seed"]:
        _fail(source, where, "the seed is not swept here: use the batch file's 'seeds' (or --seeds)")
    node: Any = data
    for i, p in enumerate(parts[:-1]):
        if not isinstance(node, dict) or p not in node:
            _fail(source, where, f"{base_src} has no key {shorten('.'.join(parts[:i + 1]))}"
                                 f"{suggest(p, node) if isinstance(node, dict) else ''}")
        node = node[p]
        if node is None:
            node = {}
            _set_none(data, parts[:i + 1])
    if not isinstance(node, dict):
        _fail(source, where, f"{base_src}: {'.'.join(parts[:-1])} is not a mapping")
    return node, parts[-1]


def _set_none(data: dict, parts: list[str]) -> None:
    node = data
    for p in parts[:-1]:
        node = node[p]
    if node[parts[-1]] is None:
        node[parts[-1]] = {}


def _apply(data: dict, dotted: str, value: Any, source: str, where: str, base_src: str) -> None:
    holder, key = _resolve_path(data, dotted, source, where, base_src)
    holder[key] = copy.deepcopy(value)


def load_batch_file(path: str | os.PathLike) -> BatchFile:
    """Read and validate a batch file; every mistake is a one-line ConfigError.

    Schema (YAML)::

        base: p4s_paper.yaml        # required: config to vary (relative to this file)
        name: p4s_sweep             # optional: run name prefix (default: the base config's name)
        seeds: 3                    # optional: N seeds from the base's optimizer.seed, or a list [1, 2, 5]
        mode: grid                  # grid (every combination, default) or zip (i-th values together)
        sweep:                      # dotted key in the base config -> list of values (one run per value)
          parameters.m_platform: [4.16, 6.0]
          workspace.axes.x: [[-0.03, 0.03], [-0.05, 0.05]]
        set:                        # optional: fixed changes applied to every run
          optimizer.generations: 50
        pareto: false               # optional: also run the NSGA-II/III fronts

    Keys may lie under parameters, design_variables, workspace, indices and
    optimizer (not optimizer.seed).  Each combination's resolved config is
    validated like a config file.
    """
    source = str(path)
    p = Path(path)
    raw, _ = yamlsafe.load_file(path, what="YAML batch file")
    if not isinstance(raw, dict):
        _fail(source, "", "expected a mapping with 'base' and 'sweep'")
    for k in raw:
        if k not in _BATCH_KEYS:
            _fail(source, shorten(k)[1:-1] if isinstance(k, str) else shorten(k),
                  f"unknown key{suggest(k, _BATCH_KEYS)}; expected one of {', '.join(sorted(_BATCH_KEYS))}")
    if "base" not in raw:
        _fail(source, "base", "missing required key (the config file to vary)")
    base = raw.get("base")
    if not isinstance(base, str) or not base:
        _fail(source, "base", "expected the path of a config file")
    base_path = Path(base) if Path(base).is_absolute() else p.parent / base
    if not base_path.exists() and not base_path.is_symlink():
        _fail(source, "base", f"config file not found: {plain(str(base_path))}")
    base_cfg = load_config(base_path)        # a mistake in the base names the base file
    base_src = str(base_path)
    base_data = yamlsafe.load(base_cfg.text, base_src)   # the text just read and validated

    name = raw.get("name", base_cfg.name)
    problem = name_problem(name)
    if problem:
        _fail(source, "name", f"{problem}, got {shorten(name)}")

    seeds = None
    if "seeds" in raw:
        s = raw["seeds"]
        if isinstance(s, bool) or not isinstance(s, (int, list)):
            _fail(source, "seeds", f"expected a count or a list of seeds, got {type(s).__name__}")
        if isinstance(s, int):
            if not 1 <= s <= 100_000:
                _fail(source, "seeds", f"expected a count between 1 and 100000, got {s}")
            seeds = [base_cfg.optimizer.seed + i for i in range(s)]
        else:
            if not s:
                _fail(source, "seeds", "expected at least one seed")
            for i, v in enumerate(s):
                if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < 2 ** 32:
                    _fail(source, f"seeds[{i}]", f"expected an integer in [0, 2^32), got {shorten(v)}")
            seeds = [int(v) for v in s]

    pareto = raw.get("pareto", False)
    if not isinstance(pareto, bool):
        _fail(source, "pareto", f"expected true or false, got {shorten(pareto)}"
                                + (" (yes/no/on/off are strings here)" if isinstance(pareto, str) else ""))
    mode = raw.get("mode", "grid")
    if mode not in ("grid", "zip"):
        _fail(source, "mode", f"expected grid or zip, got {shorten(mode)}{suggest(mode, ('grid', 'zip'))}")

    data = copy.deepcopy(base_data)
    fixed = raw.get("set") or {}
    if not isinstance(fixed, dict):
        _fail(source, "set", "expected a mapping of dotted keys to values")
    for k, v in fixed.items():
        _apply(data, str(k), v, source, f"set.{k}", base_src)

    sweep = raw.get("sweep") or {}
    if not isinstance(sweep, dict):
        _fail(source, "sweep", "expected a mapping of dotted keys to lists of values")
    keys = [str(k) for k in sweep]
    for k in keys:
        vals = sweep[k]
        if not isinstance(vals, list) or not vals:
            _fail(source, f"sweep.{k}", "expected a non-empty list of values (one run per value)")
        _resolve_path(copy.deepcopy(data), k, source, f"sweep.{k}", base_src)
    if mode == "zip" and keys:
        lens = {k: len(sweep[k]) for k in keys}
        if len(set(lens.values())) > 1:
            _fail(source, "sweep", "zip mode needs lists of equal length; got "
                  + ", ".join(f"{k}: {n}" for k, n in lens.items()))
        combos = [tuple(sweep[k][i] for k in keys) for i in range(len(sweep[keys[0]]))]
    else:
        n = math.prod(len(sweep[k]) for k in keys) if keys else 1
        if n > _MAX_COMBINATIONS:
            _fail(source, "sweep", f"grid gives {n} combinations; expected at most {_MAX_COMBINATIONS}")
        combos = list(itertools.product(*(sweep[k] for k in keys)))

    width = len(str(len(combos) - 1))
    out = []
    for i, combo in enumerate(combos):
        d = copy.deepcopy(data)
        for k, v in zip(keys, combo):
            _apply(d, k, v, source, f"sweep.{k}", base_src)
        run_name = f"{name}-c{i:0{width}d}" if keys else name
        if name_problem(run_name):
            _fail(source, "name", f"the run names ({run_name[:20]}...) would have {len(run_name)} characters; "
                                  "expected a shorter name")
        d["name"] = run_name
        label = sweep_label(dict(zip(keys, combo)))
        header = f"# resolved from base {Path(base).name}" + (f"; sweep: {label}" if label else "") + "\n"
        text = header + yamlsafe.dump(d, sort_keys=False, default_flow_style=None, allow_unicode=True)
        try:
            parse_config(text, source=source)
        except ConfigError as exc:
            blame = next((k for k in keys if exc.path and (exc.path == k or exc.path.startswith(k + ".")
                                                            or k.startswith(exc.path + "."))), None)
            if blame is not None:
                _fail(source, f"sweep.{blame}", f"value {shorten(combo[keys.index(blame)])} gives {exc.path}: {exc.message}")
            what = f"combination {i} ({label})" if label else "the resolved config"
            _fail(source, "set" if fixed and not label else "sweep", f"{what} gives {exc.path or 'config'}: {exc.message}")
        out.append((run_name, text, dict(zip(keys, combo))))
    return BatchFile(source, name, seeds, pareto, out)
