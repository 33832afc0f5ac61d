"""What a user installs: the wheel carries every file the code opens at run time, builds without a warning,
and the source distribution carries the licence and every page the README links to; no build output is tracked.

The files the code opens are found from the code itself: every ``Path(__file__)...`` expression in the
packages (``.parent``, ``.parents[k]``, ``/ "name"``) names a folder or a file; every tracked file below it must
be in the wheel. An expression of another form fails the test, so that a new way of finding data is looked at.
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
#: The installed packages (``[tool.setuptools] packages`` holds them and their data folders).
TOP_LEVEL = ("model", "control_design", "closed_loop", "fmu", "workbench")
#: Suffixes of build output, never tracked.
BUILD_OUTPUT = (".whl", ".so", ".o", ".a", ".pyc", ".dll", ".dylib", ".fmu", ".egg", ".exe", ".tar.gz")


def _tracked(*paths: str) -> list[str]:
    return subprocess.run(["git", "ls-files", "--", *paths], cwd=REPO, capture_output=True, text=True,
                          check=True).stdout.splitlines()


def _readme_relative_links() -> set[str]:
    text = (REPO / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#\s]+)", text)
    return {t for t in targets if not re.match(r"[a-z]+://", t)}


def test_readme_links_point_to_files_of_the_repository():
    links = _readme_relative_links()
    assert links, "the README links no page: this test would check nothing"
    missing = sorted(t for t in links if not (REPO / t).is_file())
    assert not missing, f"README links to missing files: {missing}"


def _clean_copy(dest: Path) -> Path:
    """The files of a fresh clone (git's tracked and new, unignored files): no egg-info of earlier builds."""
    listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=REPO,
                            capture_output=True, text=True, check=True).stdout.splitlines()
    for name in listed:
        src = REPO / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)
    return dest


def _build(kind: str, src: Path, out: Path) -> tuple[Path, str]:
    """Run setuptools' PEP 517 backend (``build_wheel`` or ``build_sdist``) in ``src``: the archive and the output.

    Warnings are shown every time (``-W always``); byte-compiling stays on, as in pip's build, so that its
    "disabled" note does not read as a warning.
    """
    code = f"import sys, setuptools.build_meta as b; print(b.{kind}(sys.argv[1]))"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    done = subprocess.run([sys.executable, "-W", "always", "-c", code, str(out)], cwd=src, capture_output=True,
                          text=True, env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    return out / done.stdout.strip().splitlines()[-1], done.stdout + done.stderr


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> tuple[Path, str]:
    """The wheel built from a clean copy of the tree, and everything the build printed."""
    tmp = tmp_path_factory.mktemp("wheel")
    return _build("build_wheel", _clean_copy(tmp / "src"), tmp)


# ------------------------------------------------------------------ the files the code opens
def _file_anchored(py: Path) -> list[tuple[int, Path]]:
    """(line, path) of every ``Path(__file__)`` expression of the module ``py``, evaluated as far as it goes."""
    tree = ast.parse(py.read_text(), str(py))
    parent = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "Path"
                and [getattr(a, "id", None) for a in node.args] == ["__file__"]):
            continue
        path, cur = py.resolve(), node
        while True:
            up = parent.get(cur)
            if isinstance(up, ast.Attribute) and up.attr == "resolve" and isinstance(parent.get(up), ast.Call):
                cur = parent[up]
            elif isinstance(up, ast.Attribute) and up.attr == "parent":
                path, cur = path.parent, up
            elif (isinstance(up, ast.Attribute) and up.attr == "parents" and isinstance(parent.get(up), ast.Subscript)
                  and isinstance(parent[up].slice, ast.Constant)):
                path, cur = path.parents[parent[up].slice.value], parent[up]
            elif (isinstance(up, ast.BinOp) and isinstance(up.op, ast.Div) and up.left is cur
                  and isinstance(up.right, ast.Constant) and isinstance(up.right.value, str)):
                path, cur = path / up.right.value, up
            else:
                break
        found.append((node.lineno, path))
    return found


