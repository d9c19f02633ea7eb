import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"


@pytest.fixture
def paper_config():
    from optdesign.config import load_config

    return load_config(CONFIGS / "p4s_paper.yaml")
