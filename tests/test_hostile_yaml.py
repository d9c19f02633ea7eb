"""The YAML reader of configs and batch files (optdesign.config.yamlsafe),
attacked through the real commands: duplicate keys at any depth, alias bombs
anywhere (a batch sweep value included), YAML 1.1 surprises where a number or
a boolean is expected, special files, oversized files, other encodings,
surrogates and control characters.  See tests/hostile_helpers.py for what
every case must satisfy; the counts are in docs/reliability.md."""
from __future__ import annotations

import math
import os
import re
import socket
import stat
import threading
import time
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import BATCH_SMALL, CONFIGS, DATA, PAPER, edited_text
from hostile_helpers import Cases, run_case, sandbox
from optdesign.config import load_config, parse_config, yamlsafe

SHIPPED = sorted(p for p in CONFIGS.glob("*.yaml") if p.name != "batch_example.yaml") + [DATA / "p4s_small.yaml"]
FAST_COMMANDS = (["validate-config"], ["evaluate", "--json"], ["batch", "--dry-run"], ["atlas", "--no-plots"],
                 ["run", "--quiet"])
SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


# ----------------------------------------------------------------------------- round trip
_LOOKALIKES = ["yes", "no", "on", "off", "y", "n", "Yes", "ON", "1:30", "012", "0x1f", "0o17", "0b101", "1e3",
               "1_000", ".inf", "-.inf", ".nan", "~", "null", "Null", "True", "FALSE", "<<", "", " ", "2001-12-14",
               "+1", "-0", "1.", ".5", "=", "!", "&a", "*a", "- x", "a: b", "#c", "'q'", '"d"']
_TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=30) | st.sampled_from(_LOOKALIKES)
_SCALARS = (st.none() | st.booleans() | st.integers(-10 ** 30, 10 ** 30) | _TEXT
            | st.floats(allow_nan=True, allow_infinity=True))
_DATA = st.recursive(_SCALARS, lambda inner: st.lists(inner, max_size=4)
                     | st.dictionaries(_TEXT, inner, max_size=4), max_leaves=30)


def _same(a, b) -> bool:
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and math.isnan(a):
        return math.isnan(b)
    return a == b


@pytest.mark.slow
def test_round_trip_of_plain_data():
    """What the package writes (a batch's resolved configs) reads back to the
    same values, both by our YAML 1.2 reader and by PyYAML's YAML 1.1 one:
    strings that either would read as something else are quoted."""
    cases = Cases()

    @settings(max_examples=200, **SETTINGS)
    @given(data=st.dictionaries(_TEXT, _DATA, max_size=5))
    def check(data):
        cases()
        text = yamlsafe.dump(data, sort_keys=False, allow_unicode=True)
        assert _same(yamlsafe.load(text), data), text
        assert _same(yaml.safe_load(text) or {}, data), text

    check()
    assert cases.n >= 200


# ----------------------------------------------------------------------------- duplicate keys
_BLOCK_KEY = re.compile(r"^(\s*)([A-Za-z_][A-Za-z0-9_]*):")
_FLOW_ITEM = re.compile(r"([{,]\s*)([A-Za-z_][A-Za-z0-9_]*): ([^,{}\[\]]+|\[[^\[\]]*\])(?=\s*[,}])")


def _duplicate(text: str, choice: int, flow: bool) -> tuple[str, str] | None:
    """The text with one mapping key written twice, and that key (None if the text has none of the kind)."""
    lines = text.splitlines(keepends=True)
    if not flow:
        keyed = [i for i, line in enumerate(lines) if _BLOCK_KEY.match(line)]
        i = keyed[choice % len(keyed)]
        return "".join(lines[:i + 1] + [lines[i]] + lines[i + 1:]), _BLOCK_KEY.match(lines[i]).group(2)
    # flow items in the YAML itself, not in a trailing comment ("# theta1, theta2, theta3: crank angles")
    items = [(i, m) for i, line in enumerate(lines) if not line.lstrip().startswith("#")
             for m in _FLOW_ITEM.finditer(line.split(" #")[0])]
    if not items:
        return None
    i, m = items[choice % len(items)]
    line = lines[i]
    lines[i] = line[:m.end()] + f", {m.group(2)}: {m.group(3)}" + line[m.end():]
    return "".join(lines), m.group(2)


