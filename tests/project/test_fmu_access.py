"""FMU access, read from the source: outside fmu/, nobody opens an FMU archive or builds an instance by hand.

Every user of an FMU goes through :func:`fmu.opened.open_fmu` (the archive checked before anything is parsed)
and :class:`fmu.instance.Instance` (every FMI call through one choke point). Every module of
:data:`SCOPE` is read with ``ast`` and fails, naming file and line, on

* an import of FMPy's instance classes, ``read_model_description`` or ``extract`` from ``fmpy`` or one of its
  submodules (``from fmpy.fmi2 import FMU2Slave``, ``import fmpy`` then ``fmpy.extract``), and
* a call of ``zipfile.ZipFile`` (any spelling: ``ZipFile`` imported by name, ``zipfile`` under an alias):
  the test cannot tell an FMU from another zip archive, so every call is one until :data:`ZIP_ALLOWED`
  says which non-FMU archive (or hostile FMU sample) it opens.

An entry of an allow-list is a file (and for FMPy the name) with the one-line reason it must stay.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
#: The folders and files read: the whole project but tests/fmu/ and tests/support/ (the FMU layer's own tests,
#: which probe the C API and the archives themselves).
SCOPE = ("fmu", "closed_loop", "control_design", "model", "workbench", "benchmarks", "tests/closed_loop",
         "tests/workbench", "tests/model", "tests/project")
#: The FMPy names that open an archive or build an instance.
FMPY_NAMES = {"FMU2Slave", "FMU2Model", "FMU3Slave", "FMU3Model", "read_model_description", "extract"}
#: ``(file, name)`` -> why the file may use that one of :data:`FMPY_NAMES`.
FMPY_ALLOWED: dict[tuple[str, str], str] = {
    **{("fmu/instance.py", cls): "the instance adapter itself: the one place FMPy's classes are made"
       for cls in ("FMU2Slave", "FMU2Model", "FMU3Slave", "FMU3Model")},
    ("fmu/opened.py", "read_model_description"): "the opened-FMU object itself, after the archive check",
    ("fmu/opened.py", "extract"): "the opened-FMU object itself, after the archive check",
    ("benchmarks/bench_fmu.py", "FMU2Slave"): "times FMPy's own FMU2Slave set+step loop as the named peer of the "
                                              "native driver",
}
#: File -> why it may call ``zipfile.ZipFile`` (what it opens is not an FMU, or is a hostile FMU on purpose).
ZIP_ALLOWED: dict[str, str] = {
    "fmu/archive.py": "the archive check itself (central directory, sizes, names) before anything is extracted",
    "fmu/opened.py": "the opened-FMU object reads members of the archive it has checked",
    "fmu/build.py": "writes the FMU it builds",
    "fmu/ssp.py": "writes and reads SSP archives, not FMUs",
    "workbench/replay.py": "sizes a NumPy .npz replay archive before np.load, not an FMU",
    "tests/project/test_packaging.py": "reads the built wheel and sdist, not FMUs",
    "tests/workbench/test_cli_ssp_reference.py": "reads the reference file copied into an SSP archive, not an FMU",
    "tests/workbench/test_cli_ssp.py": "rewrites an SSP archive (SystemStructure.ssd) to corrupt it, not an FMU",
    "tests/model/test_hostile_input.py": "writes hostile FMU archives (links, bombs, absolute paths) the archive "
                                         "check must refuse, and checks the samples themselves",
}


def sources() -> list[Path]:
    """Every .py file of :data:`SCOPE`."""
    found: list[Path] = []
    for entry in SCOPE:
        path = REPO / entry
        found += [path] if path.is_file() else sorted(path.rglob("*.py"))
    return found


def fmu_access(source: str, where: str) -> tuple[list[tuple[str, str]], list[str]]:
    """``(fmpy, zip)``: ``(name, "where:line: ...")`` for every use of one of :data:`FMPY_NAMES` imported from
    FMPy, and ``"where:line: ..."`` for every ``zipfile.ZipFile`` call in ``source``."""
    tree = ast.parse(source, where)
    fmpy_modules: set[str] = set()   # local names bound to fmpy or one of its submodules
    zip_modules: set[str] = set()    # local names bound to zipfile
    zip_classes: set[str] = set()    # local names bound to zipfile.ZipFile
    fmpy_found: list[tuple[str, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "fmpy" or alias.name.startswith("fmpy."):
                    fmpy_modules.add(alias.asname or alias.name.split(".")[0])
                elif alias.name == "zipfile":
                    zip_modules.add(alias.asname or "zipfile")
        elif isinstance(node, ast.ImportFrom) and node.module is not None:
            if node.module == "fmpy" or node.module.startswith("fmpy."):
                for alias in node.names:
                    if alias.name in FMPY_NAMES or alias.name == "*":
                        fmpy_found.append((alias.name, f"{where}:{node.lineno}: from {node.module} import "
                                                       f"{alias.name}"))
                    elif node.module == "fmpy":
                        fmpy_modules.add(alias.asname or alias.name)  # from fmpy import fmi2
            elif node.module == "zipfile":
                zip_classes |= {alias.asname or alias.name for alias in node.names if alias.name == "ZipFile"}
    zip_found: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in FMPY_NAMES:
            root = node.value
            while isinstance(root, ast.Attribute):
                root = root.value
            if isinstance(root, ast.Name) and root.id in fmpy_modules:
                fmpy_found.append((node.attr, f"{where}:{node.lineno}: {ast.unparse(node)}"))
        if isinstance(node, ast.Call):
            func = node.func
            if (isinstance(func, ast.Attribute) and func.attr == "ZipFile" and isinstance(func.value, ast.Name)
                    and func.value.id in zip_modules) or (isinstance(func, ast.Name) and func.id in zip_classes):
                zip_found.append(f"{where}:{node.lineno}: {ast.unparse(node)}")
    return fmpy_found, zip_found


def test_no_module_outside_fmu_opens_an_fmu_by_hand():
    fmpy_found: list[str] = []
    zip_found: list[str] = []
    for path in sources():
        where = path.relative_to(REPO).as_posix()
        fmpy, zips = fmu_access(path.read_text(encoding="utf-8"), where)
        fmpy_found += [text for name, text in fmpy if (where, name) not in FMPY_ALLOWED]
        zip_found += [] if where in ZIP_ALLOWED else zips
    assert fmpy_found == [], "FMPy's archive/instance API outside fmu/ (use fmu.opened.open_fmu and " \
                             "fmu.instance.Instance):\n" + "\n".join(fmpy_found)
    assert zip_found == [], "zipfile.ZipFile outside fmu/ (an FMU: OpenedFmu.member; another archive: " \
                            "ZIP_ALLOWED with its reason):\n" + "\n".join(zip_found)


def test_every_allowed_entry_exists_and_is_still_needed():
    """A stale entry (file gone, or the access removed) is an error: the allow-lists only shrink by hand."""
    for (where, name), reason in FMPY_ALLOWED.items():
        path = REPO / where
        assert path.is_file() and reason, where
        used = {found for found, _ in fmu_access(path.read_text(encoding="utf-8"), where)[0]}
        assert name in used, f"{where} no longer uses {name}: remove its entry"
    for where, reason in ZIP_ALLOWED.items():
        path = REPO / where
        assert path.is_file() and reason, where
        assert fmu_access(path.read_text(encoding="utf-8"), where)[1], f"{where} no longer calls ZipFile"


@pytest.mark.parametrize("source, fmpy, zips", [
    ("from fmpy.fmi2 import FMU2Slave\n", 1, 0),
    ("from fmpy import extract as x, simulate_fmu\n", 1, 0),
    ("import fmpy\nfmpy.read_model_description('a.fmu')\n", 1, 0),
    ("import fmpy.fmi3 as f3\nf3.FMU3Model\n", 1, 0),
    ("from fmpy import fmi2\nfmi2.FMU2Model\n", 1, 0),
    ("from fmpy.fmi1 import FMICallException\nfrom fmpy.sundials import CVodeSolver\n", 0, 0),
    ("import zipfile\nzipfile.ZipFile('plant.fmu')\n", 0, 1),
    ("import zipfile as z\nz.ZipFile(p, 'w')\n", 0, 1),
    ("from zipfile import ZipFile\nwith ZipFile(p) as zf: pass\n", 0, 1),
    ("import zipfile\nzipfile.is_zipfile(p)\n", 0, 0),
])
def test_the_reader_sees_every_spelling(source, fmpy, zips):
    """The checker itself can fail: each spelling of an access is found, harmless imports are not."""
    found = fmu_access(source, "x.py")
    assert (len(found[0]), len(found[1])) == (fmpy, zips)
