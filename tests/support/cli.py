"""The ``manip`` command line run in the test process: exit status, stdout and stderr."""

from __future__ import annotations

import contextlib
import io

from workbench.cli import main

__all__ = ["run_cli"]


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """``manip argv`` through :func:`workbench.cli.main`: ``(status, stdout, stderr)``."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(argv)
    return status, out.getvalue(), err.getvalue()
