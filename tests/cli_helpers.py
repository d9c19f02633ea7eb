"""Running the ``optdesign`` command in-process from a given folder (tests only)."""
from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path


def run_cli_in(folder: Path, argv: list[str]) -> tuple[int, str, str]:
    """``optdesign *argv`` with ``folder`` as the working directory: (exit status, stdout, stderr)."""
    from optdesign.cli import main

    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    os.chdir(folder)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc = main(argv)
    finally:
        os.chdir(old)
    return rc, out.getvalue(), err.getvalue()


def run_main(capsys, argv: list[str]) -> tuple[int, str, str]:
    """``optdesign *argv`` in-process, its output taken by pytest's ``capsys``: (exit status, stdout, stderr)."""
    from optdesign.cli import main

    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err
