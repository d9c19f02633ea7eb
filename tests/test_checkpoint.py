"""Checkpoints as data: the state pymoo carries between generations, captured,
written without pickle, restored into a freshly built algorithm.

* Walking every attribute of the algorithm (operators, survival, callback,
  termination, evaluator) before and after a generation: whatever changes is
  what the checkpoint keeps, for the paper GA, pymoo's GA, DE, NSGA-II and NSGA-III.
* Stopped after any generation and resumed from the file, each algorithm ends
  bit for bit where the uninterrupted run ends (population, optimum, generator).
* The file format refuses pickled arrays, compressed members and headers that
  lie about their size; a state that does not fit the algorithm is refused
  with the algorithm left as it was.
"""
from __future__ import annotations

import dataclasses
import io
import types
import zipfile

import numpy as np
import pytest
from conftest import DATA

from optdesign import datafile
from optdesign.config import load_config
from optdesign.evaluate import Evaluator, workspace_of
from optdesign.optimize.algorithms import build_algorithm
from optdesign.optimize.checkpoint import CheckpointError, _slots, capture, restore
from optdesign.optimize.problem import DesignProblem, index_term

#: wide bounds: many designs reach no point, so infeasible designs tie on their violation
HOSTILE = DATA / "p4s_hostile_bounds.yaml"
KINDS = ["paper_ga", "pymoo_ga", "de", "nsga2", "nsga3"]
GENERATIONS = 6


@pytest.fixture(scope="module")
def setting():
    cfg = load_config(HOSTILE)
    ev = Evaluator.from_config(cfg, workspace_of(cfg))
    return cfg, ev


def _fresh(setting, kind, generations=GENERATIONS):
    cfg, ev = setting
    terms = [index_term(k, s.sense) for k, s in cfg.indices.items()]
    if kind in ("nsga2", "nsga3"):
        prob, (alg, cb) = DesignProblem(ev, terms), build_algorithm(cfg.optimizer, len(terms), kind)
    else:
        opt = dataclasses.replace(cfg.optimizer, algorithm=kind)
        prob, (alg, cb) = DesignProblem(ev, terms[:1]), build_algorithm(opt)
    alg.setup(prob, termination=("n_gen", generations), seed=17, verbose=False, **({"callback": cb} if cb else {}))
    return alg, [cb] if cb else []


def _flat(obj, path, out, ancestors=frozenset()):
    """Every number, string and array reachable from ``obj``, by attribute path."""
    if isinstance(obj, (types.ModuleType, types.FunctionType, types.BuiltinFunctionType, type, types.MethodType)):
        return out
    if isinstance(obj, np.random.Generator):
        out[path] = repr(obj.bit_generator.state)
    elif isinstance(obj, np.ndarray) and obj.dtype != object:
        out[path] = (obj.shape, obj.tobytes())
    elif isinstance(obj, (int, float, str, bool, type(None), np.generic)):
        out[path] = repr(obj)
    elif id(obj) not in ancestors:
        ancestors = ancestors | {id(obj)}
        if isinstance(obj, dict):
            for k, v in obj.items():
                _flat(v, f"{path}[{k!r}]", out, ancestors)
        elif isinstance(obj, (list, tuple, set, frozenset, np.ndarray)):
            out[f"{path}.len"] = len(obj)
            for i, v in enumerate(sorted(obj, key=repr) if isinstance(obj, (set, frozenset)) else obj):
                _flat(v, f"{path}[{i}]", out, ancestors)
        elif hasattr(obj, "__dict__"):
            for k, v in vars(obj).items():
                _flat(v, f"{path}.{k}", out, ancestors)
    return out