@pytest.mark.slow
def test_duplicate_keys_are_refused_at_every_level():
    cases = Cases()

    @settings(max_examples=120, **SETTINGS)
    @given(src=st.sampled_from(SHIPPED), choice=st.integers(0, 10 ** 6), flow=st.booleans(),
           command=st.sampled_from(FAST_COMMANDS[:3]))
    def check(src, choice, flow, command):
        made = _duplicate(src.read_text(), choice, flow)
        if made is None:
            return
        cases()
        text, key = made
        with sandbox() as (work, outside):
            (work / "c.yaml").write_text(text)
            rc, _, err = run_case(work, outside, command + ["c.yaml"], f"{src.name}: {key} twice", file="c.yaml",
                                  key="duplicate key", allowed=(2,))
            assert re.search(rf"(^|[.: ]){re.escape(key)}: duplicate key", err), err

    check()
    assert cases.n >= 120


def test_duplicate_mechanism_is_refused():
    text = PAPER.read_text().replace("mechanism: p4s\n", "mechanism: p4s\nmechanism: sps_s\n", 1)
    with sandbox() as (work, outside):
        (work / "c.yaml").write_text(text)
        rc, _, err = run_case(work, outside, ["validate-config", "c.yaml"], "mechanism twice", file="c.yaml",
                              key="mechanism: duplicate key (line 5; first at line 4)", allowed=(2,))