def runtime_files() -> dict[str, str]:
    """Every tracked file below a ``Path(__file__)`` anchor of the packages -> the module and line naming it."""
    files: dict[str, str] = {}
    for name in _tracked(*TOP_LEVEL):
        if not name.endswith(".py"):
            continue
        for line, path in _file_anchored(REPO / name):
            assert path.exists(), f"{name}:{line}: Path(__file__) names {path}, which does not exist"
            rel = path.relative_to(REPO).as_posix()
            below = [rel] if path.is_file() else _tracked(rel)
            assert below, f"{name}:{line}: {rel} holds no tracked file"
            for f in below:
                files.setdefault(f, f"{name}:{line}")
    return files


def test_the_runtime_file_finder_finds_the_headers_templates_sources_and_robots():
    """Negative control: the files main's wheel lacked (the FMI headers) are among those the code opens."""
    files = runtime_files()
    for wanted in ("fmu/c/fmi2/fmi2Functions.h", "fmu/c/fmi3/fmi3Functions.h", "fmu/c/instance.c",
                   "fmu/templates/modelDescription3.xml", "model/dynamics/c/casadi_abi.h", "closed_loop/c/kernel.c",
                   "model/robots/panda.urdf", "model/robots/scara.toml"):
        assert wanted in files, wanted


def test_the_wheel_carries_every_file_the_code_opens(wheel):
    archive, _ = wheel
    with zipfile.ZipFile(archive) as zf:
        names = set(zf.namelist())
    missing = {f: where for f, where in runtime_files().items() if f not in names}
    assert not missing, f"opened at run time but not in the wheel (file: where the code names it): {missing}"


def test_the_wheel_carries_every_module_of_the_packages(wheel):
    """Every tracked Python module below the top-level packages is in the wheel: a new subpackage that
    pyproject.toml's explicit package list misses (model.retime was) would import in the checkout only."""
    archive, _ = wheel
    with zipfile.ZipFile(archive) as zf:
        names = set(zf.namelist())
    modules = [f for f in _tracked(*TOP_LEVEL) if f.endswith(".py")]
    assert "model/retime/solver.py" in modules  # negative control: subpackages are walked
    missing = sorted(f for f in modules if f not in names)
    assert not missing, f"modules not in the wheel (list their package in pyproject.toml): {missing}"


def test_the_wheel_builds_without_a_warning(wheel):
    """No deprecated licence table, no data folder "absent from the packages configuration", nothing else."""
    _, output = wheel
    warned = [line for line in output.splitlines() if "warn" in line.lower()]
    assert not warned, "\n".join(warned[:20])
    assert "adding license file 'LICENSE'" in output  # negative control: the build's output is what is read


def test_the_wheel_metadata_has_the_spdx_licence_and_the_one_version(wheel):
    from model.version import __version__

    archive, _ = wheel
    with zipfile.ZipFile(archive) as zf:
        meta = next(n for n in zf.namelist() if n.endswith(".dist-info/METADATA"))
        text = zf.read(meta).decode()
    assert "\nLicense-Expression: BSD-3-Clause\n" in text
    assert f"\nVersion: {__version__}\n" in text


# ------------------------------------------------------------------ the source distribution
def test_sdist_carries_the_licence_and_every_page_the_readme_links(tmp_path):
    archive, _ = _build("build_sdist", _clean_copy(tmp_path / "src"), tmp_path)
    with tarfile.open(archive) as tar:
        names = {name.split("/", 1)[1] for name in tar.getnames() if "/" in name}
    wanted = {"LICENSE", "README.md", *_readme_relative_links()}
    assert not wanted - names, f"not in the sdist: {sorted(wanted - names)}"
    assert "BSD 3-Clause" in (REPO / "LICENSE").read_text()


# ------------------------------------------------------------------ hygiene
def test_no_build_output_is_tracked():
    tracked = _tracked()
    assert "pyproject.toml" in tracked  # negative control: the listing is read
    built = [name for name in tracked if name.endswith(BUILD_OUTPUT) or ".egg-info/" in name
             or "__pycache__/" in name]
    assert not built, f"build output tracked by git: {built}"
