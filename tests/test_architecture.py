"""The import rules of the flow, checked from the source (ast), so they stay true.

Data goes one way: config -> mechanisms -> workspace -> indices -> evaluate ->
optimize -> runner -> commands (CLI), with the reports beside the run:

    optimize   the problem and its runs: design vectors and objective values;
               writes results.json, the stages' CSV files and checkpoints into
               a run folder (optdesign.runs, a plain helper at the bottom)
    report     md, csv, png, html, the batch summary and the atlases: reads
               the run folder's plain data (results.json, CSV, config.yaml);
               above evaluate and units, never importing optimize or studies
    runner     start and resume a run with its reports: hands report's writers
               to optimize's pipeline as plain callables (optimize.outputs)
    batch      many runs through the runner, their rows through report.summary
    studies    the paper studies; imported by the commands only (and by tests,
               benchmarks and docs), which hand a study's note to the run
    commands   the CLI on top

A mechanism knows geometry and physics, not the optimizer; an index knows
matrices, not YAML; the optimizer knows design vectors and objective values,
not mechanisms, reports or studies; nothing imports the CLI.

The config stops at the command layer (the commands and the runner): the
layers below are handed the plain pieces they read (CONFIG_READERS below).
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "optdesign"

#: the modules every layer may use: plain helpers that import no other part of the package
BOTTOM = {"optdesign.checking", "optdesign.formulas", "optdesign.linalg", "optdesign.intervals", "optdesign.io", "optdesign.datafile", "optdesign.names", "optdesign.fast", "optdesign.fast._jit", "optdesign.tables",
          "optdesign.symbolic", "optdesign.screws"}


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _tree(path: Path) -> ast.Module:
    """The parsed source of a module of the package (parsed once per test
    process: the tests here walk every module many times)."""
    return _TREES.get(path) or _TREES.setdefault(path, ast.parse(path.read_text(), str(path)))


_TREES: dict = {}


def _imports(path: Path) -> set[str]:
    """Every optdesign module a file imports (relative imports resolved; for
    ``from X import y`` both X and X.y, since y may be a module)."""
    name = _module_name(path)
    pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out: set[str] = set()
    for node in ast.walk(_tree(path)):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("optdesign"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[:len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("optdesign"):
                continue
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)
    return out


def _modules():
    return sorted((_module_name(p), p) for p in PKG.rglob("*.py"))


MODULES = _modules()


def _under(mod: str, prefix: str) -> bool:
    return mod == prefix or mod.startswith(prefix + ".")


def _violations(allowed_prefixes, importer_prefix):
    bad = []
    for name, path in MODULES:
        if not _under(name, importer_prefix):
            continue
        for imp in _imports(path):
            if any(_under(imp, b) for b in BOTTOM) or _under(imp, importer_prefix) or imp == "optdesign":
                continue
            if not any(_under(imp, a) for a in allowed_prefixes):
                bad.append(f"{name} imports {imp}")
    return bad


def test_the_checker_sees_imports():
    """The rule checker itself: it finds relative and absolute imports."""
    imps = _imports(PKG / "evaluate.py")
    assert "optdesign.config" in imps and "optdesign.mechanisms" in imps and "optdesign.workspace" in imps
    imps = _imports(PKG / "mechanisms" / "described" / "compiled.py")
    assert "optdesign.formulas" in imps and "optdesign.engine.layout" in imps and "optdesign.mechanisms.base" in imps
    assert len(MODULES) > 40


def test_nothing_imports_the_cli():
    bad = []
    for name, path in MODULES:
        if name in ("optdesign.cli", "optdesign.__main__") or _under(name, "optdesign.commands"):
            continue   # the entry points (``optdesign`` and ``python -m optdesign``) are the top
        for imp in _imports(path):
            if _under(imp, "optdesign.cli") or _under(imp, "optdesign.commands"):
                bad.append(f"{name} imports {imp}")
    assert not bad, bad
    # and the commands never import the CLI module (no cycle)
    for name, path in MODULES:
        if _under(name, "optdesign.commands"):
            assert not any(_under(i, "optdesign.cli") for i in _imports(path)), name


@pytest.mark.parametrize("layer, allowed", [
    # the one compiled engine: plain arrays in, statistics out; it knows no mechanism
    ("optdesign.engine", ()),
    # the bottom of the flow: a mechanism knows geometry and physics only (and packs itself for the engine)
    ("optdesign.mechanisms", ("optdesign.engine",)),
    # adaptive cubature of the mean over W: plain numerics on a region spec, below the workspace that samples it
    ("optdesign.cubature", ()),
    ("optdesign.workspace", ("optdesign.cubature",)),
    ("optdesign.indices", ()),
    # the worst case of a local constraint over the continuous W: a mechanism's matrices and indices over W
    ("optdesign.worstcase", ("optdesign.mechanisms", "optdesign.workspace", "optdesign.indices")),
    # what a user sees of a config's quantities: a plain table (from the mechanisms' unit declarations)
    ("optdesign.units", ("optdesign.mechanisms",)),
    # config validates against the mechanisms' declarations, the workspace spec and the index kinds, and
    # makes its display table (units: the design-variable table lives there, as the workspace spec in workspace)
    ("optdesign.config", ("optdesign.mechanisms", "optdesign.workspace", "optdesign.indices", "optdesign.units")),
    # derivatives of a local index from its matrices (plain numpy)
    ("optdesign.local_derivatives", ()),
    # statistics over W of a population's local indices (compiled path or numpy), no config
    ("optdesign.statistics", ("optdesign.mechanisms", "optdesign.workspace", "optdesign.cubature", "optdesign.indices")),
    # evaluate: the one place that builds mechanisms from a config
    ("optdesign.evaluate", ("optdesign.config", "optdesign.mechanisms", "optdesign.workspace", "optdesign.cubature",
                            "optdesign.indices", "optdesign.worstcase", "optdesign.statistics")),
    # derivatives of the evaluation (the evaluate layer: the mechanisms' CasADi models through the registry)
    ("optdesign.gradients", ("optdesign.evaluate", "optdesign.mechanisms", "optdesign.workspace",
                             "optdesign.indices", "optdesign.worstcase", "optdesign.local_derivatives")),
    # certificates: a design's mechanism (its enclosure) over the workspace's region
    ("optdesign.certify", ("optdesign.mechanisms", "optdesign.workspace")),
    # the optimizer knows design vectors and objective values (handed plain pieces, no config); the run
    # folder is where it writes
    ("optdesign.optimize", ("optdesign.evaluate", "optdesign.gradients", "optdesign.workspace",
                            "optdesign.certify", "optdesign.runs", "optdesign.units", "optdesign.process")),
    ("optdesign.runs", ()),
    # the settings of optdesign's own processes (the command's, a stage worker's): the standard library only
    ("optdesign.process", ()),
    # the reports read a run folder's plain data (and evaluate designs for the atlases and the pictures)
    ("optdesign.report", ("optdesign.config", "optdesign.evaluate", "optdesign.workspace", "optdesign.runs",
                          "optdesign.units")),
    # a run with its reports: where the config stops; the optimizer's pipeline is handed its plain pieces
    # (the evaluator, the units ...) and the report's writers
    ("optdesign.runner", ("optdesign.config", "optdesign.evaluate", "optdesign.optimize", "optdesign.report",
                          "optdesign.runs", "optdesign.units")),
    # many runs through the runner, their rows through the report's batch summary
    ("optdesign.batch", ("optdesign.config", "optdesign.optimize", "optdesign.report", "optdesign.runner",
                         "optdesign.runs")),
    # paper studies sit beside the optimizer: they evaluate designs of a config
    ("optdesign.studies", ("optdesign.mechanisms", "optdesign.indices", "optdesign.config", "optdesign.evaluate",
                           "optdesign.workspace")),
])
def test_layers_import_only_what_lies_below(layer, allowed):
    assert not _violations(allowed, layer), _violations(allowed, layer)


def test_no_config_below_evaluate():
    for layer in ("optdesign.mechanisms", "optdesign.workspace", "optdesign.cubature", "optdesign.indices", "optdesign.worstcase", "optdesign.statistics", "optdesign.linalg",
                  "optdesign.fast", "optdesign.engine"):
        for name, path in MODULES:
            if _under(name, layer):
                assert not any(_under(i, "optdesign.config") for i in _imports(path)), name


#: the modules that may read a Config (the config package's Config, its loaders): the config itself, the top
#: (the CLI, the commands, the runner, which makes a run's plain pieces of it, batches, and the paper studies the
#: commands name), evaluate.py's documented adapters (Evaluator.from_config, DesignModel.from_config,
#: evaluate(config, ...), build(config, ...)) and, in the reports, the readers of a run folder's config.yaml,
#: which turn it into plain pieces at once (report/folders.py for the commands, report/summary.py for a batch's
#: keys and units, report/html/rundata.py for the pages)
CONFIG_READERS = ("optdesign.config", "optdesign.cli", "optdesign.__main__", "optdesign.commands", "optdesign.runner",
                  "optdesign.batch", "optdesign.studies", "optdesign.evaluate", "optdesign.report.folders",
                  "optdesign.report.summary", "optdesign.report.html.rundata")


def _config_names(path: Path) -> set[str]:
    """How a module could hold a config without importing it: a parameter
    named ``cfg`` or ``config``, a variable ``cfg``, an attribute ``.cfg``
    (a variable ``config`` may be another library's, numba's)."""
    out = set()
    for node in ast.walk(_tree(path)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            out.update(f"parameter {x.arg}" for x in a.posonlyargs + a.args + a.kwonlyargs + [a.vararg, a.kwarg]
                       if x is not None and x.arg in ("cfg", "config"))
        elif isinstance(node, ast.Name) and node.id == "cfg":
            out.add("name cfg")
        elif isinstance(node, ast.Attribute) and node.attr == "cfg":
            out.add("attribute .cfg")
    return out


def test_the_config_stops_at_the_command_layer():
    """Below the commands and the runner the layers are handed the plain pieces
    they read (the Evaluator, the optimizer's and the checks' sections, the
    Units table, a DesignModel, the workspace spec ...), never the config: no
    module but the readers above imports optdesign.config, and none holds a
    config under another import (a parameter or variable cfg/config, an
    attribute .cfg)."""
    bad = []
    for name, path in MODULES:
        if any(_under(name, r) for r in CONFIG_READERS):
            continue
        bad += [f"{name} imports {i}" for i in _imports(path) if _under(i, "optdesign.config")]
        bad += [f"{name}: {what}" for what in sorted(_config_names(path))]
    assert not bad, bad
    # the checker sees a config handed along without its import
    assert "parameter cfg" in _config_names(PKG / "commands" / "run.py")


def test_the_evaluators_hold_no_config():
    """evaluate.py's Evaluator and DesignModel take a config in from_config only
    (the documented entry point); their other methods read their plain fields."""
    tree = ast.parse((PKG / "evaluate.py").read_text())
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
    for cls in ("Evaluator", "DesignModel"):
        for fn in classes[cls].body:
            if isinstance(fn, ast.FunctionDef) and fn.name != "from_config":
                names = {n.id for n in ast.walk(fn) if isinstance(n, ast.Name)} | \
                        {a.arg for a in ast.walk(fn) if isinstance(a, ast.arg)}
                assert not names & {"config", "cfg", "Config"}, f"{cls}.{fn.name}"


def test_optimize_does_not_import_mechanisms():
    for name, path in MODULES:
        if _under(name, "optdesign.optimize"):
            assert not any(_under(i, "optdesign.mechanisms") for i in _imports(path)), name


@pytest.mark.parametrize("other", ["optdesign.report", "optdesign.studies", "optdesign.runner", "optdesign.batch"])
def test_optimize_knows_vectors_only(other):
    """No report, no study, nothing that runs it: the layers above hand it plain callables."""
    bad = [name for name, path in MODULES
           if _under(name, "optdesign.optimize") and any(_under(i, other) for i in _imports(path))]
    assert not bad, bad


@pytest.mark.parametrize("other", ["optdesign.optimize", "optdesign.studies", "optdesign.runner", "optdesign.batch"])
def test_the_reports_read_plain_data(other):
    """The reports read results.json and the CSV files, not the optimizer's types."""
    bad = [name for name, path in MODULES
           if _under(name, "optdesign.report") and any(_under(i, other) for i in _imports(path))]
    assert not bad, bad


