"""Names that become paths and the output roots they land in: a config's
``name``, design and index names, ``--name``, a batch's ``name``; ``--out``
(and the default ``runs``) as a file, a device, a folder under a file, too
long a path; symbolic links planted where a command will write.  Nothing
may ever be written outside the chosen root; see tests/hostile_helpers.py."""
from __future__ import annotations

import os
import string
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import BATCH_SMALL, CONFIGS, DATA, small_data
from hostile_helpers import Cases, files_under, run_case, sandbox
from optdesign.batch import plan
from optdesign.config import yamlsafe
from optdesign.names import MAX_NAME, name_problem

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])
_SAFE = set(string.ascii_letters + string.digits + "._-")
_SPECIAL = ["..", ".", "../x", "/etc/passwd", "a/b", "a\\b", "-rf", ".hidden", "a..b", "x" * MAX_NAME,
            "x" * (MAX_NAME + 1), "", " ", "a b", "tab\there", "new\nline", "nul\x00", "\ud800", "\udcff",
            "caf\u00e9", "\u202eevil", "CON", "a:b", "*", "~", "$HOME", "%s", "ok-name_1.2", "A" * 300]
NAMES = st.one_of(st.sampled_from(_SPECIAL), st.text(max_size=12),
                  st.text(alphabet=sorted(_SAFE), min_size=1, max_size=110))


def _oracle(s) -> bool:
    """The rule, written a second way: 1-100 characters from [A-Za-z0-9._-], not
    starting with '.' or '-', never '..'."""
    return isinstance(s, str) and 0 < len(s) <= 100 and set(s) <= _SAFE and s[0] not in ".-" and ".." not in s


def test_the_name_rule(tmp_path):
    cases = Cases()
    root = tmp_path / "root"
    root.mkdir()

    @settings(max_examples=400, **SETTINGS)
    @given(name=NAMES | st.text(st.characters(), max_size=20))
    def check(name):
        cases()
        ok = name_problem(name) is None
        assert ok == _oracle(name), (name, name_problem(name))
        if ok:      # one component that stays where it is put
            assert os.path.basename(name) == name and os.path.normpath(name) == name and Path(name).name == name
            d = root / name
            d.mkdir(exist_ok=True)
            assert d.resolve().parent == root.resolve()

    check()
    assert cases.n >= 400


def _config(name_slot: str, name: str) -> dict:
    data = small_data()
    data.pop("reference")
    if name_slot == "config name":
        data["name"] = name
    elif name_slot == "design name":
        data["designs"] = {name: data["designs"]["before"]}
    elif name_slot == "index name":
        data["indices"] = {name: {"kind": "dynamic"}}
    return data


@pytest.mark.slow
def test_names_through_the_commands():
    """Every slot where a name becomes a path: invalid names give exit 2 naming
    the key (or the option), valid ones write only inside the chosen root."""
    cases = Cases()

    @settings(max_examples=200, **SETTINGS)
    @given(name=NAMES, slot=st.sampled_from(["config name", "design name", "index name", "--name", "batch name"]))
    def check(name, slot):
        cases()
        valid = _oracle(name)
        with sandbox() as (work, outside):
            what = f"{slot} {name!r}"
            if slot == "--name":
                # a config without free variables: even a valid --name stops before anything is written
                argv = ["run", str(CONFIGS / "cpr_rrr.yaml"), "--quiet", f"--name={name}"]
                _, _, err = run_case(work, outside, argv, what, allowed=(2,))
                assert ("--name:" in err) == (not valid), (what, err)
                assert not any(work.iterdir())
                return
            if slot == "batch name":
                try:
                    body = yamlsafe.dump({"base": str(BATCH_SMALL), "name": name, "seeds": [1]})
                except UnicodeEncodeError:
                    return
                (work / "b.yaml").write_text(body, encoding="utf-8", errors="surrogateescape")
                rc, out, err = run_case(work, outside, ["batch", "--dry-run", "b.yaml"], what,
                                        allowed=(0,) if valid else (2,))
                if valid:
                    for line in out.splitlines():
                        folder = Path(line.split()[1])
                        assert folder.parent == Path("runs") and folder.name.startswith(name), (what, line)
                elif "YAML" not in err and "control character" not in err:
                    assert "b.yaml: name: " in err, (what, err)
                assert files_under(work) == {"b.yaml"}
                return
            data = _config(slot, name)
            try:
                text = yamlsafe.dump(data, sort_keys=False, allow_unicode=True)
                (work / "c.yaml").write_text(text, encoding="utf-8")
            except UnicodeEncodeError:      # a lone surrogate cannot even be written as UTF-8
                return
            design = name if slot == "design name" else "before"
            argv = ["atlas", "c.yaml", "--no-plots", "--resolution", "3", f"--design={design}"]
            rc, _, err = run_case(work, outside, argv, what, allowed=(0,) if valid else (2,))
            if valid:
                cname = name if slot == "config name" else "p4s_small"
                assert files_under(work) == {"c.yaml", "indices", f"indices/{cname}-{design}",
                                             f"indices/{cname}-{design}/local_indices.csv"}, (what, files_under(work))
            else:
                assert files_under(work) == {"c.yaml"}, (what, files_under(work))
                if "YAML" not in err and "control character" not in err:
                    key = {"config name": "c.yaml: name: ", "design name": "c.yaml: designs.",
                           "index name": "c.yaml: indices."}[slot]
                    assert key in err, (what, err)

    check()
    assert cases.n >= 200


