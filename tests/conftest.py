"""Shared fixtures and the suite's tiers.

* a per-session compiled-code cache, so test runs start cold and leave ~/.cache alone;
* the venv's ``bin/`` on ``PATH`` (as an activated venv has it: FMPy's rebuild calls ``cmake``, which the
  ``cmake`` wheel FMPy depends on puts there);
* ``@pytest.mark.needs("tool", ...)``: the test is skipped when a system tool is missing, with a reason
  naming it and ``tools/system-packages`` (:mod:`tests.support.system_tools`);
* ``MANIP_REQUIRE_ALL=1`` (CI): any skip, for a missing tool or otherwise, is a failure;
* one summary at the end of what was skipped and why.

The markers (``slow``, ``cross``, ``browser``, ``valgrind``, ``fmi3``, ``cluster``, ``needs``) are
registered in ``pyproject.toml`` and checked (``--strict-markers``); ``make test-fast`` leaves out
``slow``, ``cross``, ``browser``, ``valgrind`` and ``cluster``.
"""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path

import pytest

from tests.support.system_tools import REQUIRE_ALL, TOOLS, require, skipped_for_tools

_VENV_BIN = str(Path(sys.executable).parent)
if _VENV_BIN not in os.environ.get("PATH", "").split(os.pathsep):
    os.environ["PATH"] = _VENV_BIN + os.pathsep + os.environ.get("PATH", "")


def _require_all() -> bool:
    return os.environ.get(REQUIRE_ALL, "") not in ("", "0")


# A shell starts background jobs with SIGINT ignored, and an ignored signal stays ignored across exec: the
# commands the tests interrupt with Ctrl-C (SIGINT) would then run to the end. A Python handler here is
# reset to the default by exec, so every child process can be interrupted however pytest was started.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session", autouse=True)
def manip_cache_dir(tmp_path_factory):
    """Point ``MANIP_CACHE_DIR`` at a fresh folder for the whole session.

    Under pytest-xdist (``make test-fast``) the workers share one folder beside their own temporary
    folders, so a library is compiled once, not once per worker: entries are written atomically
    (:mod:`model.codegen`), so two workers that build the same one at once both end with a whole file.
    """
    if os.environ.get("PYTEST_XDIST_WORKER"):
        path = tmp_path_factory.getbasetemp().parent / "manip-cache"
        path.mkdir(exist_ok=True)
    else:
        path = tmp_path_factory.mktemp("manip-cache")
    old = os.environ.get("MANIP_CACHE_DIR")
    os.environ["MANIP_CACHE_DIR"] = str(path)
    yield path
    if old is None:
        os.environ.pop("MANIP_CACHE_DIR", None)
    else:
        os.environ["MANIP_CACHE_DIR"] = old


def pytest_runtest_setup(item: pytest.Item) -> None:
    for mark in item.iter_markers("needs"):
        unknown = [name for name in mark.args if name not in TOOLS]
        if unknown or not mark.args:
            pytest.fail(f"@pytest.mark.needs{mark.args}: expected names of {', '.join(TOOLS)}", pytrace=False)
        require(*mark.args)


def _as_failure(report) -> None:
    """Under ``MANIP_REQUIRE_ALL=1``: a skipped report becomes a failure that gives the skip's reason."""
    reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
    report.outcome = "failed"
    report.longrepr = f"{REQUIRE_ALL}=1: no test may be skipped, and this one was: {reason}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    if report.skipped and _require_all() and not hasattr(report, "wasxfail"):
        _as_failure(report)


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    report = outcome.get_result()
    if report.skipped and _require_all():
        _as_failure(report)


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    """One summary of the skips: by missing tool (and what installs it), then any other reason."""
    reports = terminalreporter.stats.get("skipped", [])
    if not reports:
        return
    reasons = []
    for rep in reports:
        text = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
        reasons.append(text.removeprefix("Skipped: "))
    by_tool = skipped_for_tools(reasons)
    others: dict[str, int] = {}
    for reason in reasons:
        if not any(reason.startswith(f"needs {name} ") for name in by_tool):
            others[reason] = others.get(reason, 0) + 1
    tr = terminalreporter
    tr.section("what was skipped and why")
    if by_tool:
        packages = sorted({p for name in by_tool for p in TOOLS[name].packages.split()})
        tr.write_line(f"{sum(by_tool.values())} tests need system tools that are not on PATH "
                      f"(as root, tools/system-packages installs them: {' '.join(packages)}):")
        for name, count in sorted(by_tool.items()):
            tr.write_line(f"  {name:<13} {count:>4} tests  ({TOOLS[name].purpose}; package {TOOLS[name].packages})")
    for reason, count in sorted(others.items()):
        tr.write_line(f"  {count:>4} tests: {reason}")
    tr.write_line(f"set {REQUIRE_ALL}=1 to make any skip a failure (CI does)")