# ----------------------------------------------------------------------------- alias bombs
def _inline_bomb(levels: int, width: int) -> str:
    parts = ["&a0 [" + ", ".join(["lol"] * width) + "]"]
    for i in range(1, levels):
        parts.append(f"&a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return "[" + ", ".join(parts) + "]"


_LEAVES = ["description", "parameters.m_platform", "design_variables.r_a.bounds", "workspace.axes.x",
           "workspace.step", "indices.dynamic.options", "optimizer.population", "reference.before.dynamic", "name"]


@pytest.mark.slow
def test_alias_bombs_are_refused_quickly():
    """Bombs of 2 to 12 levels of 2 to 12 aliases, in a config leaf or as a
    batch file's sweep values: refused (one short line) within seconds; the
    large ones while the anchors are read, before anything is expanded."""
    cases = Cases()
    paper_text = PAPER.read_text()

    @settings(max_examples=80, **SETTINGS)
    @given(levels=st.integers(2, 12), width=st.integers(2, 12), leaf=st.sampled_from(_LEAVES + ["sweep"]))
    def check(levels, width, leaf):
        cases()
        bomb = _inline_bomb(levels, width)
        with sandbox() as (work, outside):
            if leaf == "sweep":
                (work / "b.yaml").write_text(f"base: {BATCH_SMALL}\nsweep:\n  parameters.m_platform: {bomb}\n")
                argv, name = ["batch", "--dry-run", "b.yaml"], "b.yaml"
            else:
                data = yaml.safe_load(paper_text)
                node = data
                *head, last = leaf.split(".")
                for k in head:
                    node = node[k]
                node[last] = "BOMB_HERE"
                (work / "c.yaml").write_text(yamlsafe.dump(data, sort_keys=False).replace("BOMB_HERE", bomb))
                argv, name = ["validate-config", "c.yaml"], "c.yaml"
            t0 = time.process_time()     # CPU seconds: the bound holds however busy the machine is
            rc, _, err = run_case(work, outside, argv, f"bomb {levels}x{width} at {leaf}", file=name, allowed=(2,))
            assert time.process_time() - t0 < 5, f"bomb {levels}x{width}: {time.process_time() - t0:.1f} s"
            assert len(err) < 600
            expanded = sum(width ** i for i in range(1, levels + 1))
            if expanded > yamlsafe.MAX_NODES:
                assert "aliases expanded" in err or "aliases (line" in err, err

    check()
    assert cases.n >= 80


def test_aliases_give_copies_not_shared_objects():
    data = yamlsafe.load("a: &x {b: [1, 2]}\nc: *x\nd:\n  <<: *x\n  e: 3\n")
    assert data == {"a": {"b": [1, 2]}, "c": {"b": [1, 2]}, "d": {"b": [1, 2], "e": 3}}
    data["a"]["b"].append(9)
    assert data["c"] == {"b": [1, 2]} and data["d"]["b"] == [1, 2]


# ----------------------------------------------------------------------------- YAML 1.1 surprises
# (text written where a number is expected, expected value or the words of the error)
SURPRISES = [
    ("1:30", "sexagesimal"), ("-1:30:00", "sexagesimal"), ("yes", "yes/no/on/off"), ("no", "yes/no/on/off"),
    ("on", "yes/no/on/off"), ("off", "yes/no/on/off"), ("y", "yes/no/on/off"), ("ON", "yes/no/on/off"),
    ("1_000", "grouped with '_'"), ("0b101", "a string"), ("2001-12-14", "a string"), ("true", "a boolean"),
    ("True", "a boolean"), ("~", r"nothing \(null\)"), ("NULL", r"nothing \(null\)"), (".inf", "finite|an integer"),
    ("-.Inf", "finite|an integer"), (".nan", "finite|an integer"), ("'12'", "a string '12'"),
    ("!!str 12", "a string '12'"),
    ("012", 12), ("0x10", 16), ("0o20", 16), ("+12", 12), ("12", 12), ("!!int 12", 12),
]
SLOTS = {  # where in the paper config, and how a value there is read back (SI)
    "optimizer.population": lambda c: c.optimizer.population,
    "parameters.m_platform": lambda c: c.parameters["m_platform"],
    "workspace.axes.z": lambda c: c.workspace.axes["z"][0],
}


@pytest.mark.parametrize("slot", list(SLOTS))
@pytest.mark.parametrize("text, outcome", SURPRISES, ids=[s[0] for s in SURPRISES])
def test_yaml11_surprises_where_a_number_is_expected(slot, text, outcome):
    data = yaml.safe_load(PAPER.read_text())
    *head, last = slot.split(".")
    node = data
    for k in head:
        node = node[k]
    node[last] = "VALUE_HERE"
    body = yamlsafe.dump(data, sort_keys=False).replace("VALUE_HERE", text)
    with sandbox() as (work, outside):
        (work / "c.yaml").write_text(body)
        if isinstance(outcome, str):
            run_case(work, outside, ["validate-config", "c.yaml"], f"{slot} = {text}", file="c.yaml",
                     key=f"{slot}: ", allowed=(2,))
            _, _, err = run_case(work, outside, ["validate-config", "c.yaml"], text, allowed=(2,))
            assert re.search(outcome, err), err
        elif slot == "workspace.axes.z":   # read as 12 m or 16 m: out of the paper design's reach
            _, _, err = run_case(work, outside, ["validate-config", "c.yaml"], f"{slot} = {text}", allowed=(2,))
            assert "no pose of W is reachable for design 'initial'" in err, err
            value = SLOTS[slot](load_config(work / "c.yaml"))
            assert value == outcome and type(value) is float
        else:
            run_case(work, outside, ["validate-config", "c.yaml"], f"{slot} = {text}", allowed=(0,))
            value = SLOTS[slot](load_config(work / "c.yaml"))
            assert value == outcome and type(value) is (int if slot == "optimizer.population" else float)


def test_numbers_yaml11_reads_as_strings_are_numbers():
    """1e-3 (no dot) is a number; PyYAML's YAML 1.1 reads it as a string."""
    text = PAPER.read_text().replace("step: 0.01", "step: 1e-2").replace("m_rod: 1.59", "m_rod: 159e-2")
    assert yaml.safe_load(text)["workspace"]["step"] == "1e-2"
    cfg = parse_config(text, "c.yaml")
    assert cfg.workspace.step == 0.01 and cfg.parameters["m_rod"] == 1.59


@pytest.mark.parametrize("word", ["yes", "on", "y", "1", "'true'"])
def test_yes_is_not_a_boolean_in_a_batch_file(tmp_path, word):
    (tmp_path / "b.yaml").write_text(f"base: {BATCH_SMALL}\npareto: {word}\n")
    with sandbox() as (work, outside):
        (work / "b.yaml").write_text(f"base: {BATCH_SMALL}\npareto: {word}\n")
        run_case(work, outside, ["batch", "--dry-run", "b.yaml"], word, file="b.yaml", key="pareto: expected true or false",
                 allowed=(2,))


# ----------------------------------------------------------------------------- files
def _run_with_deadline(work, outside, argv, what, unblock: Path | None = None, **expect):
    """run_case in a thread; a case that blocks (a FIFO opened for reading) fails instead of hanging."""
    result = {}

    def target():
        try:
            result["out"] = run_case(work, outside, argv, what, **expect)
        except BaseException as exc:  # noqa: BLE001 - re-raised below
            result["exc"] = exc

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(120)         # a case that does not block returns long before, even on a busy machine
    if t.is_alive():
        if unblock is not None:
            fd = os.open(unblock, os.O_WRONLY | os.O_NONBLOCK)
            os.close(fd)
        t.join(10)
        pytest.fail(f"{what}: blocked")
    if "exc" in result:
        raise result["exc"]
    return result["out"]


def _padded(size: int) -> bytes:
    body = BATCH_SMALL.read_bytes()
    pad = size - len(body)
    return body + (b"#" * (pad - 1) + b"\n" if pad > 0 else b"")


SPECIAL = {
    "FIFO": ("fifo", "is a FIFO"),
    "/dev/zero": ("/dev/zero", "is a device"),
    "/dev/null": ("/dev/null", "is a device"),
    "/dev/urandom": ("/dev/urandom", "is a device"),
    "symlink to /dev/zero": ("zero-link", "is a device"),
    "directory": ("adir", "is a directory"),
    "socket": ("sock", "is a socket"),
    "dangling symlink": ("dangling", "file not found"),
    "symlink loop": ("loop", "cannot read file"),
    "sparse 100 MB file": ("sparse", "at most 1,000,000 bytes"),
    "1 MB + 1 byte": ("big", "at most 1,000,000 bytes"),
    "newline in the name": ("bad\nname.yaml", "file not found"),
    "a file inside a file": ("plain/inside.yaml", "file not found"),
}


def _make_special(work: Path, label: str):
    name = SPECIAL[label][0]
    p = work / name
    if label == "FIFO":
        os.mkfifo(p)
    elif label == "symlink to /dev/zero":
        p.symlink_to("/dev/zero")
    elif label == "directory":
        p.mkdir()
    elif label == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(p))
        return name, s
    elif label == "dangling symlink":
        p.symlink_to(work / "nothing-here")
    elif label == "symlink loop":
        p.symlink_to(work / "loop")
    elif label == "sparse 100 MB file":
        with open(p, "wb") as fh:
            fh.truncate(100_000_000)
    elif label == "1 MB + 1 byte":
        p.write_bytes(_padded(yamlsafe.MAX_BYTES + 1))
    elif label == "a file inside a file":
        (work / "plain").write_text("x")
    return name, None