@pytest.mark.parametrize("kind", KINDS)
def test_what_changes_between_generations_is_kept(setting, kind):
    alg, cbs = _fresh(setting, kind)
    for _ in range(3):
        alg.next()
    # kept whole / rewritten before read / not read (DE's parameter control is told the population at the
    # start of every mating, and pymoo's DE uses NoParameterControl, which never reads it)
    skip = ("a.pop", "a.opt", "a.off", "a.problem", "a.survival.opt", "a.mating.control.data")
    before = {k: v for k, v in _flat(alg, "a", {}).items() if not k.startswith(skip)}
    alg.next()
    after = {k: v for k, v in _flat(alg, "a", {}).items() if not k.startswith(skip)}
    changed = {k for k in before.keys() | after.keys() if before.get(k) != after.get(k)}
    kept = {"a.n_iter", "a.evaluator.n_eval", "a.random_state", "a.termination.perc", "a.termination.force_termination"}
    names = {s[0] for s in _slots(alg, cbs)}
    if "mutation.scale" in names:
        kept |= {"a.mating.mutation.scale", "a.callback.mutation.scale"}
    if "callback0.best" in names:
        kept.add("a.callback.best")
    kept |= {f"a.survival.{n}" for n in names if n.startswith("norm.")}
    assert changed, "nothing changed: the walk sees nothing"
    assert changed <= kept, sorted(changed - kept)
    assert "a.random_state" in changed and "a.n_iter" in changed


def _state(alg):
    X, F, CV = alg.pop.get("X", "F", "CV")
    oX, oF = alg.opt.get("X", "F")
    data = [sorted((k, repr(v)) for k, v in ind.data.items()) for ind in alg.pop]
    return X.tobytes(), F.tobytes(), CV.tobytes(), oX.tobytes(), oF.tobytes(), data, \
        repr(alg.random_state.bit_generator.state), alg.evaluator.n_eval, alg.n_iter


@pytest.mark.parametrize("kind", KINDS)
def test_resume_after_any_generation_ends_bit_for_bit(setting, kind, tmp_path):
    ref, _ = _fresh(setting, kind)
    ref.run()
    want = _state(ref)
    ev = setting[1]
    names = ev.index_names + list(ev.extra)
    for k in range(1, GENERATIONS + 1):
        alg, cbs = _fresh(setting, kind)
        for _ in range(k):
            alg.next()
        history = [{"generation": g} for g in range(1, k + 1)]
        p = tmp_path / f"{kind}{k}.npz"
        p.write_bytes(datafile.dumps(*capture(alg, cbs, history, alg.n_iter)))
        meta, arrays = datafile.read(p)
        assert np.load(p, allow_pickle=False)["pop.X"].shape == alg.pop.get("X").shape   # numpy reads it as an npz
        again, cbs2 = _fresh(setting, kind)
        assert restore(again, cbs2, meta, arrays, names, ["generation"]) == history
        again.run()
        assert _state(again) == want, (kind, k)


def test_the_same_state_gives_the_same_bytes(setting):
    a, ca = _fresh(setting, "nsga3")
    b, cb = _fresh(setting, "nsga3")
    for alg in (a, b):
        alg.next()
        alg.next()
    assert datafile.dumps(*capture(a, ca, [], 3)) == datafile.dumps(*capture(b, cb, [], 3))


def _checkpoint(setting, kind="paper_ga"):
    alg, cbs = _fresh(setting, kind)
    alg.next()
    alg.next()
    meta, arrays = capture(alg, cbs, [{"generation": 1}, {"generation": 2}], alg.n_iter)
    return meta, arrays


def _bad(meta, arrays, edit):
    meta = {k: (dict(v) if isinstance(v, dict) else v) for k, v in meta.items()}
    arrays = dict(arrays)
    edit(meta, arrays)
    return meta, arrays


