"""Global indices of designs over a workspace (the flow config -> mechanism ->
workspace -> local indices -> means over W), vectorized over a population."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from .config import Config
from .indices import INDEX_KINDS, global_summary, local_index
from .workspace import Workspace, sample

__all__ = ["Evaluation", "evaluate", "evaluate_named", "workspace_of"]


def workspace_of(config: Config) -> Workspace:
    from .mechanisms import get

    return sample(config.workspace, get(config.mechanism).pose_names)


@dataclass
class Evaluation:
    """Global (and optionally local) index values of D designs over N points.

    ``summary[index]`` maps ``mean``/``min``/``max``/``std`` to arrays (D,),
    ``reachable_fraction`` is (D,), ``local[index]`` (D, N) if kept.
    """

    summary: dict[str, dict[str, np.ndarray]]
    reachable: np.ndarray           # (D, N)
    reachable_fraction: np.ndarray  # (D,)
    local: dict[str, np.ndarray] | None
    workspace: Workspace


def _stack_designs(config: Config, designs) -> dict[str, np.ndarray]:
    if isinstance(designs, Mapping):
        arr = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in designs.items()}
    else:  # a list of mappings
        keys = list(designs[0])
        arr = {k: np.array([d[k] for d in designs], dtype=float) for k in keys}
    D = max(v.shape[0] for v in arr.values())
    full = {}
    for k, dv in config.design_variables.items():
        v = arr.get(k, np.array([dv.value]))
        full[k] = np.broadcast_to(v, (D,)).astype(float)
    return full


def evaluate(config: Config, designs, workspace: Workspace | None = None, keep_local: bool = False,
             index_names=None) -> Evaluation:
    """Evaluate a population: ``designs`` maps parameter names to arrays (D,)
    (missing ones take their config value) or is a list of mappings."""
    from .mechanisms import get

    ws = workspace if workspace is not None else workspace_of(config)
    full = _stack_designs(config, designs)
    params = {k: v[:, None] for k, v in full.items()}
    kw = dict(config.parameters)
    kw.update(params)
    mech = get(config.mechanism)(**kw)
    names = list(index_names) if index_names is not None else list(config.indices)
    needs = {INDEX_KINDS[config.indices[n].kind].needs for n in names}
    # the fused compiled kernel (optdesign.fast) when it applies; OPTDESIGN_FAST=0 forces numpy
    fast = None
    if not keep_local:
        from .fast import try_evaluate

        fast = try_evaluate(config, mech, ws.X, names)
        if fast is None and getattr(mech, "global_statistics", None) is not None:
            # the mechanism's own compiled path (described mechanisms); None: the numpy path
            from .mechanisms.described.compiled import requests_of

            fast = mech.global_statistics(requests_of(config, names), ws.X)
    if fast is not None:
        summary, reach = fast
        local = {}
    else:
        with np.errstate(all="ignore"):
            reach = np.broadcast_to(mech.reachable(ws.X), (len(next(iter(full.values()))), ws.n))
            mats = mech.index_matrices(ws.X, needs)
            summary, local = {}, {}
            for n in names:
                spec = config.indices[n]
                vals = local_index(spec.kind, J=mats.get("J"), M=mats.get("M"), convention=spec.convention,
                                   options=spec.options)
                vals = np.broadcast_to(vals, reach.shape)
                summary[n] = global_summary(vals, reach)
                if keep_local:
                    local[n] = np.where(reach, vals, np.nan)
    frac = reach.mean(axis=-1)
    return Evaluation(summary, reach, frac, local if keep_local else None, ws)


def evaluate_named(config: Config, names=None, workspace: Workspace | None = None) -> dict[str, dict]:
    """Global indices of named designs as plain floats (for tables and JSON)."""
    names = list(names) if names else list(config.designs)
    ev = evaluate(config, [config.design(n) for n in names], workspace)
    out = {}
    for i, n in enumerate(names):
        rec = {k: {s: float(v[s][i]) for s in ("mean", "min", "max", "std")} for k, v in ev.summary.items()}
        rec["reachable_fraction"] = float(ev.reachable_fraction[i])
        out[n] = rec
    return out
