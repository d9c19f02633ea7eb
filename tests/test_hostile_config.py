"""Broken configs end with exit status 2 and one line naming the file and the key.

A property-based test mutates ``configs/p4s_paper.yaml`` (wrong types, missing
and extra keys, NaN and infinite numbers, zero and negative lengths, reversed
bounds, unknown names, huge numbers) and runs ``optdesign validate-config``,
``evaluate``, ``atlas`` or ``reproduce`` on each (``run``, ``batch`` and
``validate-dynamics`` too on the whole-file cases); whole-file cases (empty, binary, not a
mapping, deeply nested, anchor bombs, unsafe tags) run both in-process and as
real processes.  Every run must return 2, print exactly one stderr line
``optdesign: error: <file>: <key>: ...`` with no traceback, and write nothing
(in particular nothing under ``runs/`` or ``indices/``).
"""
from __future__ import annotations

import copy
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
import yaml
from cli_helpers import run_cli_in
from conftest import paper_data
from hypothesis import HealthCheck, given, settings, strategies as st

BASE = paper_data()
COMMANDS = (["validate-config"], ["evaluate"], ["evaluate", "--json"], ["atlas", "--no-plots"], ["reproduce"])
# commands that would run long on a valid config: only for files that cannot be valid
WHOLE_FILE_COMMANDS = COMMANDS + (["run", "--quiet"], ["batch"], ["validate-dynamics", "--design", "before"])

# ----------------------------------------------------------------------------- catalogue
NAN, INF = float("nan"), float("inf")
HUGE = (1e300, -1e300, 10 ** 400, -(10 ** 400), 1e13)
NON_FINITE = (NAN, INF, -INF)
WRONG_TYPE = ("abc", True, [1.0], {"zz": 1}, "1.5", b"\x00\x01")
NOT_A_NUMBER = WRONG_TYPE + (None,)


def _number_bad(positive=False, nonneg=False):
    bad = NOT_A_NUMBER + NON_FINITE + HUGE
    if positive:
        bad += (0, 0.0, -1e-9, -0.25)
    elif nonneg:
        bad += (-1e-9, -4.16)
    return bad


def _int_bad(minimum, maximum):
    return NOT_A_NUMBER + NON_FINITE + (2.5, minimum - 1, maximum + 1, 10 ** 400, -(10 ** 400))


def _pair_bad(positive=False, none_ok=False):
    bad = (() if none_ok else (None,)) + ("abc", 1.0, [1.0], [1.0, 2.0, 3.0], [], [NAN, 0.3], [0.2, INF], ["a", 0.3],
           [0.3, 0.2], [1e300, 1e301], {"lo": 1})
    return bad + (([-0.3, -0.2], [0.0, 0.3]) if positive else ())


def _choice_bad():
    return ("no_such_name", "", 3, None, [1], {"a": 1}, True)