@pytest.mark.parametrize("command", FAST_COMMANDS, ids=lambda c: c[0])
@pytest.mark.parametrize("label", list(SPECIAL))
def test_special_and_oversized_files_are_refused_before_reading(label, command):
    with sandbox() as (work, outside):
        name, keep = _make_special(work, label)
        try:
            t0 = time.process_time()
            _, _, err = _run_with_deadline(work, outside, command + [name], f"{label} / {command[0]}",
                                           unblock=work / name if label == "FIFO" else None, allowed=(2,))
            assert SPECIAL[label][1] in err, err
            assert time.process_time() - t0 < 5
        finally:
            if keep is not None:
                keep.close()


def test_a_file_of_exactly_the_limit_is_read():
    with sandbox() as (work, outside):
        (work / "c.yaml").write_bytes(_padded(yamlsafe.MAX_BYTES))
        assert (work / "c.yaml").stat().st_size == yamlsafe.MAX_BYTES
        run_case(work, outside, ["validate-config", "c.yaml"], "1 MB", allowed=(0,))


# ----------------------------------------------------------------------------- encodings and characters
_BASE = BATCH_SMALL.read_text()


def _edit(old: str, new: str) -> str:
    return edited_text(_BASE, {old: new})

ENCODINGS = {   # label: (bytes, accepted?, words of the error)
    "UTF-16 LE": (_BASE.encode("utf-16"), False, "not a text file"),
    "UTF-16 BE": (_BASE.encode("utf-16-be"), False, "not a text file"),
    "UTF-32": (_BASE.encode("utf-32"), False, "not a text file"),
    "Latin-1": (edited_text(_BASE, {"name: batch_small": "name: b\ndescription: caf\xe9"}).encode("latin-1"),
                False, "not a text file"),
    "UTF-8 with BOM": (b"\xef\xbb\xbf" + _BASE.encode(), True, None),
    "CRLF lines": (edited_text(_BASE, {"\n": "\r\n"}).encode(), True, None),
    "surrogate escape": (_edit("name: batch_small", 'name: "\\ud800"').encode(), False, "invalid Unicode"),
    "surrogate bytes": (_edit("name: batch_small", "name: x").encode() + b"description: \xed\xa0\x80\n",
                        False, "not a text file"),
    "control escape in a name": (_edit("name: batch_small", 'name: "a\\x01b"').encode(), False,
                                 "name: value 'a\\x01b' holds a control character"),
    "ANSI escape in a value": (_edit("name: batch_small", 'name: b\ndescription: "\\e[31mred"').encode(),
                               False, "holds a control character"),
    "NEL in a value": (_edit("name: batch_small", 'name: b\ndescription: "a\\Nb"').encode(), False,
                       "control character"),
    "newline in a name": (_edit("name: batch_small", 'name: "a\\nb"').encode(), False, "U+000A"),
    "tab in a value": (_edit("name: batch_small", 'name: b\ndescription: "a\\tb"').encode(), True, None),
    "zero-width joiner in a name": (_edit("name: batch_small", "name: a\u200db").encode(), False, "U+200D"),
    "RTL override in a value": (_edit("name: batch_small", "name: b\ndescription: a\u202eb").encode(),
                                True, None),
    "control character in a key": (_edit("name: batch_small", '"na\\x7fme": b').encode(), False,
                                   "control character"),
}


