"""Random mutations of every shipped config (configs/*.yaml), run through
``optdesign validate-config`` in-process: wrong types, huge and tiny
numbers, non-finite numbers, unicode text, deep nesting, deleted keys,
mistyped keys (which must be refused with a "did you mean"), and valid
changes (which must be read exactly: no silent wrong result).  The
p4s-specific catalogue of exact messages is tests/test_hostile_config.py."""
from __future__ import annotations

import pytest

import copy
import math

import yaml
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import CONFIGS
from hostile_helpers import Cases, run_case, sandbox
from optdesign.config import load_config, yamlsafe
from optdesign.config.reader import join

SHIPPED = {p.name: yaml.safe_load(p.read_text()) for p in sorted(CONFIGS.glob("*.yaml")) if p.name != "batch_example.yaml"}
SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])
#: mappings whose keys the user chooses (a new key there is a new design, index or reference)
#: mappings whose keys are the user's own names (a renamed one is a new name, not a typo):
#: named designs, indices, reference values and a described mechanism's declared parameters
FREE_KEYS = {("designs",), ("indices",), ("reference",), ("mechanism", "parameters")}


def _paths(node, prefix=()):
    """Every (path, value) below ``node``: mapping entries and list items."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield prefix + (k,), v
        yield from _paths(v, prefix + (k,))


def _key(path) -> str:
    out = ""
    for p in path:
        out = join(out, p)
    return out


def _set(data, path, value):
    node = data
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


def _nested(depth: int):
    v = 1.0
    for _ in range(depth):
        v = [v]
    return v


_HOSTILE = st.one_of(
    st.sampled_from([[], {}, [1, 2, 3], "abc", True, False, None, "", " ", "0.1", {"value": "x"}, [[0.1, 0.2]]]),
    st.sampled_from([1e300, -1e300, 10 ** 400, -(10 ** 30), 10 ** 20, 1e13, 5e-324, -5e-324, 0, -0.0, -1]),
    st.sampled_from([math.nan, math.inf, -math.inf]),
    st.text(max_size=40).filter(lambda s: not any(0xD800 <= ord(c) <= 0xDFFF for c in s)),
    st.integers(1, 120).map(_nested),
)


def _typo(key: str, how: int, pos: int) -> str:
    """A one-edit typo of ``key``: a swap, a deletion, a doubling or a case change."""
    i = pos % len(key)
    if how == 0 and len(key) > 1:
        i = min(i, len(key) - 2)
        return key[:i] + key[i + 1] + key[i] + key[i + 2:]
    if how == 1 and len(key) > 1:
        return key[:i] + key[i + 1:]
    if how == 2:
        return key[:i] + key[i] + key[i:]
    return key.swapcase() if key.swapcase() != key else key + "s"


@st.composite
def mutations(draw):
    """(config name, mutated data, description, kind, mutated path, extra)."""
    name = draw(st.sampled_from(sorted(SHIPPED)))
    data = copy.deepcopy(SHIPPED[name])        # a fresh copy (a YAML round trip cost 20 ms an example)
    paths = list(_paths(data))
    kind = draw(st.sampled_from(["replace", "replace", "delete", "typo", "unicode", "valid"]))
    dvs = [(k, v) for k, v in data["design_variables"].items()
           if isinstance(v, dict) and v.get("bounds") and v["bounds"][1] > v["bounds"][0]]
    if kind == "valid" and not dvs:     # a config without free variables
        kind = "replace"
    if kind == "valid":
        k, v = draw(st.sampled_from(dvs))
        lo, hi = v["bounds"]
        x = draw(st.floats(lo, hi, allow_nan=False))
        v["value"] = x
        return name, data, f"design_variables.{k}.value = {x!r}", kind, ("design_variables", k), x
    if kind == "typo":
        keyed = [(p, v) for p, v in paths if isinstance(p[-1], str) and p[:-1] not in FREE_KEYS and p[-1] != "<<"]
        path, _ = draw(st.sampled_from(keyed))
        new = _typo(path[-1], draw(st.integers(0, 3)), draw(st.integers(0, 100)))
        parent = data
        for p in path[:-1]:
            parent = parent[p]
        if new in parent:
            new = new + "_x"
        parent[new] = parent.pop(path[-1])
        return name, data, f"{_key(path)} -> {new}", kind, path[:-1] + (new,), path[-1]
    path, _ = draw(st.sampled_from(paths))
    if kind == "delete":
        parent = data
        for p in path[:-1]:
            parent = parent[p]
        del parent[path[-1]]
        return name, data, f"without {_key(path)}", kind, path, None
    value = draw(st.text(max_size=60).filter(lambda s: not any(0xD800 <= ord(c) <= 0xDFFF for c in s))
                 if kind == "unicode" else _HOSTILE)
    _set(data, path, value)
    return name, data, f"{_key(path)} = {str(value)[:60]!r}", kind, path, value


@pytest.mark.slow
def test_mutated_shipped_configs():
    cases = Cases()
    counts = {"refused": 0, "accepted": 0}

    @settings(max_examples=350, **SETTINGS)
    @given(case=mutations())
    def check(case):
        cases()
        name, data, what, kind, path, extra = case
        with sandbox() as (work, outside):
            try:
                text = yamlsafe.dump(data, sort_keys=False, allow_unicode=True)
            except (ValueError, OverflowError, RecursionError):
                return
            (work / "c.yaml").write_text(text, encoding="utf-8")
            rc, _, err = run_case(work, outside, ["validate-config", "c.yaml"], f"{name}: {what}",
                                  allowed=(0, 2), file="c.yaml")
            counts["refused" if rc == 2 else "accepted"] += 1
            if rc == 2 and kind != "delete" and not err.startswith("optdesign: error: c.yaml: YAML"):
                # the line names the section the mutation was in (a deleted key may be missed where
                # another section refers to it: an index named by the weights)
                assert f"c.yaml: {path[0]}" in err or "c.yaml: nested" in err, f"{name}: {what}: {err}"
            if kind == "typo":
                assert rc == 2, f"{name}: {what}: a mistyped key was accepted"
                assert _key(path) in err and ("unknown" in err), f"{name}: {what}: {err}"
                if len(extra) >= 4 and (len(path) < 3 or path[-3:-1] != ("workspace", "axes")):
                    assert "did you mean" in err, f"{name}: {what}: {err}"
            if rc == 0:
                cfg = load_config(work / "c.yaml")
                if kind == "valid":
                    dv = cfg.design_variables[path[1]]
                    unit = data["design_variables"][path[1]].get("unit")
                    scale = {"deg": math.pi / 180.0, "mm": 1e-3}.get(unit, 1.0)
                    assert dv.value == extra * scale, (what, dv.value)
                elif kind in ("replace", "unicode"):
                    node = cfg.raw
                    for p in path:
                        node = node[p]
                    assert node == extra or (isinstance(extra, float) and math.isnan(extra)), (what, node)
            if kind == "valid" and rc == 2:    # only the mechanism's geometry may refuse a value inside the bounds
                assert "design_variables" in err and "expected" in err, err

    check()
    assert cases.n >= 350
    assert counts["refused"] > 100 and counts["accepted"] > 20, counts
