"""Hostile run folders: crafted checkpoints and every tampering of a folder.

A run of ``p4s_tiny.yaml`` is interrupted in its last stage (every other stage
finished, NSGA-III checkpointed), then copies of its folder are changed and
resumed with ``optdesign run --resume``:

* code planted in the folder (a pickle with a ``__reduce__`` payload as
  ``checkpoint.pkl`` or as the checkpoint itself, a pickled numpy array in the
  checkpoint, a Python tag in config.yaml with its hashes forged) never runs;
* every change listed in ``CHANGES`` ends with status 2 and one line naming
  the changed file, never a traceback;
* single bytes changed anywhere in the folder (hypothesis): status 2, or
  status 0 with exactly the result of the uninterrupted run.
"""
from __future__ import annotations

import hashlib
import json
import os
import pickle
import shutil
import tempfile
from pathlib import Path

import pytest
from cli_helpers import run_cli_in
from conftest import CONFIGS, DATA
from hypothesis import HealthCheck, given, settings, strategies as st

from optdesign.config import load_config
from optdesign.runner import start_run
from optdesign.optimize.workers import Interrupted
from optdesign.runs import _binding

TINY = DATA / "p4s_tiny.yaml"
SEED = 11
#: generations before the stop: 4 x 4 single-index, 2 x 4 weighted sums, 3 NSGA-II, 1 NSGA-III
STOP = 28


def _interrupted(out: Path) -> Path:
    with pytest.raises(Interrupted):
        start_run(load_config(TINY), seed=SEED, out=out, stop_after=STOP)
    (folder,) = list(out.iterdir())
    return folder


def _strip(results: dict) -> dict:
    r = json.loads(json.dumps(results))
    r.pop("wall_time_s", None)
    return r


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("hostile")
    ref = start_run(load_config(TINY), seed=SEED, out=root / "ref")
    return {"ref": ref.folder.path, "results": _strip(ref.results),
            "base": _interrupted(root / "base"), "other": _interrupted(root / "other")}


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst, symlinks=True)
    return dst


def _resume(folder: Path) -> tuple[int, str]:
    rc, _, err = run_cli_in(folder.parent, ["run", "--resume", str(folder), "--quiet"])
    return rc, err


def _manifest(f: Path, **changes) -> None:
    m = json.loads((f / "manifest.json").read_text())
    m.update(changes)
    (f / "manifest.json").write_text(json.dumps(m))


def _edit_json(p: Path, edit) -> None:
    obj = json.loads(p.read_text())
    p.write_text(json.dumps(edit(obj)))


def _forget_checkpoints(f: Path) -> None:
    """As after a SIGKILL: the manifest records no checkpoint hashes."""
    _manifest(f, checkpoints={})