LENGTHS = ("r_a", "r_b", "L", "d")
# (path, bad values, expected key prefix in the message or None for the path itself)
LEAVES: list[tuple[tuple, tuple, str | None]] = [
    (("mechanism",), _choice_bad() + ("P4S", "p4s "), None),
    (("name",), (3, None, [1], {"a": 1}, True), None),
    (("description",), (3, [1], {"a": 1}, True, 1.5), None),
    (("parameters", "m_platform"), _number_bad(nonneg=True), None),
    (("parameters", "m_rod"), _number_bad(nonneg=True), None),
    (("parameters", "rod_Ixx"), _number_bad(nonneg=True), None),
    (("parameters", "g"), _number_bad(nonneg=True), None),
    (("parameters", "k"), _number_bad(positive=True), None),
    (("design_variables", "phi", "unit"), ("furlong", 3, [1], "DEG"), None),
    (("workspace", "type"), _choice_bad(), None),
    (("workspace", "sampling"), _choice_bad(), None),
    (("workspace", "step"), _number_bad(positive=True) + (1e-9,), None),
    (("workspace", "axes", "x"), tuple(v for v in _pair_bad() if not isinstance(v, float)) + (NAN, INF), None),
    (("workspace", "axes", "z"), NOT_A_NUMBER + NON_FINITE + HUGE, None),
    (("indices", "dynamic", "kind"), _choice_bad(), None),
    (("indices", "stiffness", "convention"), _choice_bad(), None),
    (("indices", "isotropy", "sense"), _choice_bad(), None),
    (("optimizer", "algorithm"), _choice_bad(), None),
    (("optimizer", "normalization"), _choice_bad(), None),
    (("optimizer", "population"), _int_bad(4, 100_000), None),
    (("optimizer", "generations"), _int_bad(1, 100_000), None),
    (("optimizer", "elites"), _int_bad(0, 49), None),
    (("optimizer", "seed"), _int_bad(0, 2 ** 32 - 1), None),
    (("optimizer", "crossover_probability"), _number_bad() + (1.5, -0.1), None),
    (("optimizer", "mutation_probability"), _number_bad() + (1.0001, -1e-9), None),
    (("optimizer", "weights", "dynamic"), _number_bad(nonneg=True), None),
    (("optimizer", "pareto", "algorithms"), ("nsga2", ["nsga9"], [1], None, {"a": 1}), None),
    (("optimizer", "pareto", "population"), _int_bad(4, 100_000), None),
    (("reference", "after", "dynamic"), NOT_A_NUMBER + NON_FINITE + HUGE, None),
]
for _v in ("r_a", "r_b", "phi"):
    LEAVES.append((("design_variables", _v, "value"), NOT_A_NUMBER + NON_FINITE + HUGE + (0.0, -0.25),
                   f"design_variables.{_v}"))
    LEAVES.append((("design_variables", _v, "bounds"), _pair_bad(positive=_v in LENGTHS, none_ok=True),
                   f"design_variables.{_v}"))
for _v in ("L", "d"):
    LEAVES.append((("design_variables", _v, "value"), NOT_A_NUMBER + NON_FINITE + HUGE + (0.0, -0.38),
                   f"design_variables.{_v}"))
for _dname in ("before", "after"):
    for _v in LENGTHS:
        LEAVES.append((("designs", _dname, _v), NOT_A_NUMBER + NON_FINITE + HUGE + (0.0, -0.1), None))
    LEAVES.append((("designs", _dname, "phi"), NOT_A_NUMBER + NON_FINITE + HUGE + (0.0, 90.0, -30.0, 180.0), None))
    LEAVES.append((("designs", _dname, "d"), (0.5, 0.6), None))   # d >= 2 r_a: no platform
# geometry that no config may hold: d >= 2 r_a on the design variables
LEAVES.append((("design_variables", "d", "value"), (0.6, 1.0), "design_variables.d"))

MISSING = [("mechanism",), ("design_variables",), ("workspace",), ("indices",),
           ("design_variables", "r_a"), ("design_variables", "L"), ("design_variables", "d"),
           ("design_variables", "phi", "value"), ("workspace", "axes"), ("workspace", "axes", "z"),
           ("workspace", "axes", "x"), ("workspace", "step")]

MAPPINGS = [(), ("parameters",), ("design_variables",), ("design_variables", "r_a"), ("designs",),
            ("designs", "before"), ("workspace",), ("workspace", "axes"), ("indices",),
            ("indices", "dynamic"), ("optimizer",), ("optimizer", "pareto"), ("optimizer", "weights"),
            ("reference",), ("reference", "before")]
EXTRA_VALUES = (1, "zzz", [1], {"zz": 1})
# a node replaced by something that is not a mapping
NOT_MAPPING = (None, 3, "abc", [1, 2], [{"a": 1}])
MAPPING_NODES = [m for m in MAPPINGS if m and m not in (("optimizer",), ("optimizer", "pareto"),
                                                         ("designs",), ("reference",), ("parameters",))]


def _key(path) -> str:
    return ".".join(str(p) for p in path)


def _get(d, path):
    for p in path:
        d = d[p]
    return d


