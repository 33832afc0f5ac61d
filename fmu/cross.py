"""Compile C sources into a shared library for any platform of :data:`fmu.platforms.PLATFORMS`.

The host's binary is built by the host compiler (``$CC``, gcc or cc:
:func:`model.codegen.find_compiler`); every other platform by the clang of
the ``ziglang`` PyPI package (``python -m ziglang cc -target ...``), which
ships the C runtime headers and import libraries of each target, so nothing
is downloaded at build time. Both use the one flag policy of
:func:`model.codegen.compile_flags` (strict warnings, ``-ffp-contract=off``),
at ``-O2``, plus hidden visibility: the binary exports the functions its
headers mark for export (``FMI2_Export``: ``visibility("default")`` on ELF and
Mach-O, ``__declspec(dllexport)`` on Windows) and nothing else.

The two macOS slices go into one universal (fat) Mach-O by :func:`write_universal`.
The first build for a target also builds zig's copy of that target's C
runtime into zig's cache (``~/.cache/zig``, ``$ZIG_GLOBAL_CACHE_DIR``): once
per machine, 15 s to 2 min a target here (Windows the longest), then cached.
"""

from __future__ import annotations

import importlib.util
import shutil
import struct
import subprocess
import sys
import time
from functools import lru_cache
from pathlib import Path
from typing import Callable, Sequence

from model.codegen import CompilerNotFoundError, compile_flags, compile_objects, find_compiler
from model.errors import ToolchainError

from .platforms import PLATFORMS, Platform, host_platform, platform_folder

__all__ = [
    "CFLAGS",
    "CASADI_CFLAGS",
    "CrossCompileError",
    "buildable_platforms",
    "compile_shared",
    "compiler_for",
    "place_binaries",
    "write_universal",
    "zig_command",
    "zig_version",
]

# model.codegen's policy (strict warnings, -ffp-contract=off) at -O2, with hidden symbols. CasADi's
# generated functions leave some of their (arg, res, iw, w, mem) parameters unused: that one warning
# is relaxed for the generated file only.
CFLAGS = compile_flags(generated=False, optimisation="-O2") + ("-fvisibility=hidden",)
CASADI_CFLAGS = compile_flags(generated=True, optimisation="-O2") + ("-fvisibility=hidden",)

Progress = Callable[[str], None]


class CrossCompileError(ToolchainError):
    """A compiler is missing, or compiling or linking a platform's binary failed (the message has its output)."""


@lru_cache(maxsize=None)
def zig_command() -> tuple[str, ...] | None:
    """The command prefix of zig (``python -m ziglang``), or None when the ``ziglang`` package is not installed."""
    if importlib.util.find_spec("ziglang") is None:
        return None
    return (sys.executable, "-m", "ziglang")


@lru_cache(maxsize=None)
def zig_version() -> str:
    """zig's version (``0.17.1``), or ``""`` without zig."""
    zig = zig_command()
    if zig is None:
        return ""
    proc = subprocess.run([*zig, "version"], capture_output=True, text=True, check=False)
    return proc.stdout.strip()


def buildable_platforms() -> tuple[tuple[Platform, ...], str]:
    """Every platform this machine can build, and ``""`` or one line saying why the others cannot be."""
    host = host_platform()
    if zig_command() is None:
        return (host,), ("only the host's binary (" + host.name + "): the cross compiler is missing "
                         "(pip install 'manipulator-workbench[cross]' installs ziglang)")
    return PLATFORMS, ""


def compiler_for(target: Platform) -> list[str]:
    """The compiler command for ``target``: the host compiler for the host, else ``zig cc -target``."""
    if target == host_platform():
        try:
            return [find_compiler()]
        except CompilerNotFoundError as exc:
            raise CrossCompileError(str(exc)) from None
    zig = zig_command()
    if zig is None:
        raise CrossCompileError(f"{target.name}: cross-compiling needs the ziglang package "
                                "(pip install 'manipulator-workbench[cross]')")
    return [*zig, "cc", "-target", target.zig_target]


def _link_flags(target: Platform, binary_name: str) -> list[str]:
    if target.object_format == "elf":
        return ["-Wl,--no-undefined", "-Wl,--as-needed", "-lm"]
    if target.object_format == "macho":  # an install name free of the build folder
        return ["-lm", f"-Wl,-install_name,@rpath/{binary_name}"]
    return ["-s"]  # PE: the C runtime's maths is in the UCRT; no debug directory pointing at the build folder


