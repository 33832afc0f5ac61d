"""What ``validate-fmu`` finds in an FMU without running it: its description, its binaries, its internal step.

* :func:`model_description_problems`: FMPy's validation of ``modelDescription.xml`` (schema, names, units,
  ModelStructure);
* :func:`binary_problems`: this machine's binary exports its FMI version's functions only (``fmi2`` or
  ``fmi3``) and needs only libc and libm; the binaries of other platforms (Windows, macOS, Linux on aarch64)
  are listed and checked structurally (:mod:`fmu.binaries`);
* :func:`internal_step`: the start value of the FMU's ``internal_step`` (s).

The robot the FMU records is read by :mod:`fmu.robot_resource`. Every function opens the FMU with
:func:`fmu.opened.open_fmu` (the archive checked before anything is read or extracted).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any

from .opened import OpenedFmu, open_fmu

__all__ = ["binary_problems", "internal_step", "model_description_problems"]


def model_description_problems(fmu_path: str | os.PathLike[str]) -> list[str]:
    """FMPy's validation of the FMU (schema, variable names, units, ModelStructure)."""
    from fmpy.validation import validate_fmu as fmpy_validate_fmu

    from .archive import check_fmu_archive

    check_fmu_archive(fmu_path)  # FMPy reads the archive itself: refuse a hostile one first
    return list(fmpy_validate_fmu(str(fmu_path)))


def _write_member(fmu: OpenedFmu, member: str, folder: Path) -> Path:
    """Archive member ``member`` written under ``folder`` (its size already checked by the archive check)."""
    data = fmu.member(member)
    assert data is not None  # a name of fmu.members()
    out = folder / Path(member).name
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(data)
    return out


def binary_problems(fmu_path: str | os.PathLike[str]) -> tuple[list[str], dict[str, Any]]:
    """Check the FMU's binary: only ``fmi2`` (FMI 2.0) or ``fmi3`` (FMI 3.0) functions exported, only libc and libm needed.

    Returns the problems and facts (``exports``, ``needed``, ``platforms``, ``structure``) for the report.
    """
    from .binaries import carried_platforms
    from .platforms import host_platform, platform_folder

    problems: list[str] = []
    facts: dict[str, Any] = {}
    with open_fmu(fmu_path, validate=False) as fmu, tempfile.TemporaryDirectory(prefix="mw_fmu_check_") as tmp:
        version = fmu.fmi_version
        prefix = f"fmi{version}"
        host = host_platform()
        carried = carried_platforms(fmu, version)
        facts["platforms"] = list(carried)
        problems += _other_platforms(fmu, carried, host.name, Path(tmp), facts, prefix)
        if host.name not in carried:
            folder = platform_folder(host.name, version)
            return problems + [f"{fmu_path}: no binaries/{folder}/*{host.suffix} (this machine's) in the FMU"], facts
        member = carried[host.name]
        lib = _write_member(fmu, member, Path(tmp) / host.name)
        tools = [t for t in ("nm", "readelf") if shutil.which(t) is None]
        if tools:
            return [f"binary check: expected {tools} on PATH (binutils)"], facts
        nm = subprocess.run(["nm", "-D", "--defined-only", str(lib)], capture_output=True, text=True, check=False)
        if nm.returncode != 0:  # not a shared object nm can read: a problem of the FMU, not a crash
            reason = " ".join(nm.stderr.split())[:200]
            return [f"{member} is not a shared object nm can read ({reason})"], facts
        exports = sorted(line.split()[-1] for line in nm.stdout.splitlines() if line.strip())
        others = [s for s in exports if not s.startswith(prefix)]
        if others:
            problems.append(f"{member} exports non-FMI symbols: {others}")
        facts["exports"] = len(exports)
        elf = subprocess.run(["readelf", "-d", str(lib)], capture_output=True, text=True, check=False)
        needed = re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", elf.stdout)
        extra = [lib_name for lib_name in needed if not re.fullmatch(r"lib(c|m)\.so\.\d+", lib_name)]
        if extra:
            problems.append(f"{member} needs libraries beyond libc and libm: {extra}")
        facts["needed"] = needed
    return problems, facts


def _other_platforms(fmu: OpenedFmu, carried: dict[str, str], host: str, tmp: Path,
                     facts: dict[str, Any], prefix: str) -> list[str]:
    """Structural checks (llvm-objdump) of the binaries this machine does not load; problems named by member."""
    from .binaries import check_binary, objdump
    from .platforms import PLATFORMS

    others = [p for p in PLATFORMS if p.name in carried and p.name != host]
    tool = objdump()
    if not others or tool is None:
        facts["structure"] = "no other platforms" if not others else "not checked: llvm-objdump not on PATH"
        return []
    problems = []
    for target in others:
        found = check_binary(_write_member(fmu, carried[target.name], tmp / target.name), target, tool, prefix=prefix)
        problems += [f"{carried[target.name]} ({target.name}): {p}" for p in found.problems]
    facts["structure"] = f"checked with llvm-objdump: {', '.join(p.name for p in others)}"
    return problems


def internal_step(fmu: OpenedFmu) -> float:
    """The start value of the FMU's ``internal_step``, s."""
    return float(fmu.start_values(["internal_step"])[0])
