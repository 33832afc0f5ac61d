"""The suite on a machine without the optional system tools: a test that needs one is skipped, naming it and
tools/system-packages, the run ends with one summary of the skips, MANIP_REQUIRE_ALL=1 turns any skip into a
failure, and an unregistered marker is an error (--strict-markers). Run on a small test file with PATH emptied."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from tests.support.system_tools import REQUIRE_ALL, TOOLS

REPO = Path(__file__).resolve().parents[2]
SAMPLE = '''
import pytest

@pytest.mark.needs("valgrind")
def test_needs_valgrind():
    pass

def test_needs_nothing():
    pass
'''


def _run(tmp_path: Path, text: str, **env: str) -> subprocess.CompletedProcess:
    path = tmp_path / "test_sample.py"
    path.write_text(text)
    environ = {k: v for k, v in os.environ.items() if k != REQUIRE_ALL}
    environ.update(PATH=str(tmp_path / "empty-bin"), **env)  # no tool on PATH
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "tests.conftest",
                           "-c", str(REPO / "pyproject.toml"), "--rootdir", str(REPO), str(path)],
                          cwd=REPO, capture_output=True, text=True, env=environ, timeout=300)


def test_a_missing_tool_is_a_skip_naming_it_and_the_run_ends_with_a_summary(tmp_path):
    done = _run(tmp_path, SAMPLE)
    assert done.returncode == 0, done.stdout + done.stderr
    out = done.stdout
    assert re.search(r"1 passed, 1 skipped", out), out
    summary = out[out.index("what was skipped and why"):]
    assert "1 tests need system tools that are not on PATH (as root, tools/system-packages installs them" in summary
    assert re.search(r"valgrind +1 tests +\(the FMU's memory checks; package valgrind\)", summary), summary


def test_with_require_all_a_skip_is_a_failure(tmp_path):
    done = _run(tmp_path, SAMPLE + "\ndef test_skips_itself():\n    pytest.skip('for another reason')\n",
                **{REQUIRE_ALL: "1"})
    assert done.returncode == 1, done.stdout
    # the missing tool fails in setup (an error), the test's own skip in its call (a failure)
    assert re.search(r"1 failed, 1 passed, 1 error", done.stdout), done.stdout
    assert f"{REQUIRE_ALL}=1: needs valgrind" in done.stdout
    assert f"{REQUIRE_ALL}=1: no test may be skipped, and this one was: Skipped: for another reason" in done.stdout


def test_an_unregistered_marker_is_an_error(tmp_path):
    done = _run(tmp_path, "import pytest\n\n@pytest.mark.slowish\ndef test_x():\n    pass\n")
    assert done.returncode != 0 and "'slowish' not found in `markers`" in done.stdout + done.stderr


def test_tools_system_packages_installs_every_package_of_the_tools():
    text = (REPO / "tools" / "system-packages").read_text()
    listed = set(re.search(r"^packages=\((.*)\)$", text, re.M).group(1).split())
    wanted = {p for tool in TOOLS.values() for p in tool.packages.split()}
    assert len(wanted) >= 9  # negative control: the table is read
    assert wanted <= listed, sorted(wanted - listed)