def _truncate(p: Path) -> None:
    b = p.read_bytes()
    p.write_bytes(b[: len(b) // 2])


NSGA3 = "stages/pareto_nsga3/checkpoint.npz"
DONE = "stages/single_dynamic_min"


def _replace(p: Path, make) -> None:
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p)
    else:
        p.unlink()
    make(p)


#: change -> (what to do to a copy of the folder (it gets the other run too), the file the message names)
CHANGES = {
    "config.yaml with other bounds": (lambda f, o: (f / "config.yaml").write_text(
        (f / "config.yaml").read_text().replace("[0.21, 0.29]", "[0.20, 0.30]")), "config.yaml"),
    "config.yaml of another mechanism": (lambda f, o: (f / "config.yaml").write_text(
        (CONFIGS / "cpr_rrr_opt.yaml").read_text()), "config.yaml"),
    "config.yaml binary": (lambda f, o: (f / "config.yaml").write_bytes(bytes(range(256)) * 4), "config.yaml"),
    "config.yaml a directory": (lambda f, o: _replace(f / "config.yaml", Path.mkdir), "config.yaml"),
    "config.yaml a FIFO": (lambda f, o: _replace(f / "config.yaml", os.mkfifo), "config.yaml"),
    "config.yaml missing": (lambda f, o: (f / "config.yaml").unlink(), str()),
    "seed changed in the manifest": (lambda f, o: _manifest(f, seed=SEED + 1), "manifest.json"),
    "pareto changed in the manifest": (lambda f, o: _manifest(f, pareto=False), "manifest.json"),
    "stages_done a string": (lambda f, o: _manifest(f, stages_done="single_dynamic_min"), "manifest.json"),
    "stages_done numbers": (lambda f, o: _manifest(f, stages_done=[1, 2]), "manifest.json"),
    "wall_time_s a string": (lambda f, o: _manifest(f, wall_time_s="1.5 s"), "manifest.json"),
    "wall_time_s NaN": (lambda f, o: _manifest(f, wall_time_s=float("nan")), "manifest.json"),
    "wall_time_s a boolean": (lambda f, o: _manifest(f, wall_time_s=True), "manifest.json"),
    "manifest nested 100,000 deep": (lambda f, o: (f / "manifest.json").write_text("[" * 100000 + "]" * 100000),
                                     "manifest.json"),
    "manifest a FIFO": (lambda f, o: _replace(f / "manifest.json", os.mkfifo), "manifest.json"),
    "manifest of 65 MiB": (lambda f, o: os.truncate(f / "manifest.json", 65 * 2 ** 20), "manifest.json"),
    "a stage record naming a file outside": (lambda f, o: _edit_json(f / "manifest.json", lambda m: {
        **m, "stages": {**m["stages"], "single_dynamic_min": {"seed": 1, "files": {"../../x": "0" * 64}}}}),
        "manifest.json"),
    "a stage record of another seed": (lambda f, o: _edit_json(f / "manifest.json", lambda m: {
        **m, "stages": {**m["stages"], "single_dynamic_min": {**m["stages"]["single_dynamic_min"], "seed": 1}}}),
        "manifest.json"),
    "stages a file": (lambda f, o: _replace(f / "stages", lambda p: p.write_text("x")), "stages"),
    "truncated history.csv of a finished stage": (lambda f, o: _truncate(f / DONE / "history.csv"),
                                                  f"{DONE}/history.csv"),
    "population.csv of a finished stage deleted": (lambda f, o: (f / DONE / "population.csv").unlink(),
                                                   f"{DONE}/population.csv"),
    "tampered result.json of a finished stage": (lambda f, o: _edit_json(
        f / DONE / "result.json", lambda r: {**r, "value": r["value"] * 0.5}), f"{DONE}/result.json"),
    "result.json of []": (lambda f, o: (f / DONE / "result.json").write_text("[]"), f"{DONE}/result.json"),
    "result.json of {}": (lambda f, o: (f / DONE / "result.json").write_text("{}"), f"{DONE}/result.json"),
    "front csv of a finished stage truncated": (lambda f, o: _truncate(f / "pareto_nsga2.csv"), "pareto_nsga2.csv"),
    "a stage folder a link outside": (lambda f, o: _replace(f / "stages/pareto_nsga3", lambda p: p.symlink_to(
        shutil.copytree(f / "stages/pareto_nsga2", f.parent / "outside"))), "stages/pareto_nsga3"),
    "config.yaml a link (to the same text)": (lambda f, o: _replace(f / "config.yaml", lambda p: p.symlink_to(
        shutil.copy(o / "config.yaml", f.parent / "c.yaml"))), "config.yaml"),
    "checkpoint copied from another stage": (lambda f, o: shutil.copy(
        f / "stages/pareto_nsga2/checkpoint.npz", f / NSGA3), NSGA3),
    "checkpoint copied from another stage, unrecorded": (lambda f, o: (shutil.copy(
        f / "stages/pareto_nsga2/checkpoint.npz", f / NSGA3), _forget_checkpoints(f)), NSGA3),
    "checkpoint copied from another run": (lambda f, o: shutil.copy(o / NSGA3, f / NSGA3), NSGA3),
    "checkpoint copied from another run, unrecorded": (lambda f, o: (shutil.copy(o / NSGA3, f / NSGA3),
                                                                      _forget_checkpoints(f)), NSGA3),
    "truncated checkpoint, unrecorded": (lambda f, o: (_truncate(f / NSGA3), _forget_checkpoints(f)), NSGA3),
    "checkpoint a directory, unrecorded": (lambda f, o: (_replace(f / NSGA3, Path.mkdir), _forget_checkpoints(f)),
                                           NSGA3),
}


@pytest.mark.slow
@pytest.mark.parametrize("label", list(CHANGES))
def test_a_changed_folder_is_refused_naming_the_file(runs, tmp_path, label):
    change, named = CHANGES[label]
    f = _copy(runs["base"], tmp_path / "run")
    change(f, runs["other"])
    outside = sorted((p, p.stat().st_mtime_ns) for p in tmp_path.glob("outside/*"))
    rc, err = _resume(f)
    assert sorted((p, p.stat().st_mtime_ns) for p in tmp_path.glob("outside/*")) == outside   # nothing written there
    assert rc == 2, (label, rc, err)
    assert err.count("\n") == 1 and err.startswith("optdesign: error: ") and "Traceback" not in err, err
    assert str(f / named).rstrip("/") in err, (label, err)


@pytest.mark.slow
def test_an_intact_copy_resumes_to_the_uninterrupted_result(runs, tmp_path):
    f = _copy(runs["base"], tmp_path / "run")
    rc, err = _resume(f)
    assert rc == 0, err
    assert _strip(json.loads((f / "results.json").read_text())) == runs["results"]
    for rel in ("pareto_nsga3.csv", "pareto_nsga2.csv", "history.csv", "population.csv"):
        assert (f / rel).read_bytes() == (runs["ref"] / rel).read_bytes(), rel


@pytest.mark.slow
@pytest.mark.parametrize("what", ["results.json", "config.yaml"])
def test_a_changed_complete_folder_is_refused(runs, tmp_path, what):
    f = _copy(runs["ref"], tmp_path / "done")
    assert _resume(f)[0] == 0
    if what == "results.json":
        _edit_json(f / what, lambda r: {**r, "objective": 0.5})
    else:
        (f / what).write_text((f / what).read_text().replace("seed: 3", "seed: 4"))
    rc, err = _resume(f)
    assert rc == 2 and str(f / what) in err and err.count("\n") == 1, err


class _Payload:
    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return open, (str(self.marker), "w")


def _object_npz(marker: Path) -> bytes:
    import io
    import zipfile

    import numpy as np

    buf, arr = io.BytesIO(), io.BytesIO()
    np.save(arr, np.array([_Payload(marker)], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(buf, "w") as zf:
        zf.writestr("meta.json", json.dumps({"format": "optdesign-checkpoint", "format_version": 2}))
        zf.writestr("pop.X.npy", arr.getvalue())
    return buf.getvalue()


@pytest.mark.slow
def test_planted_code_never_runs(runs, tmp_path):
    marker = tmp_path / "payload-ran"
    payload = pickle.dumps(_Payload(marker))
    # a checkpoint.pkl beside the checkpoint: never read; the run finishes as it should
    f = _copy(runs["base"], tmp_path / "pkl")
    (f / "stages/pareto_nsga3/checkpoint.pkl").write_bytes(payload)
    rc, err = _resume(f)
    assert rc == 0 and _strip(json.loads((f / "results.json").read_text())) == runs["results"], err
    # the payload as the checkpoint, recorded or not; a pickled numpy array in a zip
    for label, data, forget in (("pickle", payload, False), ("pickle, unrecorded", payload, True),
                                ("object array, unrecorded", _object_npz(marker), True)):
        f = _copy(runs["base"], tmp_path / label.replace(" ", "").replace(",", ""))
        (f / NSGA3).write_bytes(data)
        if forget:
            _forget_checkpoints(f)
        rc, err = _resume(f)
        assert rc == 2 and str(f / NSGA3) in err and err.count("\n") == 1, (label, err)
    # a Python tag in config.yaml, with the manifest's hashes forged to match it
    f = _copy(runs["base"], tmp_path / "yaml")
    text = (f / "config.yaml").read_text() + f"description: !!python/object/apply:builtins.open [{str(marker)!r}, w]\n"
    (f / "config.yaml").write_text(text)
    m = json.loads((f / "manifest.json").read_text())
    m["config_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    m["binding"] = _binding(m["run_id"], m["config_sha256"], m["seed"], m["pareto"])
    (f / "manifest.json").write_text(json.dumps(m))
    rc, err = _resume(f)
    assert rc == 2 and "config.yaml" in err and err.count("\n") == 1, err
    assert not marker.exists(), "a payload ran"
    # the payload is live: unpickled, it creates the marker (so the checks above can fail)
    pickle.loads(payload)
    assert marker.exists()


@pytest.mark.slow
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.data())
def test_any_changed_byte_is_refused_or_changes_nothing(runs, data):
    base = runs["base"]
    files = sorted(str(p.relative_to(base)) for p in base.rglob("*") if p.is_file())
    rel = data.draw(st.sampled_from(files), label="file")
    forget = data.draw(st.booleans(), label="as after a SIGKILL (no checkpoint hashes)")
    with tempfile.TemporaryDirectory() as tmp:
        f = _copy(base, Path(tmp) / "run")
        if forget:
            _forget_checkpoints(f)
        b = bytearray((f / rel).read_bytes())
        i = data.draw(st.integers(0, len(b) - 1), label="offset")
        # any byte, or a printable one (which keeps JSON and YAML valid more often)
        b[i] = data.draw((st.integers(0, 255) | st.integers(32, 126)).filter(lambda v: v != b[i]), label="byte")
        (f / rel).write_bytes(bytes(b))
        rc, err = _resume(f)
        assert "Traceback" not in err
        if rc == 0:
            assert _strip(json.loads((f / "results.json").read_text())) == runs["results"], (rel, i)
        else:
            assert rc == 2 and err.count("\n") == 1, (rel, i, rc, err)
