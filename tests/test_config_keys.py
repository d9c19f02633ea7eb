"""The config's key table (optdesign/config/keys.py) drives the allowed keys,
the spec dataclasses, the checks, the docs and these hostile cases: every
invalid value the table declares for a key (a wrong type, a value just outside
its range, a choice that is not one) ends ``validate-config`` with exit status
2 and one line naming the file and the key; the key's valid example passes in
the same place, so the refusal is the value's."""
from __future__ import annotations

import ast
import copy
import dataclasses
from pathlib import Path

import pytest
import yaml
from cli_helpers import run_cli_in
from conftest import DATA, ROOT

from optdesign.checking import Checker, CheckError, suggest
from optdesign.config import ConfigError, OptimizerSpec, parse_config
from optdesign.config.checks import CHECKS_KEYS, ChecksSpec
from optdesign.config.keydocs import main, markdown_table, update_docs
from optdesign.config.keys import CHECKS, OPTIMIZER, REQUIRED, SECTIONS, TOP, WORKSPACE
from optdesign.config.loader import TOP_KEYS
from optdesign.config.sections import OPT_KEYS, WS_KEYS
from optdesign.workspace import WorkspaceSpec

TINY = yaml.safe_load((DATA / "p4s_tiny.yaml").read_text())
DOCS = ROOT / "docs" / "config.md"


# ----------------------------------------------------------------------------- the table drives the code
def test_allowed_keys_come_from_the_table():
    assert OPT_KEYS == {k.name.split(".")[0] for k in OPTIMIZER.keys}
    assert OPTIMIZER.allowed("pareto") == {"algorithms", "population", "generations"}
    assert OPTIMIZER.allowed("extremes") == {"starts", "scan", "walk"}
    assert WS_KEYS == {k.name for k in WORKSPACE.keys} and CHECKS_KEYS == {k.name for k in CHECKS.keys}
    assert TOP_KEYS == {k.name for k in TOP.keys}


@pytest.mark.parametrize("cls, section", [(OptimizerSpec, OPTIMIZER), (ChecksSpec, CHECKS)])
def test_the_specs_are_the_tables(cls, section):
    fields = {f.name: (f.default if f.default_factory is dataclasses.MISSING else f.default_factory())
              for f in dataclasses.fields(cls)}
    assert fields == section.defaults()
    assert cls() == cls(**section.defaults())
    assert OptimizerSpec().population == 50 and OptimizerSpec().pareto_algorithms == ("nsga2", "nsga3")


def test_the_workspace_spec_agrees_with_the_table():
    """WorkspaceSpec lives below the config (it is not built from the table):
    its defaults must be the table's, but for ``tolerance``, which the spec
    holds only for adaptive sampling (None otherwise)."""
    spec = {f.name: f.default for f in dataclasses.fields(WorkspaceSpec) if f.default is not dataclasses.MISSING}
    keys = {k.name: k.default for k in WORKSPACE.keys if k.default is not REQUIRED}
    assert set(spec) <= set(keys)
    differ = {name for name in spec if spec[name] != keys[name]}
    assert differ == {"tolerance"} and spec["tolerance"] is None and keys["tolerance"] == 1e-3


def test_an_unread_config_takes_the_table_defaults():
    data = copy.deepcopy(TINY)
    del data["optimizer"]
    cfg = parse_config(yaml.safe_dump(data), "t.yaml")
    assert cfg.optimizer == OptimizerSpec(weights={"dynamic": 1.0, "stiffness": 1.0})
    assert cfg.checks == ChecksSpec()
    assert cfg.workspace.seed == WORKSPACE["seed"].default and cfg.workspace.sampling == WORKSPACE["sampling"].default


# ----------------------------------------------------------------------------- the docs
def test_the_docs_tables_are_generated_from_the_table():
    text = DOCS.read_text(encoding="utf-8")
    for name, section in SECTIONS.items():
        block = f"<!-- keys:{name} -->\n{markdown_table(section)}\n<!-- /keys:{name} -->"
        assert block in text, f"docs/config.md: regenerate with python -m optdesign.config.keydocs --write-docs docs/config.md ({name})"
    assert update_docs(text) == text
    assert main(["--check", str(DOCS)]) == 0


def test_the_docs_generator_replaces_a_stale_table(tmp_path):
    f = tmp_path / "c.md"
    f.write_text("intro\n<!-- keys:checks -->\n| stale |\n<!-- /keys:checks -->\nend\n", encoding="utf-8")
    assert main(["--check", str(f)]) == 1
    assert main(["--write-docs", str(f)]) == 0
    assert f.read_text(encoding="utf-8") == f"intro\n<!-- keys:checks -->\n{markdown_table(CHECKS)}\n<!-- /keys:checks -->\nend\n"
    assert main(["--check", str(f)]) == 0
    for k in CHECKS.keys:
        assert f"| `{k.name}` |" in f.read_text(encoding="utf-8")


# ----------------------------------------------------------------------------- hostile cases from the table
def _place(section: str, key, value):
    """TINY with ``value`` at the key (under the key's ``where``), and the key path."""
    data = copy.deepcopy(TINY)
    if not section:
        data[key.name] = value
        return data, key.name
    block = data.setdefault(section, {})
    for k, v in key.where.items():
        if v is None:
            block.pop(k, None)
        else:
            block[k] = copy.deepcopy(v)
    *parents, last = key.name.split(".")
    for p in parents:
        block = block.setdefault(p, {})
    block[last] = value
    return data, f"{section}.{key.name}"


