"""One version, written once (model/version.py): the build reads it, ``manip --version`` and the FMU's
``generationTool`` print it (tests/fmu/test_export.py), and no module looks it up another way."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib

from model.version import __version__

REPO = Path(__file__).resolve().parents[2]


def test_the_build_reads_the_version_from_model_version():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "model.version.__version__"}
    assert re.fullmatch(r"\d+\.\d+\.\d+", __version__)


def test_manip_version_prints_it():
    done = subprocess.run([sys.executable, "-m", "workbench.cli", "--version"], cwd=REPO, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0 and done.stdout == f"manip {__version__}\n"


def test_no_module_looks_the_version_up_elsewhere():
    """Neither the installed metadata (absent in a source tree, stale in an old editable install) nor a copy."""
    sources = [p for top in ("model", "control_design", "closed_loop", "fmu", "workbench", "benchmarks")
               for p in (REPO / top).rglob("*.py") if p.name != "version.py"]
    assert len(sources) > 50  # negative control: the packages are read
    looked_up = re.compile(r"""version\(\s*["']manipulator-workbench""")  # importlib.metadata.version(...)
    found = [f"{p.relative_to(REPO)}" for p in sources
             if looked_up.search(p.read_text()) or f'"{__version__}"' in p.read_text()]
    assert not found, found
    assert looked_up.search('metadata.version("manipulator-workbench")')  # negative control: the pattern matches