@st.composite
def broken_configs(draw):
    """(mutated mapping, expected key prefix, description)."""
    data = copy.deepcopy(BASE)
    kind = draw(st.sampled_from(["leaf", "leaf", "leaf", "missing", "extra", "not_mapping"]))
    if kind == "leaf":
        path, bad, expect = draw(st.sampled_from(LEAVES))
        value = draw(st.sampled_from(bad))
        _get(data, path[:-1])[path[-1]] = value
        return data, expect or _key(path), f"{_key(path)} = {value!r}"
    if kind == "missing":
        path = draw(st.sampled_from(MISSING))
        del _get(data, path[:-1])[path[-1]]
        return data, _key(path), f"without {_key(path)}"
    if kind == "extra":
        path = draw(st.sampled_from(MAPPINGS))
        name = draw(st.sampled_from(["bogus", "R_A", "mechanisms", "extra key", "x" * 300]))
        value = draw(st.sampled_from(EXTRA_VALUES))
        _get(data, path)[name] = value
        # a key longer than 100 characters is named by its first 100 (messages stay short)
        return data, _key(path + (name[:100],)), f"extra {_key(path + (name[:20],))}"
    path = draw(st.sampled_from(MAPPING_NODES))
    allowed = NOT_MAPPING
    if path[0] == "design_variables":      # a plain number is a fixed design variable
        allowed = tuple(v for v in allowed if not isinstance(v, (int, float)))
    if path[0] == "indices":               # an empty entry takes the defaults of its kind
        allowed = tuple(v for v in allowed if v is not None)
    value = draw(st.sampled_from(allowed))
    _get(data, path[:-1])[path[-1]] = value
    return data, _key(path), f"{_key(path)} = {value!r}"


# ----------------------------------------------------------------------------- running
def _dump(data) -> str:
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


def _check_failure(rc, err, file_name, expect, what, tmp: Path):
    assert rc == 2, f"{what}: exit status {rc}, stderr {err!r}"
    assert err.endswith("\n") and err.count("\n") == 1, f"{what}: not one line: {err!r}"
    assert "Traceback" not in err, what
    assert err.startswith(f"optdesign: error: {file_name}: "), f"{what}: {err!r}"
    if expect:
        assert expect in err, f"{what}: the message does not name {expect!r}: {err!r}"
    assert len(err) < 2000, f"{what}: a {len(err)}-character message"
    left = sorted(p.name for p in tmp.iterdir())
    assert left == [file_name], f"{what}: wrote {left}"


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=broken_configs(), command=st.sampled_from(COMMANDS))
def test_broken_config_gives_one_line_and_status_2(case, command):
    data, expect, what = case
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        (tmp / "c.yaml").write_text(_dump(data), encoding="utf-8")
        rc, _, err = run_cli_in(tmp, command + ["c.yaml"])
        _check_failure(rc, err, "c.yaml", expect, what, tmp)


def test_the_unbroken_config_passes(tmp_path):
    (tmp_path / "c.yaml").write_text(_dump(BASE), encoding="utf-8")
    for command in COMMANDS[:3]:
        rc, out, err = run_cli_in(tmp_path, command + ["c.yaml"])
        assert rc == 0 and err == "", (command, err)


# ----------------------------------------------------------------------------- whole files
def _bomb(levels: int = 9, width: int = 9, where: str = "top") -> bytes:
    lines = ["a0: &a0 [" + ", ".join(["x"] * width) + "]"]
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    if where == "top":
        lines.append(f"mechanism: *a{levels - 1}")
        return ("\n".join(lines) + "\n").encode()
    # an otherwise valid config whose description holds the bomb (anchors defined inline)
    text = _dump({k: v for k, v in BASE.items() if k != "description"})
    inline = ["&a0 [" + ", ".join(["x"] * width) + "]"]
    for i in range(1, levels):
        inline.append(f"&a{i} [" + ", ".join([f"*a{i - 1}"] * width) + "]")
    return (text + "description: [" + ", ".join(inline) + "]\n").encode()


