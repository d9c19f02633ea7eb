"""A stage's pymoo algorithm as data (and back), for data-only checkpoints.

:func:`capture` turns the state a GA, NSGA-II or NSGA-III run carries from one
generation to the next into a JSON-able ``meta`` dict and plain numpy arrays;
:func:`restore` puts it into an algorithm built afresh exactly as a new run
builds it (``build_algorithm`` and ``setup``), after checking every key,
dtype and shape against that algorithm.  What ``next()`` reads between
generations in pymoo 0.6.2, and so what is kept:

* the population and the current optimum (``opt``, which for NSGA-III is not
  a subset of the population): per design X, F, G, H, CV, feasibility, the
  values pymoo's survivals attach (``rank``, ``crowding``, ``niche``,
  ``dist_to_niche``, ``n_gen``, ``n_iter``) and ours (``index_<name>``), and
  which values were evaluated;
* the generation and evaluation counters, the termination's progress;
* the algorithm's numpy Generator (``bit_generator.state``, a dict of ints);
* the paper GA's adaptive mutation step and its callback's best objective;
* NSGA-III's normalization: ideal, worst and nadir points and extreme points.

Nothing else changes between generations (``tests/test_checkpoint.py`` walks
the algorithm's objects and checks it).  NSGA-III's ``survival.opt`` is
rewritten by every survival before it is read, the offspring (``off``) are
never read again, and operators without state are rebuilt by construction.
"""
from __future__ import annotations

import time

import numpy as np
from pymoo.algorithms.moo.nsga3 import ReferenceDirectionSurvival
from pymoo.core.individual import Individual
from pymoo.core.population import Population

from .operators import AdaptiveGaussianMutation, AdaptiveMutationCallback

__all__ = ["capture", "restore", "CheckpointError"]

_FIELDS = ("X", "F", "G", "H", "CV")
_GRADIENTS = ("_dF", "_dG", "_dH", "_ddF", "_ddG", "_ddH")
#: per-design values pymoo's survivals set (DE: ``index``, the parent an offspring replaces)
PYMOO_DATA = ("n_gen", "n_iter", "rank", "crowding", "niche", "dist_to_niche", "index")
_TYPES = {"int": int, "float": float, "bool": bool, "np.int64": np.int64, "np.float64": np.float64,
          "np.bool_": np.bool_}
_STORED = {"int": np.int64, "np.int64": np.int64, "float": np.float64, "np.float64": np.float64,
           "bool": np.bool_, "np.bool_": np.bool_}
_TAG = {v: k for k, v in _TYPES.items()}
_META = {"algorithm", "stage_seed", "n_iter", "n_eval", "n_max_gen", "rng", "force_termination", "populations",
         "state", "history"}


class CheckpointError(ValueError):
    """The checkpoint does not fit the algorithm (the message says what)."""


def _slots(algorithm, callbacks) -> list[tuple[str, object, str, tuple | None]]:
    """(name, object, attribute, shape or None for a float) of every piece of
    operator and callback state."""
    out = []
    mut = getattr(getattr(algorithm, "mating", None), "mutation", None)
    if isinstance(mut, AdaptiveGaussianMutation):
        out.append(("mutation.scale", mut, "scale", None))
    for j, cb in enumerate(callbacks):
        if isinstance(cb, AdaptiveMutationCallback):
            out.append((f"callback{j}.best", cb, "best", None))
    if isinstance(algorithm.survival, ReferenceDirectionSurvival):
        m = algorithm.problem.n_obj
        norm = algorithm.survival.norm
        out += [("norm.ideal_point", norm, "ideal_point", (m,)), ("norm.worst_point", norm, "worst_point", (m,)),
                ("norm.nadir_point", norm, "nadir_point", (m,)), ("norm.extreme_points", norm, "extreme_points", (m, m))]
    return out


# ---------------------------------------------------------------------- capture
def _pack(pop, prefix: str, arrays: dict) -> dict:
    for ind in pop:
        if any(getattr(ind, g).size for g in _GRADIENTS):
            raise RuntimeError("a design carries derivatives; checkpoints do not keep them")
    for f in _FIELDS:
        arrays[f"{prefix}.{f}"] = np.array([getattr(ind, f) for ind in pop], dtype=float).reshape(len(pop), -1)
    arrays[f"{prefix}.FEAS"] = np.array([ind.FEAS for ind in pop], dtype=bool).reshape(len(pop), 1)
    evaluated = {frozenset(ind.evaluated) for ind in pop}
    if len(evaluated) != 1:
        raise RuntimeError("designs of one population evaluated differently")
    keys = []
    for ind in pop:
        keys.extend(k for k in ind.data if k not in keys)
    data = []
    for j, k in enumerate(keys):
        tags = {_TAG.get(type(ind.data[k])) for ind in pop if k in ind.data}
        if len(tags) != 1 or None in tags:
            raise RuntimeError(f"value {k!r} of the designs has types {tags}")
        (tag,) = tags
        arrays[f"{prefix}.has.{j}"] = np.array([k in ind.data for ind in pop], dtype=bool)
        arrays[f"{prefix}.data.{j}"] = np.array([ind.data.get(k, 0) for ind in pop], dtype=_STORED[tag])
        data.append([k, tag])
    return {"n": len(pop), "evaluated": sorted(next(iter(evaluated))), "data": data}


