"""Command lines as a hostile user types them: random argument lists over
every command, usage errors (one line with the hint to --help, exit 2),
and "did you mean" for mistyped commands, options, choices, config keys,
index kinds and mechanisms."""
from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import BATCH_SMALL, CONFIGS, DATA
from hostile_helpers import Cases, run_case, sandbox
from optdesign.cli import build_parser

SETTINGS = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])
SMALL = str(DATA / "p4s_small.yaml")
FIXED = str(CONFIGS / "cpr_rrr.yaml")           # no free variable: `run` stops before running anything


def _options() -> dict[str, list[str]]:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")  # noqa: SLF001
    return {name: [o for o in p._option_string_actions if o.startswith("--")] for name, p in sub.choices.items()}  # noqa: SLF001


OPTIONS = _options()
VALUES = ["1", "0", "-1", "2", "3", "99999999999999999999", "1e3", "nan", "inf", "-inf", "", " ", ",", "1,,2", "x",
          "before", "after", "nope", "local", "dask", "tcp://127.0.0.1:1", "tls://h:1", "::", "a" * 3000,
          "\x00", "\udcff", "caf\u00e9", "../../x", "/dev/null", "/dev/zero", ".", "..", SMALL, FIXED,
          str(BATCH_SMALL), "missing.yaml", "0.57", "-0.05"]
#: commands whose valid calls are quick (the others get arguments that stop them early)
COMMANDS = ["validate-config", "evaluate", "atlas", "ik", "fk", "batch", "summarize", "run", "rnu", "evalute", "",
            "--version", "--help", "-h", "batch --dry-run"]


@st.composite
def command_lines(draw):
    cmd = draw(st.sampled_from(COMMANDS))
    argv = cmd.split() if cmd else []
    name = argv[0] if argv else ""
    opts = OPTIONS.get(name, []) + ["--sed", "--seeds=", "--", "-x", "--jobs=-3", "--out=/dev/null"]
    for _ in range(draw(st.integers(0, 5))):
        what = draw(st.sampled_from(["option", "option", "value", "typo"]))
        if what == "option" and opts:
            argv.append(draw(st.sampled_from(opts)))
            if draw(st.booleans()):
                argv.append(draw(st.sampled_from(VALUES)))
        elif what == "typo" and opts:
            o = draw(st.sampled_from(opts))
            argv.append(o[:-1] if len(o) > 3 else o + "x")
        else:
            argv.append(draw(st.sampled_from(VALUES) | st.text(max_size=8)))
    if name == "run":          # never a run that runs: a config without free variables, or --resume of nothing
        argv += draw(st.sampled_from([[FIXED], ["--resume", "no-such-folder"], [FIXED, "--resume", "x"]]))
    if name == "batch" and "--dry-run" not in argv:
        argv.append("--dry-run")
    return argv


@pytest.mark.slow
def test_random_command_lines():
    cases = Cases()
    status = {0: 0, 1: 0, 2: 0}

    @settings(max_examples=300, **SETTINGS)
    @given(argv=command_lines())
    def check(argv):
        cases()
        if argv and argv[0] == "batch" and any(a == "--backend" for a in argv):
            argv = [a for a in argv if a != "--backend"]        # no connection attempts here
        with sandbox() as (work, outside):
            rc, _, err = run_case(work, outside, argv, f"optdesign {argv!r}")
            status[rc] += 1
            if argv[:1] == ["run"]:
                assert not (work / "runs").exists()

    check()
    assert cases.n >= 300
    assert status[2] > 100 and status[0] > 10, status


USAGE = [   # (arguments, words of the one line)
    (["rnu"], "invalid choice 'rnu' (did you mean 'run'?)"),
    (["evalute", SMALL], "(did you mean 'evaluate'?)"),
    (["valdate-config", SMALL], "(did you mean 'validate-config'?)"),
    (["sumarize", "."], "(did you mean 'summarize'?)"),
    (["run", SMALL, "--sed", "3"], "(did you mean '--seed'?)"),
    (["batch", SMALL, "--dry-rn"], "(did you mean '--dry-run'?)"),
    (["batch", SMALL, "--backend", "dusk"], "invalid choice 'dusk' (did you mean 'dask'?)"),
    (["batch", SMALL, "--seeds", "abc"], "argument --seeds: expected an integer of ASCII digits, got 'abc'"),
    (["batch", SMALL, "--seed-list", ","], "--seed-list: expected at least one seed"),
    (["batch", SMALL, "--seed-list", " "], "--seed-list: expected at least one seed"),
    (["batch", SMALL, "--seed-list", "1,,2"], "--seed-list: an empty entry"),
    (["batch", SMALL, "--seed-list", "1,-2"], "--seed-list: expected seeds in [0, 2^32)"),
    (["batch", SMALL, "--seed-list", "4294967296"], "--seed-list: expected seeds in [0, 2^32)"),
    (["batch", SMALL, "--timeout", "nan"], "argument --timeout: expected a finite number of ASCII digits, got 'nan'"),
    (["batch", SMALL, "--retries", "-1"], "--retries: expected a non-negative integer"),
    (["atlas"], "atlas: the following arguments are required: config"),
    (["atlas", SMALL, "--resolution", "1"], "--resolution: expected an integer in [2, 2000]"),
    ([], "expected a command"),
    (["ik", SMALL, "a"], "argument POSE: expected a number of ASCII digits, got 'a'"),
    (["run", SMALL, "--seed", "-1"], "--seed: expected an integer in [0, 2^32)"),
    (["run", SMALL, "--jobs", "0"], "--jobs: expected a positive integer"),
    (["run", SMALL, "--name", "../x"], "--name: character '/' is not allowed"),
    (["run", SMALL, "--resume", "x"], "give a CONFIG or --resume RUN_DIR, not both"),
    (["evaluate", SMALL, "--design", "aftr"], "no design named 'aftr' (did you mean 'after'?)"),
]


