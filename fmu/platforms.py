"""The one table of the platforms an FMU binary is built for, and their folder names in FMI 2.0 and 3.0.

Each :class:`Platform` says how to build (the ``zig cc`` target), where the
binary goes (the FMI 2.0 and FMI 3.0 ``binaries/`` folders), what it is (the
object format and machine a structural check expects) and how it is run here
(natively, under wine, under qemu-user, or not at all).

FMI 2.0 names three 64-bit platforms: ``linux64``, ``win64`` and ``darwin64``.
It has no name for Linux on aarch64 or macOS on arm64:

* ``darwin64`` holds one universal (fat) Mach-O with both ``x86_64`` and
  ``arm64`` slices. FMI 2.0 importers on Apple silicon look in ``darwin64``
  (FMPy does, whatever the machine), and a universal library is the Apple
  way to serve both; the Reference-FMUs put a thin x86_64 library there, which
  an arm64 process cannot load.
* Linux on aarch64 uses the FMI 3.0 folder name ``aarch64-linux`` in FMI 2.0
  FMUs too. ``linux64`` cannot hold two machines, and the Reference-FMUs build
  no FMI 2.0 binary for aarch64 at all; an importer on an ARM Linux rig points
  at ``binaries/aarch64-linux/`` (FMPy: ``libraryPath``) or imports the FMI 3.0
  FMU, where the name is standard.
"""

from __future__ import annotations

import platform as _platform
from dataclasses import dataclass

from model.errors import InputError, ToolchainError

__all__ = [
    "Platform",
    "PLATFORMS",
    "FMI2_ALIASES",
    "UnsupportedHostError",
    "host_platform",
    "platform_folder",
    "resolve_platforms",
]


@dataclass(frozen=True)
class Platform:
    """One target of an FMU binary.

    Attributes
    ----------
    name
        Our name: the FMI 3.0 platform tuple (``x86_64-windows``).
    zig_target
        The ``zig cc -target`` triple, with the oldest C runtime it links against
        (glibc 2.17, macOS 11) so the binary runs on old systems too.
    fmi2_folder, fmi3_folder
        The folder under ``binaries/`` in an FMI 2.0 and an FMI 3.0 FMU.
    suffix
        The shared-library suffix: ``.so``, ``.dll`` or ``.dylib``.
    object_format, machine
        What a structural check expects: ``elf``/``pe``/``macho`` and ``x86_64``/``aarch64``.
    runner
        How an x86_64 Linux machine runs the platform's test driver: ``"native"``, ``"wine"``,
        ``"qemu-aarch64"`` or ``""`` (no way: checked structurally only).
    runtime
        The C runtime the binary may need, for a person.
    """

    name: str
    zig_target: str
    fmi2_folder: str
    fmi3_folder: str
    suffix: str
    object_format: str
    machine: str
    runner: str
    runtime: str

    @property
    def system(self) -> str:
        """``linux``, ``windows`` or ``darwin``."""
        return self.name.split("-", 1)[1]


#: Every platform the workbench builds, in the order they are built and listed.
PLATFORMS: tuple[Platform, ...] = (
    Platform("x86_64-linux", "x86_64-linux-gnu.2.17", "linux64", "x86_64-linux", ".so", "elf", "x86_64",
             "native", "glibc: libc.so.6, libm.so.6"),
    Platform("x86_64-windows", "x86_64-windows-gnu", "win64", "x86_64-windows", ".dll", "pe", "x86_64",
             "wine", "the Universal C Runtime (api-ms-win-crt-*) and KERNEL32.dll"),
    Platform("x86_64-darwin", "x86_64-macos.11.0", "darwin64", "x86_64-darwin", ".dylib", "macho", "x86_64",
             "", "libSystem.B.dylib"),
    Platform("aarch64-darwin", "aarch64-macos.11.0", "darwin64", "aarch64-darwin", ".dylib", "macho", "aarch64",
             "", "libSystem.B.dylib"),
    Platform("aarch64-linux", "aarch64-linux-gnu.2.17", "aarch64-linux", "aarch64-linux", ".so", "elf", "aarch64",
             "qemu-aarch64", "glibc: libc.so.6, libm.so.6"),
)

_BY_NAME = {p.name: p for p in PLATFORMS}

#: FMI 2.0 folder names accepted as platform names (``darwin64``: both macOS machines, one universal binary).
FMI2_ALIASES: dict[str, tuple[str, ...]] = {
    "linux64": ("x86_64-linux",),
    "win64": ("x86_64-windows",),
    "darwin64": ("x86_64-darwin", "aarch64-darwin"),
}


class UnsupportedHostError(ToolchainError):
    """FMUs are exported on Linux (x86_64 or aarch64) only."""


def platform_folder(name: str, fmi_version: int) -> str:
    """The ``binaries/`` folder of platform ``name`` in an FMU of FMI version 2 or 3.

    >>> platform_folder("aarch64-darwin", 2), platform_folder("aarch64-darwin", 3)
    ('darwin64', 'aarch64-darwin')
    """
    if fmi_version not in (2, 3):
        raise InputError(f"expected 2 or 3, got {fmi_version!r}", parameter="fmi_version")
    try:
        target = _BY_NAME[name]
    except KeyError:
        raise InputError(f"expected one of {', '.join(_BY_NAME)}, got {name!r}", parameter="platform") from None
    return target.fmi2_folder if fmi_version == 2 else target.fmi3_folder


def host_platform() -> Platform:
    """The platform of this machine; :class:`UnsupportedHostError` if it is not Linux on x86_64 or aarch64."""
    system, machine = _platform.system(), _platform.machine().lower()
    if system != "Linux":
        raise UnsupportedHostError(
            f"FMU export is supported on Linux (linux64) only; got {system or 'an unknown system'}. "
            "An FMU exported on Linux carries its C code in sources/, from which importers rebuild "
            "the binary on other platforms (e.g. FMPy's 'Compile platform binary')")
    arch = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64", "arm64": "aarch64"}.get(machine)
    if arch is None or _platform.architecture()[0] != "64bit":
        raise UnsupportedHostError(f"FMU export runs on 64-bit x86_64 or aarch64 Linux; got {machine or 'unknown'}")
    return _BY_NAME[f"{arch}-linux"]


def resolve_platforms(names: str | list[str] | tuple[str, ...], *, flag: str = "--platforms") -> tuple[Platform, ...]:
    """The platforms named in ``names`` (a comma list or a sequence), in table order, the host's always included.

    Names are our platform names, the FMI 2.0 folder names (``linux64``, ``win64``,
    ``darwin64`` = both macOS machines) or ``host``.

    Raises
    ------
    model.errors.InputError
        An unknown name, naming ``flag``, the value and the known names.
    """
    items = [n.strip() for n in (names.split(",") if isinstance(names, str) else names)]
    wanted = {host_platform().name}
    for item in items:
        if item == "host" or item == "":
            continue
        if item in _BY_NAME:
            wanted.add(item)
        elif item in FMI2_ALIASES:
            wanted.update(FMI2_ALIASES[item])
        else:
            known = ", ".join(["host", *FMI2_ALIASES, *_BY_NAME])
            raise InputError(f"{flag}: unknown platform {item!r}; known: {known}")
    return tuple(p for p in PLATFORMS if p.name in wanted)