# ----------------------------------------------------------------------------- output roots
def _make(work: Path, label: str) -> str:
    if label == "a file":
        (work / "f").write_text("x")
        return "f"
    if label == "a folder under a file":
        (work / "f").write_text("x")
        return "f/sub"
    if label == "a symbolic-link loop":
        (work / "loop").symlink_to(work / "loop")
        return "loop"
    return {"/dev/null": "/dev/null", "an empty path": "", "a NUL": "a\x00b", "too long a name": "x" * 5000,
            "/proc/self/status": "/proc/self/status"}[label]


OUTS = ["a file", "a folder under a file", "/dev/null", "an empty path", "a NUL", "too long a name",
        "a symbolic-link loop", "/proc/self/status"]
OUT_COMMANDS = {
    "run": ["run", str(DATA / "p4s_small.yaml"), "--quiet"],
    "reproduce": ["reproduce", str(DATA / "p4s_small.yaml"), "--quiet"],
    "batch": ["batch", str(BATCH_SMALL)],
    "batch --dry-run": ["batch", str(BATCH_SMALL), "--dry-run"],
    "atlas": ["atlas", str(DATA / "p4s_small.yaml"), "--no-plots"],
    "summarize": ["summarize", "."],
}


@pytest.mark.parametrize("command", list(OUT_COMMANDS))
@pytest.mark.parametrize("label", OUTS)
def test_bad_output_roots(label, command):
    with sandbox() as (work, outside):
        out = _make(work, label)
        before = files_under(work)
        run_case(work, outside, OUT_COMMANDS[command] + ["--out", out], f"--out {label} / {command}",
                 key="--out: ", allowed=(2,))
        assert files_under(work) == before


@pytest.mark.parametrize("command", ["run", "reproduce", "batch"])
def test_runs_as_a_file(command):
    with sandbox() as (work, outside):
        (work / "runs").write_text("not a folder")
        run_case(work, outside, OUT_COMMANDS[command], f"runs a file / {command}", key="--out: runs is not a folder",
                 allowed=(2,))
        assert files_under(work) == {"runs"}


def test_a_symbolic_link_where_the_atlas_writes():
    with sandbox() as (work, outside):
        (work / "indices").mkdir()
        (work / "indices" / "p4s_small-before").symlink_to(outside)
        run_case(work, outside, ["atlas", str(DATA / "p4s_small.yaml"), "--no-plots", "--design", "before"],
                 "atlas into a link", key="outside", allowed=(2,))


def test_a_symbolic_link_where_a_batch_run_goes():
    (t,) = plan([str(BATCH_SMALL)], seeds=[1])
    with sandbox() as (work, outside):
        (work / "runs").mkdir()
        (work / "runs" / t.folder_name).symlink_to(outside)
        rc, out, err = run_case(work, outside, ["batch", str(BATCH_SMALL), "--seed-list", "1", "--jobs", "1"],
                                "batch into a link", allowed=(1,))
        assert "outside" in out
