"""Which platforms an FMU carries, and a structural check of each binary with ``llvm-objdump``.

The check reads the binary, it does not load it, so it covers platforms this
machine cannot run (macOS): object format and machine (every slice of a
universal Mach-O; the arm64 one must carry a code signature, zig's ad-hoc one),
exported symbols (the FMI functions and nothing else, bar
the two symbols every Mach-O dylib exports) and imported libraries (the
platform's C runtime only).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from model.errors import ToolchainError

from .platforms import PLATFORMS, Platform, platform_folder

if TYPE_CHECKING:
    from .opened import OpenedFmu

__all__ = ["BinaryCheck", "carried_platforms", "check_binary", "objdump"]

_FORMAT = {  # llvm-objdump's "file format" of each (object format, machine)
    ("elf", "x86_64"): "elf64-x86-64",
    ("elf", "aarch64"): "elf64-littleaarch64",
    ("pe", "x86_64"): "coff-x86-64",
}
_MACHO_ARCH = {"x86_64": "x86_64", "aarch64": "arm64"}
#: Libraries a binary may import, per object format: the C runtime of the platform.
_ALLOWED_IMPORTS = {
    "elf": re.compile(r"lib(c|m)\.so\.6"),
    "pe": re.compile(r"(?i)kernel32\.dll|api-ms-win-crt-[a-z]+-l1-1-0\.dll"),
    "macho": re.compile(r"/usr/lib/libSystem\.B\.dylib"),
}
_MACHO_LINKER_SYMBOLS = {"__mh_dylib_header", "___dso_handle"}


@dataclass
class BinaryCheck:
    """What :func:`check_binary` found in one binary (one slice of a universal file)."""

    platform: str
    exports: list[str] = field(default_factory=list)
    imports: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)


def objdump() -> str | None:
    """``llvm-objdump`` on PATH (or a versioned ``llvm-objdump-N``), or None."""
    found = shutil.which("llvm-objdump")
    if found:
        return found
    for version in range(30, 10, -1):
        found = shutil.which(f"llvm-objdump-{version}")
        if found:
            return found
    return None


def carried_platforms(fmu: "str | Path | OpenedFmu", fmi_version: int = 2) -> dict[str, str]:
    """Platform name -> archive member of its binary, for every platform of the table the FMU has a binary for.

    ``fmu``: an :class:`fmu.opened.OpenedFmu` or the path of an FMU (then opened by :func:`fmu.opened.open_fmu`).
    """
    from .opened import OpenedFmu, open_fmu

    if isinstance(fmu, OpenedFmu):
        names = set(fmu.members())
    else:
        with open_fmu(fmu, validate=False) as opened:
            names = set(opened.members())
    found = {}
    for target in PLATFORMS:
        folder = f"binaries/{platform_folder(target.name, fmi_version)}/"
        members = sorted(n for n in names if n.startswith(folder) and n.endswith(target.suffix) and "/" not in n[len(folder):])
        if members:
            found[target.name] = members[0]
    return found


def _run(tool: str, *args: str) -> str:
    proc = subprocess.run([tool, *args], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise ToolchainError(" ".join(proc.stderr.split())[:200] or f"exit {proc.returncode}")
    return proc.stdout


def check_binary(path: str | Path, target: Platform, tool: str, *, prefix: str = "fmi2") -> BinaryCheck:
    """Check one binary file as a binary of ``target`` (see the module docstring); ``tool`` is llvm-objdump."""
    path = str(path)
    result = BinaryCheck(target.name)
    try:
        if target.object_format == "macho":
            arch = _MACHO_ARCH[target.machine]
            archs = re.findall(r"cputype CPU_TYPE_(\w+)", _run(tool, "--macho", "--universal-headers", path))
            if not archs:  # a thin file: the machine of its one header
                archs = re.findall(r"^MH_MAGIC_64\s+(\w+)", _run(tool, "--macho", "--private-header", path), re.M)
            wanted = {"x86_64": "X86_64", "arm64": "ARM64"}[arch]
            if wanted not in archs:
                result.problems.append(f"no {arch} slice (has: {archs or 'none'})")
                return result
            if arch == "arm64" and "LC_CODE_SIGNATURE" not in _run(tool, "--macho", "--private-headers",
                                                                  f"--arch={arch}", path):
                result.problems.append("the arm64 slice has no code signature (Apple silicon loads signed code only)")
            trie = _run(tool, "--macho", "--exports-trie", f"--arch={arch}", path)
            result.exports = re.findall(r"^0x[0-9A-Fa-f]+\s+(\S+)", trie, re.M)
            dylibs = _run(tool, "--macho", "--dylibs-used", f"--arch={arch}", path).splitlines()[1:]
            names = [line.split(" (")[0].strip() for line in dylibs if line.strip()]
            result.imports = [n for n in names if not n.startswith("@rpath/")]  # the first is its own install name
            result.exports = [s for s in result.exports if s not in _MACHO_LINKER_SYMBOLS]
            result.exports = [s[1:] if s.startswith("_") else s for s in result.exports]
        else:
            header = _run(tool, "-f", path)
            fmt = re.search(r"file format (\S+)", header)
            if fmt is None or fmt.group(1) != _FORMAT[(target.object_format, target.machine)]:
                result.problems.append(f"file format {fmt.group(1) if fmt else '?'}, expected "
                                       f"{_FORMAT[(target.object_format, target.machine)]}")
                return result
            private = _run(tool, "-p", path)
            if target.object_format == "elf":
                result.imports = re.findall(r"^\s*NEEDED\s+(\S+)", private, re.M)
                table = _run(tool, "-T", path)
                result.exports = [line.split()[-1] for line in table.splitlines()
                                  if re.match(r"^[0-9a-f]{8,}\s", line) and "*UND*" not in line]
            else:
                result.imports = re.findall(r"DLL Name: (\S+)", private)
                exports = private.split("Export Table:", 1)[1] if "Export Table:" in private else ""
                result.exports = re.findall(r"^\s+\d+\s+0x[0-9a-f]+\s+(\S+)", exports, re.M)
    except ToolchainError as exc:
        result.problems.append(f"llvm-objdump cannot read it ({exc})")
        return result
    others = sorted(s for s in result.exports if not s.startswith(prefix))
    if others:
        result.problems.append(f"exports non-FMI symbols: {others[:8]}")
    if not result.exports:
        result.problems.append("exports no symbols")
    extra = sorted({i for i in result.imports if not _ALLOWED_IMPORTS[target.object_format].fullmatch(i)})
    if extra:
        result.problems.append(f"imports libraries beyond the C runtime: {extra}")
    return result