def capture(algorithm, callbacks, history: list[dict], n_iter: int) -> tuple[dict, dict]:
    """``(meta, arrays)`` of an algorithm after a generation; ``n_iter`` is the
    generation it runs next, ``history`` the rows of the generations done."""
    arrays: dict[str, np.ndarray] = {}
    pops = {"pop": _pack(algorithm.pop, "pop", arrays), "opt": _pack(algorithm.opt, "opt", arrays)}
    arrays["termination.perc"] = np.array(float(algorithm.termination.perc))
    state = []
    for j, (name, obj, attr, shape) in enumerate(_slots(algorithm, callbacks)):
        v = getattr(obj, attr)
        state.append([name, "none" if v is None else "float" if shape is None else "array"])
        if v is not None:
            arrays[f"state.{j}"] = np.array(v, dtype=float)
    cols = list(history[0]) if history else []
    kinds = []
    for j, c in enumerate(cols):
        ints = all(type(r[c]) is int for r in history)
        kinds.append("int" if ints else "float")
        arrays[f"history.{j}"] = np.array([r[c] for r in history], dtype=np.int64 if ints else float)
    meta = {"algorithm": type(algorithm).__name__, "stage_seed": algorithm.seed, "n_iter": int(n_iter),
            "n_eval": int(algorithm.evaluator.n_eval), "n_max_gen": algorithm.termination.n_max_gen,
            "rng": algorithm.random_state.bit_generator.state,
            "force_termination": bool(algorithm.termination.force_termination), "populations": pops,
            "state": state, "history": {"columns": cols, "kinds": kinds, "rows": len(history)}}
    return meta, arrays


# ---------------------------------------------------------------------- restore
def _need(ok: bool, what: str) -> None:
    if not ok:
        raise CheckpointError(what)


def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _take(arrays: dict, used: set, name: str, dtype, shape) -> np.ndarray:
    a = arrays.get(name)
    _need(a is not None, f"no array {name!r}")
    _need(a.dtype == np.dtype(dtype) and a.shape == tuple(shape),
          f"array {name!r}: {a.dtype} {a.shape}, expected {np.dtype(dtype)} {tuple(shape)}")
    used.add(name)
    return a


def _unpack(meta: dict, prefix: str, arrays: dict, used: set, problem, value_names) -> Population:
    _need(isinstance(meta, dict) and set(meta) == {"n", "evaluated", "data"}, f"populations.{prefix}: keys")
    n = meta["n"]
    _need(_is_int(n) and 1 <= n <= 10 ** 6, f"populations.{prefix}.n: {n!r}")
    width = {"X": problem.n_var, "F": problem.n_obj, "G": problem.n_ieq_constr, "H": problem.n_eq_constr, "CV": 1}
    v = {f: _take(arrays, used, f"{prefix}.{f}", float, (n, width[f])) for f in _FIELDS}
    for f in ("X", "F", "G", "CV"):
        _need(bool(np.all(np.isfinite(v[f]))), f"{prefix}.{f}: not finite")
    _need(bool(np.all(v["CV"] >= 0)), f"{prefix}.CV: negative")
    feas = _take(arrays, used, f"{prefix}.FEAS", bool, (n, 1))
    _need(bool(np.all(feas == (v["CV"] <= 0))), f"{prefix}.FEAS: does not match CV")
    known = {"F", "G", "H"} | {f"index_{k}" for k in value_names}
    ev = meta["evaluated"]
    _need(isinstance(ev, list) and all(isinstance(e, str) and e in known for e in ev), f"{prefix}: evaluated")
    keys = meta["data"]
    _need(isinstance(keys, list), f"populations.{prefix}.data")
    allowed = set(PYMOO_DATA) | {f"index_{k}" for k in value_names}
    data = []
    for j, item in enumerate(keys):
        _need(isinstance(item, list) and len(item) == 2 and item[0] in allowed and item[1] in _TYPES,
              f"populations.{prefix}.data[{j}]")
        has = _take(arrays, used, f"{prefix}.has.{j}", bool, (n,))
        vals = _take(arrays, used, f"{prefix}.data.{j}", _STORED[item[1]], (n,))
        data.append((item[0], _TYPES[item[1]], has, vals))
    inds = []
    for i in range(n):
        ind = Individual()
        ind._X, ind._F, ind._G, ind._H, ind._CV = (v[f][i].copy() for f in _FIELDS)
        ind.evaluated = set(ev)
        for k, typ, has, vals in data:
            if has[i]:
                ind.data[k] = typ(vals[i].item())
        inds.append(ind)
    return Population(inds)


