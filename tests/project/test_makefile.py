"""``make clean`` removes everything the build, the tests, the demo and the tools write into the tree (the
patterns of .gitignore, the one list of them) and nothing else; ``make distclean`` the venv too."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="make is one of the three things a fresh "
                                "machine needs (README: Fresh clone)")


def _ignored() -> list[str]:
    lines = (REPO / ".gitignore").read_text().splitlines()
    return [line.strip() for line in lines if line.strip() and not line.startswith("#")]


def _make_outputs(root: Path) -> list[Path]:
    """One file or folder for each .gitignore pattern, at the top and (for a bare name) in a package too."""
    made = []
    for pattern in _ignored():
        name = pattern.strip("/").replace("*", "x")
        for where in ([root] if "/" in pattern.rstrip("/") else [root, root / "model" / "dynamics"]):  # "/x": top
            path = where / name
            if pattern.endswith("/"):
                (path / "inner").mkdir(parents=True, exist_ok=True)
                (path / "inner" / "file").write_text("x")
            else:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text("x")
            made.append(path)
    return made


def test_make_clean_removes_every_ignored_pattern_but_the_venv(tmp_path):
    shutil.copy(REPO / "Makefile", tmp_path / "Makefile")
    kept = [tmp_path / "model" / "robot.py", tmp_path / "README.md", tmp_path / "tests" / "data" / "arm.toml"]
    for path in kept:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("kept")
    made = _make_outputs(tmp_path)
    assert len(made) >= 12  # negative control: the patterns were read and made
    done = subprocess.run(["make", "clean"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    left = [p.relative_to(tmp_path).as_posix() for p in made if p.exists()]
    assert left == [".venv"], f"make clean left {left}"
    assert all(p.read_text() == "kept" for p in kept)  # the sources stay
    done = subprocess.run(["make", "distclean"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and not (tmp_path / ".venv").exists(), done.stderr