BAD = {
    "X of the wrong shape": lambda m, a: a.__setitem__("pop.X", a["pop.X"][:, :2]),
    "X as integers": lambda m, a: a.__setitem__("pop.X", a["pop.X"].astype(np.int64)),
    "NaN in F": lambda m, a: a.__setitem__("pop.F", np.full_like(a["pop.F"], np.nan)),
    "feasibility not that of CV": lambda m, a: a.__setitem__("pop.FEAS", ~a["pop.FEAS"]),
    "a missing array": lambda m, a: a.pop("pop.G"),
    "an extra array": lambda m, a: a.__setitem__("spare", np.zeros(3)),
    "another algorithm": lambda m, a: m.__setitem__("algorithm", "NSGA2"),
    "another stage seed": lambda m, a: m.__setitem__("stage_seed", 18),
    "another budget": lambda m, a: m.__setitem__("n_max_gen", 99),
    "a generation beyond the budget": lambda m, a: m.__setitem__("n_iter", 99),
    "a generator of another kind": lambda m, a: m.__setitem__("rng", {**m["rng"], "bit_generator": "MT19937"}),
    "a generator state out of range": lambda m, a: m.__setitem__("rng", {**m["rng"], "state": {"state": -1, "inc": 1}}),
    "an unknown value name": lambda m, a: m["populations"].__setitem__(
        "pop", {**m["populations"]["pop"], "data": [["__reduce__", "int"]]}),
    "history rows not the generations": lambda m, a: a.__setitem__("history.0", np.array([2, 1])),
    "state names of another algorithm": lambda m, a: m.__setitem__("state", [["norm.ideal_point", "array"]]),
}


@pytest.mark.parametrize("label", list(BAD))
def test_a_state_that_does_not_fit_is_refused(setting, label):
    meta, arrays = _bad(*_checkpoint(setting), BAD[label])
    alg, cbs = _fresh(setting, "paper_ga")
    fresh = repr(alg.random_state.bit_generator.state)
    ev = setting[1]
    with pytest.raises(CheckpointError):
        restore(alg, cbs, meta, arrays, ev.index_names, ["generation"])
    assert alg.pop is None and repr(alg.random_state.bit_generator.state) == fresh


def _zip(members: dict[str, bytes], compress=zipfile.ZIP_STORED) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compress) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def _npy(a, **kw) -> bytes:
    buf = io.BytesIO()
    np.save(buf, a, **kw)
    return buf.getvalue()


class _Payload:
    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return open, (str(self.marker), "w")


def test_the_file_format_refuses_what_is_not_plain_data(tmp_path):
    marker = tmp_path / "payload-ran"
    obj = np.array([_Payload(marker)], dtype=object)
    header = b"\x93NUMPY\x01\x00" + b"{'descr': '<f8', 'fortran_order': False, 'shape': (100000000000,), }".ljust(118) + b"\n"
    cases = {
        "a pickled object array": _zip({"meta.json": b"{}", "a.npy": _npy(obj, allow_pickle=True)}),
        "a compressed member": _zip({"meta.json": b"{}", "a.npy": _npy(np.zeros(3))}, zipfile.ZIP_DEFLATED),
        "a header claiming 800 GB": _zip({"meta.json": b"{}", "a.npy": header + b"\0" * 8}),
        "no meta.json": _zip({"a.npy": _npy(np.zeros(3))}),
        "meta.json not an object": _zip({"meta.json": b"[1]"}),
        "meta.json nested 100,000 deep": _zip({"meta.json": b"[" * 100000 + b"]" * 100000}),
        "meta.json with NaN": _zip({"meta.json": b'{"a": NaN}'}),
        "a member outside the names": _zip({"meta.json": b"{}", "../x.npy": _npy(np.zeros(3))}),
        "a complex array": _zip({"meta.json": b"{}", "a.npy": _npy(np.zeros(3, complex))}),
        "a pickle": __import__("pickle").dumps(_Payload(marker)),
        "empty": b"",
    }
    for label, data in cases.items():
        p = tmp_path / "c.npz"
        p.write_bytes(data)
        with pytest.raises(datafile.DataFileError):
            datafile.read(p)
        assert not marker.exists(), label
    (tmp_path / "d").mkdir()
    with pytest.raises(datafile.DataFileError):
        datafile.read(tmp_path / "d")
    good = tmp_path / "g.npz"
    good.write_bytes(datafile.dumps({"a": [1, 2]}, {"x": np.arange(3.0), "n": np.arange(2), "b": np.ones(1, bool)}))
    meta, arrays = datafile.read(good)
    assert meta == {"a": [1, 2]} and arrays["x"].tolist() == [0.0, 1.0, 2.0] and arrays["n"].dtype == np.int64
    # the payload is live: numpy with pickle allowed runs it (which is why the reader never allows it)
    np.load(io.BytesIO(_npy(obj, allow_pickle=True)), allow_pickle=True)
    assert marker.exists()
