"""The optional system tools of the test suite: which are here, and what a test that needs a missing one does.

A fresh machine with Python, gcc and make runs ``make test``: every test that needs a tool
beyond those is skipped, with a reason naming the tool and ``tools/system-packages`` (which
installs them all on Debian or Ubuntu), and the run ends with one summary of what was skipped
and why (``tests/conftest.py``). With ``MANIP_REQUIRE_ALL=1`` (CI: ``.ci/run``) a missing tool
fails the test instead, so CI proves everything.

A test says what it needs with the marker ``@pytest.mark.needs("clang")`` (checked before it
runs) or, where the need depends on a parameter, by calling :func:`require` inside it. A tool
is looked up on ``PATH`` only, so hiding it from ``PATH`` simulates a machine without it.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import pytest

__all__ = ["REQUIRE_ALL", "TOOLS", "Tool", "find", "missing_reason", "require", "skipped_for_tools"]

#: The variable that turns a skip for a missing tool into a failure (CI sets it).
REQUIRE_ALL = "MANIP_REQUIRE_ALL"
#: Where Debian's ``libc6-arm64-cross`` puts the aarch64 glibc that ``qemu-aarch64 -L`` runs a driver with.
AARCH64_SYSROOT = Path("/usr/aarch64-linux-gnu")
#: Words every skip reason of this module contains (the summary collects the skips by them).
_REASON_MARK = "tools/system-packages installs it"


def _which(*names: str) -> Callable[[], str | None]:
    def find() -> str | None:
        return next((path for path in map(shutil.which, names) if path), None)
    return find


def _llvm_objdump() -> str | None:
    return _which("llvm-objdump", *(f"llvm-objdump-{v}" for v in range(30, 10, -1)))()


def _qemu_aarch64() -> str | None:
    qemu = shutil.which("qemu-aarch64")
    return qemu if qemu and (AARCH64_SYSROOT / "lib" / "ld-linux-aarch64.so.1").is_file() else None


@dataclass(frozen=True)
class Tool:
    """An optional system tool: what it is for, how to find it, the Debian packages that bring it."""

    name: str
    purpose: str
    packages: str
    locate: Callable[[], str | None]


#: Every optional tool of the suite (``tools/system-packages`` installs the same list).
TOOLS: dict[str, Tool] = {t.name: t for t in (
    Tool("valgrind", "the FMU's memory checks", "valgrind", _which("valgrind")),
    Tool("clang", "the C built with a second compiler", "clang", _which("clang")),
    Tool("llvm-objdump", "structure of the Windows, macOS and aarch64 binaries", "llvm", _llvm_objdump),
    Tool("wine", "running the win64 FMU binary", "wine wine64", _which("wine64", "wine")),
    Tool("qemu-aarch64", "running the aarch64-linux FMU binary", "qemu-user libc6-arm64-cross", _qemu_aarch64),
    Tool("chromium", "the teach page and the report in a real browser", "chromium", _which("chromium")),
    Tool("chromedriver", "driving Chromium from the tests (Selenium)", "chromium-driver", _which("chromedriver")),
    Tool("cmake", "FMPy's rebuild of a source FMU", "cmake", _which("cmake")),
)}


def find(name: str) -> str | None:
    """The path of the tool ``name`` (a key of :data:`TOOLS`), or None when it is not here."""
    return TOOLS[name].locate()


def missing_reason(name: str) -> str:
    """The reason a test that needs the missing tool ``name`` gives: the tool, its use and its packages."""
    tool = TOOLS[name]
    return (f"needs {name} ({tool.purpose}): not on PATH; {_REASON_MARK} "
            f"(Debian/Ubuntu package {tool.packages})")


def require(*names: str) -> str:
    """The path of the first of the tools ``names``; each one missing skips the test, or with
    ``MANIP_REQUIRE_ALL=1`` fails it. Returns the path of the first tool."""
    for name in names:
        if find(name) is None:
            if os.environ.get(REQUIRE_ALL, "") not in ("", "0"):
                pytest.fail(f"{REQUIRE_ALL}=1: {missing_reason(name)}", pytrace=False)
            pytest.skip(missing_reason(name))
    found = find(names[0])
    assert found is not None
    return found


def skipped_for_tools(reasons: list[str]) -> dict[str, int]:
    """Tool name -> number of tests skipped for it, from the skip reasons of a run (others are left out)."""
    counts: dict[str, int] = {}
    for reason in reasons:
        if _REASON_MARK in reason and reason.startswith("needs "):
            name = reason[len("needs "):].split(" ", 1)[0]
            counts[name] = counts.get(name, 0) + 1
    return counts