WHOLE_FILES = {
    "empty": (b"", None),
    "blank": (b"   \n\n\t\n", None),
    "comment only": (b"# nothing here\n", None),
    "binary": (bytes(range(256)) * 4, None),
    "NUL bytes": (b"mechanism: p4s\x00\n", None),
    "latin-1": ("mechanism: p4s\nname: caf\xe9\n".encode("latin-1"), None),
    "UTF-16": ("mechanism: p4s\n".encode("utf-16"), None),
    "a list": (b"- mechanism: p4s\n- 2\n", None),
    "an integer": (b"42\n", None),
    "a string": (b"just words\n", None),
    "null": (b"null\n", None),
    "deep flow nesting": (b"mechanism: " + b"[" * 1_200 + b"]" * 1_200 + b"\n", None),
    "deep block nesting": (b"".join(b" " * i + b"k:\n" for i in range(5_000)), None),
    # refused while the anchors are read (the 9^6 level passes the node limit), never expanded
    "anchor bomb": (_bomb(), "aliases expanded"),
    "anchor bomb as the description": (_bomb(where="description"), "description"),
    "python tag": (b"mechanism: !!python/object/apply:os.system ['echo hi']\n", None),
    "binary tag": (b"mechanism: !!binary aGVsbG8=\n", "mechanism"),
    "timestamp": (b"mechanism: 2001-12-14\n", "mechanism"),
    "unhashable key": (b"? [a, b]\n: 1\n", None),
    "integer key": (b"1: 2\n", None),
    "unclosed bracket": (b"mechanism: [p4s\n", None),
    "tab indentation": (b"mechanism:\tp4s\n\tname: x\n", None),
    "two documents": (b"mechanism: p4s\n---\nmechanism: p4s\n", None),
    "huge text": (b"mechanism: p4s\nname: " + b"x" * 500_000 + b"\n", None),
    "1e400 literal": (_dump(BASE).replace("m_rod: 1.59", "m_rod: 1.0e+400").encode(), "parameters.m_rod"),
    "digits": (_dump(BASE).replace("m_rod: 1.59", "m_rod: " + "9" * 4000).encode(), "parameters.m_rod"),
    "too many digits": (_dump(BASE).replace("m_rod: 1.59", "m_rod: " + "9" * 5000).encode(), None),
}


@pytest.mark.parametrize("label", list(WHOLE_FILES))
def test_whole_file_cases(tmp_path, label):
    data, expect = WHOLE_FILES[label]
    (tmp_path / "c.yaml").write_bytes(data)
    # deep nesting is refused at 64 levels; two commands suffice there
    commands = WHOLE_FILE_COMMANDS if label != "deep flow nesting" else (["validate-config"], ["run", "--quiet"])
    for command in commands:
        rc, _, err = run_cli_in(tmp_path, command + ["c.yaml"])
        _check_failure(rc, err, "c.yaml", expect, f"{label} / {command}", tmp_path)


def test_missing_file_and_directory(tmp_path):
    (tmp_path / "adir").mkdir()
    for name in ("nothing.yaml", "adir"):
        for command in COMMANDS:
            rc, _, err = run_cli_in(tmp_path, command + [name])
            assert rc == 2 and err.count("\n") == 1 and err.startswith(f"optdesign: error: {name}: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["adir"]


def test_unknown_design_name(tmp_path):
    (tmp_path / "c.yaml").write_text(_dump(BASE), encoding="utf-8")
    rc, _, err = run_cli_in(tmp_path, ["evaluate", "c.yaml", "--design", "nope"])
    _check_failure(rc, err, "c.yaml", "designs", "unknown design", tmp_path)


SUBPROCESS_CASES = ["binary", "anchor bomb", "digits"]


@pytest.mark.parametrize("label", SUBPROCESS_CASES)
def test_real_process(tmp_path, label):
    """The same through the installed command in a fresh interpreter (no
    traceback reaches the terminal, exit status 2)."""
    data, expect = WHOLE_FILES[label]
    (tmp_path / "c.yaml").write_bytes(data)
    cmd = [sys.executable, "-c", "import sys; from optdesign.cli import main; sys.exit(main())"]
    r = subprocess.run(cmd + ["evaluate", "c.yaml"], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    _check_failure(r.returncode, r.stderr, "c.yaml", expect, label, tmp_path)
    assert r.stdout == ""