CASES = [(name, key, v) for name, s in SECTIONS.items() for key in s.keys for v in key.invalid_values()]


def _sec(name):
    return "" if name == "top" else name


@pytest.mark.parametrize("name, key", [(n, k) for n, s in SECTIONS.items() for k in s.keys],
                         ids=[f"{n}.{k.name}" for n, s in SECTIONS.items() for k in s.keys])
def test_every_key_has_a_valid_example_and_invalid_values(name, key):
    """The key's example (or default, or the value TINY has) is read where the hostile cases put their values."""
    example = key.example if key.example is not None else key.default
    if example is None or example is REQUIRED or callable(example):
        block = TINY if name == "top" else TINY.get(name, {})
        example = block.get(key.name)
    data, _ = _place(_sec(name), key, list(example) if isinstance(example, tuple) else example)
    if example is None:            # the key left out
        block = data if name == "top" else data[name]
        del block[key.name]
    parse_config(yaml.safe_dump(data), "ok.yaml")
    assert key.invalid_values(), key.name
    assert key.doc and key.type_text(), key.name


@pytest.mark.parametrize("name, key, value", CASES, ids=[f"{n}.{k.name}={v!r}"[:80] for n, k, v in CASES])
def test_every_declared_invalid_value_is_refused(tmp_path, name, key, value):
    data, keypath = _place(_sec(name), key, value)
    f = tmp_path / "hostile.yaml"
    f.write_text(yaml.safe_dump(data, allow_unicode=True), encoding="utf-8")
    with pytest.raises(ConfigError) as exc:
        parse_config(f.read_text(encoding="utf-8"), str(f))
    assert exc.value.path.startswith(keypath), (exc.value.path, str(exc.value))
    rc, out, err = run_cli_in(tmp_path, ["validate-config", "hostile.yaml"])
    assert rc == 2 and out == "", (rc, out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"optdesign: error: hostile.yaml: {keypath}"), err


def test_the_messages_of_a_range_name_it():
    f = "x.yaml"
    cases = [("optimizer", "population", 3, "expected an integer >= 4, got 3"),
             ("optimizer", "crossover_probability", 1.5, "expected a probability in [0, 1], got 1.5"),
             ("optimizer", "constraint_margin", 0.5, "expected a fraction in [0, 0.5), got 0.5"),
             ("optimizer", "algorithm", "dee", "expected one of de, paper_ga, pymoo_ga, got 'dee' (did you mean 'de'?)"),
             ("checks", "integral_tolerance", 0.9, "expected 0 (no integrals) or a relative tolerance in [1e-10, 0.5], got 0.9")]
    for section, name, value, words in cases:
        data = copy.deepcopy(TINY)
        data.setdefault(section, {})[name] = value
        with pytest.raises(ConfigError) as exc:
            parse_config(yaml.safe_dump(data), f)
        assert str(exc.value) == f"{f}: {section}.{name}: {words}"


# ----------------------------------------------------------------------------- one toolkit, one did-you-mean
def test_one_did_you_mean():
    """difflib is called in one module; every hint has one wording."""
    pkg = ROOT / "optdesign"
    users = sorted(str(p.relative_to(ROOT)) for p in pkg.rglob("*.py") if "difflib" in p.read_text())
    assert users == ["optdesign/checking.py"]
    assert suggest("sed", ["seed", "polish"]) == " (did you mean 'seed'?)"
    assert suggest("SEED", ["seed"]) == " (did you mean 'seed'?)"
    assert suggest("zzz", ["seed"]) == "" and suggest(3, ["seed"]) == ""


def test_the_toolkit_is_a_bottom_module():
    tree = ast.parse((ROOT / "optdesign" / "checking.py").read_text())
    mods = ["." * n.level + (n.module or "") for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    mods += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    assert mods and not [m for m in mods if m.startswith(("optdesign", "."))], mods


def test_configs_and_descriptions_say_it_the_same_way():
    from optdesign.mechanisms import DescriptionError, describe

    gs = yaml.safe_load((ROOT / "configs" / "gough_stewart.yaml").read_text())["mechanism"]
    gs["legz"] = gs.pop("legs")
    with pytest.raises(DescriptionError) as d:
        describe(gs)
    data = copy.deepcopy(TINY)
    data["optimizer"]["seedd"] = 1
    with pytest.raises(ConfigError) as c:
        parse_config(yaml.safe_dump(data), "x.yaml")
    assert d.value.path == "mechanism.legz" and d.value.message.startswith("unknown key (did you mean 'legs'?); expected one of ")
    assert c.value.path == "optimizer.seedd" and c.value.message.startswith("unknown key (did you mean 'seed'?); expected one of ")
    with pytest.raises(CheckError, match=r"^a\.b: expected an integer >= 4, got 3$"):
        Checker().integer(3, "a.b", minimum=4)
    gs = yaml.safe_load((ROOT / "configs" / "gough_stewart.yaml").read_text())["mechanism"]
    gs["pose"]["jacobian"] = "rate"
    with pytest.raises(DescriptionError) as d:
        describe(gs)
    assert d.value.message == "expected one of angular_velocity, rates, got 'rate' (did you mean 'rates'?)"


def test_the_table_is_complete():
    for s in SECTIONS.values():
        names = [k.name for k in s.keys]
        assert len(names) == len(set(names))
        for k in s.keys:
            assert k.type in ("integer", "number", "string", "boolean", "pair", "list", "mapping", "name", "point"), k
    assert Path(DOCS).exists()