@pytest.mark.parametrize("command", FAST_COMMANDS[:2], ids=lambda c: c[0])
@pytest.mark.parametrize("label", list(ENCODINGS))
def test_encodings_and_characters(label, command):
    data, ok, words = ENCODINGS[label]
    with sandbox() as (work, outside):
        (work / "c.yaml").write_bytes(data)
        _, _, err = run_case(work, outside, command + ["c.yaml"], label, file=None if ok else "c.yaml",
                             allowed=(0,) if ok else (2,))
        if words:
            assert words in err, err
        if ok and label == "RTL override in a value":
            assert load_config(work / "c.yaml").raw["description"] == "a\u202eb"


def test_the_file_is_not_read_twice_unbounded(tmp_path, monkeypatch):
    """A config is read once, at most limit + 1 bytes, whatever its size claims."""
    reads = []
    real = os.read

    def counting(fd, n):
        b = real(fd, n)
        reads.append(len(b))
        return b

    p = tmp_path / "c.yaml"
    p.write_bytes(_padded(yamlsafe.MAX_BYTES + 5000))
    monkeypatch.setattr(os, "stat", lambda path, *a, **k: _fake_stat(path))
    monkeypatch.setattr(os, "read", counting)
    with pytest.raises(Exception, match="at most 1,000,000 bytes"):
        load_config(p)
    assert sum(reads) == yamlsafe.MAX_BYTES + 1


def _fake_stat(path):
    """A stat result that calls every file a small regular one (as /proc files do)."""
    st_ = os.lstat(path)
    return os.stat_result((stat.S_IFREG | 0o644, st_.st_ino, st_.st_dev, 1, 0, 0, 10, 0, 0, 0))