def _rng_state(s) -> dict:
    _need(isinstance(s, dict) and set(s) == {"bit_generator", "state", "has_uint32", "uinteger"}
          and s["bit_generator"] == "PCG64" and isinstance(s["state"], dict)
          and set(s["state"]) == {"state", "inc"}, "rng: not a PCG64 state")
    ok = all(_is_int(x) and 0 <= x < 2 ** 128 for x in s["state"].values())
    _need(ok and s["has_uint32"] in (0, 1) and _is_int(s["uinteger"]) and 0 <= s["uinteger"] < 2 ** 32,
          "rng: values out of range")
    return s


def restore(algorithm, callbacks, meta: dict, arrays: dict, value_names, history_columns) -> list[dict]:
    """Put a captured state into a freshly set-up algorithm; returns the
    history rows.  Raises CheckpointError (nothing changed) if the state does
    not fit this algorithm, problem, stage or budget."""
    problem, term = algorithm.problem, algorithm.termination
    _need(set(meta) >= _META, f"meta.json: missing {sorted(_META - set(meta))}")
    _need(meta["algorithm"] == type(algorithm).__name__, f"algorithm {str(meta['algorithm'])[:40]!r}, "
          f"this stage runs {type(algorithm).__name__}")
    _need(meta["stage_seed"] == algorithm.seed, "the stage's seed differs")
    _need(meta["n_max_gen"] == term.n_max_gen, "the stage's number of generations differs")
    n_iter, n_eval = meta["n_iter"], meta["n_eval"]
    _need(_is_int(n_iter) and 2 <= n_iter <= term.n_max_gen + 1, f"n_iter: {str(n_iter)[:40]}")
    _need(_is_int(n_eval) and n_eval >= 0, f"n_eval: {str(n_eval)[:40]}")
    _need(isinstance(meta["force_termination"], bool), "force_termination")
    rng = _rng_state(meta["rng"])
    used: set = set()
    pops = meta["populations"]
    _need(isinstance(pops, dict) and set(pops) == {"pop", "opt"}, "populations: keys")
    pop = _unpack(pops["pop"], "pop", arrays, used, problem, value_names)
    opt = _unpack(pops["opt"], "opt", arrays, used, problem, value_names)
    perc = float(_take(arrays, used, "termination.perc", float, ()))
    _need(0.0 <= perc <= 1.0, "termination.perc")
    slots = _slots(algorithm, callbacks)
    state = meta["state"]
    _need(isinstance(state, list) and all(isinstance(x, list) and len(x) == 2 for x in state)
          and [x[0] for x in state] == [s[0] for s in slots], "state: names")
    values = []
    for j, (name, obj, attr, shape) in enumerate(slots):
        kind = state[j][1]
        _need(kind in (("float",) if shape is None else ("array", "none")), f"state {name}: {str(kind)[:20]}")
        values.append(None if kind == "none" else
                      float(_take(arrays, used, f"state.{j}", float, ())) if shape is None else
                      _take(arrays, used, f"state.{j}", float, shape).copy())
    h = meta["history"]
    _need(isinstance(h, dict) and set(h) == {"columns", "kinds", "rows"}, "history: keys")
    _need(h["rows"] == n_iter - 1 and h["columns"] == list(history_columns) and isinstance(h["kinds"], list)
          and len(h["kinds"]) == len(h["columns"]) and all(k in ("int", "float") for k in h["kinds"]),
          "history: columns or rows do not fit the stage")
    cols = [_take(arrays, used, f"history.{j}", np.int64 if k == "int" else float, (h["rows"],))
            for j, k in enumerate(h["kinds"])]
    _need(not cols or np.array_equal(cols[0], np.arange(1, n_iter)), "history: generations not 1, 2, ...")
    _need(used == set(arrays), f"unexpected arrays {sorted(set(arrays) - used)[:3]}")
    conv = [int if k == "int" else float for k in h["kinds"]]
    history = [{c: f(col[i].item()) for c, f, col in zip(h["columns"], conv, cols)} for i in range(h["rows"])]
    try:
        algorithm.random_state.bit_generator.state = rng
    except (TypeError, ValueError, KeyError) as exc:
        raise CheckpointError(f"rng: {exc}") from None
    algorithm.pop, algorithm.opt = pop, opt
    algorithm.n_iter, algorithm.is_initialized = n_iter, True
    algorithm.evaluator.n_eval = n_eval
    term.perc, term.force_termination = perc, meta["force_termination"]
    algorithm.start_time = time.time()   # only pymoo's Result reads it
    for (name, obj, attr, shape), v in zip(slots, values):
        setattr(obj, attr, v)
    return history