def test_studies_are_imported_by_the_commands_only():
    """A paper study is named by the command that runs it (tests, benchmarks and docs may use it too)."""
    bad = [f"{name} imports {i}" for name, path in MODULES
           if not _under(name, "optdesign.commands") and not _under(name, "optdesign.studies")
           for i in _imports(path) if _under(i, "optdesign.studies")]
    assert not bad, bad
    # the rule sees the command that does
    assert any(_under(i, "optdesign.studies") for i in _imports(PKG / "commands" / "run.py"))


def test_a_mechanisms_own_code_is_not_named_outside_it():
    """A mechanism's modules (its compiled path above all) are imported only
    inside its own package; elsewhere mechanisms are reached through the
    registry (optdesign.mechanisms) and the base interface (base, params, state).  The paper studies
    (optdesign.studies) are the one place that names a mechanism on purpose.  The
    description machinery (optdesign.mechanisms.described) is shared: a
    hand-written mechanism may run on the engine as its own description (the 3-P(4S))."""
    own = {}
    for name, _ in MODULES:
        parts = name.split(".")
        if len(parts) >= 3 and parts[1] == "mechanisms" and parts[2] not in ("base", "params", "state", "described"):
            own[name] = "optdesign.mechanisms." + parts[2].removesuffix("_fk")
    bad = []
    for name, path in MODULES:
        if _under(name, "optdesign.studies"):
            continue
        for imp in _imports(path):
            home = own.get(imp)
            if home is not None and not _under(name, home) and not name.startswith(home + "_"):
                bad.append(f"{name} imports {imp}")
    assert not bad, bad
def test_modules_fit_in_one_sitting():
    """No module above ~400 lines except compiled kernels."""
    long = []
    for name, path in MODULES:
        n = len(path.read_text().splitlines())
        if n > 420 and not name.endswith("kernels"):
            long.append((name, n))
    assert not long, long