@pytest.mark.parametrize("argv, words", USAGE, ids=[" ".join(u[0])[:40] or "nothing" for u in USAGE])
def test_usage_errors_are_one_line(argv, words):
    with sandbox() as (work, outside):
        _, _, err = run_case(work, outside, argv, " ".join(argv), allowed=(2,))
        assert words in err, err
        if "argument" in words or "required" in words or "did you mean '-" in words or "invalid choice" in words:
            assert err.rstrip().endswith("--help')"), err


CONFIG_TYPOS = [   # (old text, new text, words)
    ("mechanism: p4s", "mechansim: p4s", "mechansim: unknown key (did you mean 'mechanism'?)"),
    ("mechanism: p4s", "mechanism: p4z", "unknown mechanism 'p4z' (did you mean 'p4s'?)"),
    ("dynamic: {}", "dynamic: {kind: dynamc}", "unknown index 'dynamc' (did you mean 'dynamic'?)"),
    ("workspace: {type: box", "workspace: {tpye: box", "workspace.tpye: unknown key (did you mean 'type'?)"),
    ("sampling: grid", "samplng: grid", "(did you mean 'sampling'?)"),
    ("sampling: grid", "sampling: gird", "(did you mean 'grid'?)"),
    ("seed: 3", "sed: 3", "optimizer.sed: unknown key (did you mean 'seed'?)"),
    ("elites: 2", "elite: 2", "(did you mean 'elites'?)"),
    ("r_a: {value: 0.25, bounds: [0.21, 0.29]}", "r_a: {value: 0.25, bonds: [0.21, 0.29]}", "(did you mean 'bounds'?)"),
    ("dynamic: {}", "dynamic: {options: {k: 1}}", "index 'dynamic' takes no options"),
    ("stiffness: {}", "stiffness: {options: {kk: 1}}", "options.kk: unknown key (did you mean 'k'?)"),
    ("isotropy: {}", "isotropy: {convention: frobenuis}", "(did you mean 'frobenius'?)"),
]


@pytest.mark.parametrize("old, new, words", CONFIG_TYPOS, ids=[c[1][:30] for c in CONFIG_TYPOS])
def test_did_you_mean_in_configs(old, new, words, edited_copy):
    from conftest import edited_text

    with sandbox() as (work, outside):
        (work / "c.yaml").write_text(edited_text((DATA / "p4s_small.yaml").read_text(), {old: new}))
        _, _, err = run_case(work, outside, ["validate-config", "c.yaml"], new, file="c.yaml", allowed=(2,))
        assert words in err, err


@pytest.mark.slow
def test_names_that_are_not_utf8_on_a_strict_terminal(tmp_path):
    """A file name with a byte that is not UTF-8 (a lone surrogate in Python),
    printed back to a terminal whose encoding is strict: escaped, no traceback."""
    import os
    import shutil
    import subprocess
    import sys

    from conftest import ROOT

    name, bad_name = os.fsdecode(b"\xff.yaml"), os.fsdecode(b"x\xff")
    shutil.copy(SMALL, tmp_path / name)
    env = {**os.environ, "PYTHONIOENCODING": "utf-8:strict", "PYTHONPATH": str(ROOT)}
    for argv, status in ((["validate-config", name], 0), (["validate-config", os.fsdecode(b"\xfe.yaml")], 2),
                         (["run", name, f"--name={bad_name}"], 2)):
        r = subprocess.run([sys.executable, "-m", "optdesign.cli", *argv], cwd=tmp_path, env=env,
                           capture_output=True, timeout=120)
        assert r.returncode == status, r.stderr
        assert b"Traceback" not in r.stderr and b"\\udc" in (r.stdout + r.stderr)
        if status == 2:
            assert r.stderr.count(b"\n") == 1