def compile_shared(target: Platform, sources: Sequence[Path], binary: Path, *, include: Sequence[Path] = (),
                   generated: Sequence[Path] = (), work: Path | None = None, progress: Progress | None = None) -> Path:
    """Compile and link ``sources`` into the shared library ``binary`` for ``target``.

    Parameters
    ----------
    target
        A row of :data:`fmu.platforms.PLATFORMS`.
    sources
        The ``.c`` files; those also in ``generated`` get :data:`CASADI_CFLAGS`, the others :data:`CFLAGS`.
    binary
        The library to write (its suffix should be ``target.suffix``).
    include
        ``-I`` folders.
    work
        Where objects and linker by-products go (``work/obj-<name>``); default ``binary.parent``.
    progress
        Called with one line before compiling.

    Returns
    -------
    Path
        ``binary``. Linker by-products (Windows import library, PDB) stay in the object folder.

    Raises
    ------
    CrossCompileError
        No compiler, or the compiler or linker failed.
    """
    cc = compiler_for(target)
    binary = Path(binary)
    obj_dir = Path(work if work is not None else binary.parent) / f"obj-{target.name}"
    obj_dir.mkdir(parents=True, exist_ok=True)
    flags_include = [f"-I{folder}" for folder in include]
    generated_set = {Path(g).resolve() for g in generated}
    units = [(Path(src), obj_dir / (Path(src).stem + ".o"),
              (*(CASADI_CFLAGS if Path(src).resolve() in generated_set else CFLAGS), *flags_include)) for src in sources]
    tool = cc[0] if len(cc) == 1 else f"zig cc {zig_version()} -target {target.zig_target}"
    if progress is not None:
        progress(f"{target.name}: compiling {len(units)} files with {tool}")
    t0 = time.perf_counter()
    compile_objects(cc, units, error=CrossCompileError)
    linked = obj_dir / binary.name  # Windows writes .lib and .pdb next to the DLL: keep them out of the FMU
    strip = ["-s"] if len(cc) > 1 and target.object_format != "pe" else []  # zig keeps its C runtime's debug info
    cmd = [*cc, "-shared", "-o", str(linked), *[str(u[1]) for u in units], *_link_flags(target, binary.name), *strip]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise CrossCompileError(f"linking {binary.name} for {target.name} failed (exit {proc.returncode}):\n"
                                f"$ {' '.join(cmd)}\n{proc.stdout}{proc.stderr[-4000:]}")
    binary.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(linked, binary)
    if progress is not None:
        progress(f"{target.name}: {binary.name} built in {time.perf_counter() - t0:.1f} s")
    return binary


def place_binaries(targets: Sequence[Platform], sources: Sequence[Path], root: Path, identifier: str, *,
                   fmi_version: int, work: Path, include: Sequence[Path] = (), generated: Sequence[Path] = (),
                   progress: Progress | None = None) -> dict[str, Path]:
    """Build ``sources`` for every platform of ``targets`` into ``root/binaries/<folder>/<identifier><suffix>``.

    Folders are those of :func:`fmu.platforms.platform_folder` for ``fmi_version``;
    platforms that share a folder (FMI 2.0's ``darwin64``) are joined into one
    universal binary. ``work`` holds objects and slices. Returns each platform
    name's binary file (shared files appear under each of their platforms).
    """
    by_folder: dict[str, list[Platform]] = {}
    for target in targets:
        by_folder.setdefault(platform_folder(target.name, fmi_version), []).append(target)
    placed: dict[str, Path] = {}
    for folder, group in by_folder.items():
        final = Path(root) / "binaries" / folder / f"{identifier}{group[0].suffix}"
        if len(group) == 1:
            built = [compile_shared(group[0], sources, final, include=include, generated=generated, work=work,
                                    progress=progress)]
        else:
            built = [compile_shared(t, sources, Path(work) / t.name / final.name, include=include, generated=generated,
                                    work=work, progress=progress) for t in group]
            write_universal(built, final)
            if progress is not None:
                progress(f"joined {', '.join(t.name for t in group)} into one universal binary binaries/{folder}/")
        for target in group:
            placed[target.name] = final
    return placed


# ------------------------------------------------------------ universal Mach-O

_MH_MAGIC_64 = 0xFEEDFACF  # a thin 64-bit Mach-O, little-endian on both x86_64 and arm64
_FAT_MAGIC = 0xCAFEBABE    # the fat header, big-endian (<mach-o/fat.h>)
_FAT_ALIGN = 14            # 2**14: the 16 KiB page of arm64, also a multiple of x86_64's 4 KiB


def write_universal(slices: Sequence[Path], output: Path) -> Path:
    """Join thin 64-bit Mach-O files into one universal (fat) Mach-O at ``output``, as ``lipo -create`` does.

    The layout of ``<mach-o/fat.h>``: a big-endian header (magic, count), one
    ``fat_arch`` (CPU type, subtype, offset, size, alignment) per slice, then
    each slice at an offset aligned to 2**14 bytes.
    """
    blobs = [Path(s).read_bytes() for s in slices]
    archs = []
    for path, blob in zip(slices, blobs):
        magic, cputype, cpusubtype = struct.unpack_from("<Iii", blob, 0)
        if magic != _MH_MAGIC_64:
            raise CrossCompileError(f"{path}: not a thin 64-bit Mach-O (magic {magic:#x})")
        archs.append((cputype, cpusubtype))
    if len(set(archs)) != len(archs):
        raise CrossCompileError(f"universal binary: two slices of the same CPU type in {[str(s) for s in slices]}")
    align = 1 << _FAT_ALIGN
    offsets, end = [], 8 + 20 * len(blobs)
    for blob in blobs:
        offsets.append(-(-end // align) * align)
        end = offsets[-1] + len(blob)
    out = bytearray(struct.pack(">II", _FAT_MAGIC, len(blobs)))
    for (cputype, cpusubtype), blob, offset in zip(archs, blobs, offsets):
        out += struct.pack(">iiIII", cputype, cpusubtype, offset, len(blob), _FAT_ALIGN)
    for blob, offset in zip(blobs, offsets):
        out += b"\0" * (offset - len(out)) + blob
    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_bytes(bytes(out))
    return output
