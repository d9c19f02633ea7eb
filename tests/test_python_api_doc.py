"""docs/python-api.md runs as written: its Python blocks, in order, in one
namespace, from a folder laid out like the repository root (its asserts are
the page's checks)."""
from __future__ import annotations

import pytest

import os
import re
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "python-api.md"


def _blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M)


def test_the_page_has_code():
    blocks = _blocks(PAGE.read_text())
    assert len(blocks) >= 6
    code = "\n".join(blocks)
    for name in ("load_config", "config_from_dict", "od.evaluate", "start_run", "DesignProblem", "minimize"):
        assert name in code, name


@pytest.mark.slow
def test_python_api_page_runs(tmp_path, capsys):
    import optdesign
    import optdesign.evaluate  # noqa: F401 - imported before: `od.evaluate` must stay the function

    assert callable(optdesign.evaluate) and optdesign.evaluate.__name__ == "evaluate"
    (tmp_path / "configs").mkdir()
    shutil.copy(ROOT / "configs" / "p4s_paper.yaml", tmp_path / "configs" / "p4s_paper.yaml")
    old = os.getcwd()
    os.chdir(tmp_path)
    ns: dict = {"__name__": "python_api_page"}
    try:
        for i, block in enumerate(_blocks(PAGE.read_text())):
            exec(compile(block, f"{PAGE.name} block {i + 1}", "exec"), ns)
    finally:
        os.chdir(old)
    out = capsys.readouterr().out
    assert "design_variables" in out           # the ConfigError's key path was printed
    assert (tmp_path / "runs-api").is_dir()    # the run went where the page says
