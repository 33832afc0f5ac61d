"""One SCARA FMU with binaries for five platforms, run on three of them and checked on all five.

The FMU is exported once per test session through the real ``manip export-fmu``
with its default ``--platforms`` (everything zig builds). The C test driver
(``fmu/c/fmu_driver.c``) is cross-compiled too and runs

* the win64 binary under wine, the aarch64-linux binary under qemu-user (with
  Debian's aarch64 glibc as its sysroot), and the linux64 binary natively:
  the same lifecycle and bad-call checks (``soak``) and the same numbers
  (``trace``: 200 Co-Simulation steps, ME derivatives and directional
  derivatives) to 1e-12 of the linux64 run, relative to each column's scale.
  The bound: the wrapper is compiled without floating-point contraction, so
  gcc and clang round alike, and what differs is the C runtime's sin/cos (UCRT
  against glibc, last-ulp differences: 1.7e-21 measured here, aarch64 bitwise
  equal); 1e-12 leaves room for libm versions and fails on any real change.
* macOS cannot be run here: both slices of the universal ``darwin64`` binary
  are checked structurally (Mach-O, machine, exported symbols, libraries).

Tests that run a binary need wine or qemu-aarch64 (and its sysroot), the structural checks
llvm-objdump: without them they are skipped, naming the tool (:mod:`tests.support.system_tools`);
``tools/system-packages`` installs them, and CI (``MANIP_REQUIRE_ALL=1``) runs them all.
Cold, the cross builds cost minutes once per machine (zig builds each target's C
runtime into its cache); warm, about 10 s.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from fmu.binaries import carried_platforms, check_binary, objdump
from fmu.build import build_driver
from fmu.platforms import PLATFORMS, host_platform, platform_folder

from tests.support.fmu_support import build_root
from tests.support.system_tools import AARCH64_SYSROOT, require

pytestmark = pytest.mark.cross
BY_NAME = {p.name: p for p in PLATFORMS}
TOL = 1e-12
STEPS = 200
REPEATS = 3


def _manip() -> list[str]:
    return [sys.executable, "-m", "workbench.cli"]


@pytest.fixture(scope="session")
def cross_export():
    """The five-platform SCARA FMU, its export's stderr, and the folder it is extracted into."""
    from fmu.cross import zig_command

    assert zig_command() is not None, "the ziglang package is required (it is in the test extra: pip install -e '.[test]')"
    root = build_root() / "cross"
    fmu_path = root / "scara.fmu"
    proc = subprocess.run([*_manip(), "export-fmu", "scara", "-o", str(fmu_path)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    folder = root / "unzipped"
    with zipfile.ZipFile(fmu_path) as zf:
        zf.extractall(folder)
    return fmu_path, proc.stderr, folder


@lru_cache(maxsize=None)
def _driver(name: str) -> Path:
    suffix = ".exe" if BY_NAME[name].system == "windows" else ""
    return build_driver(build_root() / "cross" / f"fmu_driver-{name}{suffix}", BY_NAME[name])


def _args(folder: Path, mode: str, count: int) -> list[str]:
    from fmpy import read_model_description

    md = read_model_description(str(folder))
    inputs = [str(v.valueReference) for v in md.modelVariables if v.causality == "input"]
    return [mode, "LIB", md.guid, str(len(md.derivatives)), str(count), *inputs]


def _run(name: str, folder: Path, mode: str, count: int, tmp_path: Path) -> subprocess.CompletedProcess:
    """Run the driver of platform ``name`` on that platform's binary of the FMU."""
    target = BY_NAME[name]
    lib = folder / "binaries" / platform_folder(name, 2) / f"scara{target.suffix}"
    args = [str(lib) if a == "LIB" else a for a in _args(folder, mode, count)]
    env = dict(os.environ)
    if target.runner == "native":
        prefix: list[str] = []
    elif target.runner == "wine":
        prefix = [require("wine")]
        # one prefix for the session: wine's first start in a new prefix costs about 10 s here
        env.update(WINEDEBUG="-all", WINEPREFIX=str(build_root() / "cross" / "wineprefix"))
    elif target.runner == "qemu-aarch64":
        prefix = [require("qemu-aarch64"), "-L", str(AARCH64_SYSROOT)]
    else:
        raise AssertionError(f"{name}: not runnable here")
    return subprocess.run([*prefix, str(_driver(name)), *args], capture_output=True, text=True, env=env, timeout=300)


def _numbers(stdout: str) -> dict[str, np.ndarray]:
    """The rows of a ``trace`` run by label (``cs 17``, ``me der``), carriage returns (wine) dropped."""
    rows = {}
    for line in stdout.replace("\r", "").splitlines():
        words = line.split()
        if words[:1] == ["cs"]:
            rows[" ".join(words[:2])] = np.array([float(w) for w in words[2:]])
        elif words[:1] == ["me"]:
            rows[" ".join(words[:2])] = np.array([float(w) for w in words[2:]])
    return rows


@lru_cache(maxsize=None)
def _linux64_trace(folder: Path) -> dict[str, np.ndarray]:
    proc = _run("x86_64-linux", folder, "trace", STEPS, folder)
    assert proc.returncode == 0, proc.stderr
    return _numbers(proc.stdout)


def _worst(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    """Largest difference over all rows, relative to max(1, |column| over the run)."""
    assert a.keys() == b.keys() and len(a) == STEPS + 2
    cs = np.array([a[f"cs {k}"] for k in range(1, STEPS + 1)])
    scale = np.maximum(1.0, np.abs(cs).max(axis=0))
    return max(float(np.max(np.abs(a[key] - b[key]) / (scale if key.startswith("cs") else
                                                          np.maximum(1.0, np.abs(a[key]))))) for key in a)


# ------------------------------------------------------------------- the FMU

def test_one_fmu_carries_five_platforms_in_fmi2_folders(cross_export):
    from fmpy import supported_platforms

    fmu_path, stderr, _ = cross_export
    carried = carried_platforms(fmu_path)
    assert set(carried) == set(BY_NAME)
    assert carried == {"x86_64-linux": "binaries/linux64/scara.so", "x86_64-windows": "binaries/win64/scara.dll",
                       "x86_64-darwin": "binaries/darwin64/scara.dylib", "aarch64-darwin": "binaries/darwin64/scara.dylib",
                       "aarch64-linux": "binaries/aarch64-linux/scara.so"}
    assert {"linux64", "win64", "darwin64"} <= set(supported_platforms(str(fmu_path)))  # FMPy's reading of it
    for name in BY_NAME:  # progress per platform on stderr
        assert f"{name}: scara" in stderr and "built in" in stderr
    with zipfile.ZipFile(fmu_path) as zf:  # nothing of the build (objects, import libraries, PDBs) in the FMU
        binaries = [n for n in zf.namelist() if n.startswith("binaries/") and not n.endswith("/")]
    assert len(binaries) == 4


@pytest.mark.needs("llvm-objdump")
@pytest.mark.parametrize("name", list(BY_NAME))
def test_each_binary_exports_the_fmi_functions_and_needs_only_the_c_runtime(cross_export, name):
    tool = objdump()
    _, _, folder = cross_export
    reference = check_binary(folder / "binaries/linux64/scara.so", BY_NAME["x86_64-linux"], tool)
    found = check_binary(folder / "binaries" / platform_folder(name, 2) / f"scara{BY_NAME[name].suffix}",
                         BY_NAME[name], tool)
    assert found.problems == []
    assert sorted(found.exports) == sorted(reference.exports) and len(found.exports) == 44
    assert found.imports


@pytest.mark.needs("llvm-objdump")
def test_darwin64_is_one_universal_binary_of_both_macs(cross_export):
    """Read by llvm-objdump's own Mach-O reader: the fat header written by fmu.cross.write_universal."""
    _, _, folder = cross_export
    out = subprocess.run([objdump(), "--macho", "--universal-headers", str(folder / "binaries/darwin64/scara.dylib")],
                         capture_output=True, text=True, check=True).stdout
    assert "nfat_arch 2" in out and "CPU_TYPE_X86_64" in out and "CPU_TYPE_ARM64" in out


@pytest.mark.needs("llvm-objdump")
def test_the_structural_check_catches_a_wrong_machine_and_a_thin_file(cross_export, tmp_path):
    """Negative controls: the x86_64 ELF read as aarch64, a thin Mach-O read as a universal one's arm64 slice."""
    _, _, folder = cross_export
    tool = objdump()
    wrong = check_binary(folder / "binaries/linux64/scara.so", BY_NAME["aarch64-linux"], tool)
    assert wrong.problems == ["file format elf64-x86-64, expected elf64-littleaarch64"]
    thin = tmp_path / "thin.dylib"
    blob = (folder / "binaries/darwin64/scara.dylib").read_bytes()
    import struct

    offset, size = struct.unpack_from(">II", blob, 8 + 8)  # the first slice (x86_64)
    thin.write_bytes(blob[offset:offset + size])
    assert check_binary(thin, BY_NAME["x86_64-darwin"], tool).problems == []
    assert "no arm64 slice" in check_binary(thin, BY_NAME["aarch64-darwin"], tool).problems[0]


@pytest.mark.needs("llvm-objdump")
def test_validate_fmu_lists_the_platforms_and_checks_them(cross_export):
    from fmu.validate import binary_problems

    fmu_path, _, _ = cross_export
    problems, facts = binary_problems(fmu_path)
    assert problems == []
    assert facts["platforms"] == list(BY_NAME) and facts["exports"] == 44
    assert facts["structure"].startswith("checked with llvm-objdump: x86_64-windows")


# ------------------------------------------------------------- run, not link

@pytest.mark.parametrize("name", ["x86_64-linux", "x86_64-windows", "aarch64-linux"])
def test_the_binary_runs_the_lifecycle_and_refuses_bad_calls(cross_export, name, tmp_path):
    _, _, folder = cross_export
    proc = _run(name, folder, "soak", REPEATS, tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert f"soak: {REPEATS} repetitions, 0 failures" in proc.stdout


@pytest.mark.parametrize("name", ["x86_64-windows", "aarch64-linux"])
def test_the_numbers_match_the_linux64_run(cross_export, name, tmp_path):
    _, _, folder = cross_export
    proc = _run(name, folder, "trace", STEPS, tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    worst = _worst(_linux64_trace(folder), _numbers(proc.stdout))
    print(f"{name}: largest difference from linux64 {worst:.2e}")
    assert worst <= TOL


def test_the_comparison_catches_a_different_model(cross_export, tmp_path):
    """Negative control: the linux64 numbers off by 1e-10 (relative) fail the 1e-12 comparison."""
    _, _, folder = cross_export
    reference = _linux64_trace(folder)
    shifted = {k: v * (1 + 1e-10) for k, v in reference.items()}
    assert _worst(reference, shifted) > TOL


# ------------------------------------------------------------------ the CLI

def test_an_unknown_platform_is_one_line_naming_the_flag_and_value(tmp_path):
    out = tmp_path / "x.fmu"
    proc = subprocess.run([*_manip(), "export-fmu", "scara", "-o", str(out), "--platforms", "linux64,win32"],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--platforms" in lines[0] and "'win32'" in lines[0]
    assert "linux64" in lines[0] and "aarch64-linux" in lines[0]
    assert not out.exists() and not any(tmp_path.iterdir())


def _extra_source(folder: Path) -> Path:
    """A C file exporting one FMI function and one helper, with a third function left hidden."""
    source = folder / "extra.c"
    source.write_text("#if defined(_WIN32)\n#define EXPORT __declspec(dllexport)\n#else\n"
                      "#define EXPORT __attribute__((visibility(\"default\")))\n#endif\n"
                      "EXPORT const char *fmi2GetVersion(void) { return \"2.0\"; }\n"
                      "EXPORT int helper(void) { return 1; }\n"
                      "int hidden(void) { return 2; }\n")
    return source


@pytest.mark.needs("llvm-objdump")
@pytest.mark.parametrize("name", ["x86_64-windows", "aarch64-darwin", "aarch64-linux"])
def test_compile_shared_builds_any_sources_and_the_check_sees_an_extra_export(cross_export, name, tmp_path):
    """fmu.cross.compile_shared on other sources (as an FMI 3.0 build calls it); negative control: a helper
    exported next to an FMI function is reported, a hidden one is not."""
    from fmu.cross import compile_shared

    source = _extra_source(tmp_path)
    target = BY_NAME[name]
    binary = compile_shared(target, [source], tmp_path / "out" / f"extra{target.suffix}", work=tmp_path / "work")
    assert binary.is_file() and not (tmp_path / "out" / "obj-" f"{name}").exists()
    found = check_binary(binary, target, objdump())
    assert sorted(found.exports) == ["fmi2GetVersion", "helper"]
    assert found.problems == ["exports non-FMI symbols: ['helper']"]


def test_without_zig_the_default_is_the_hosts_binary_and_one_line_says_why(tmp_path, monkeypatch, capsys):
    import fmu.cross
    from workbench.cli import main

    monkeypatch.setattr(fmu.cross, "zig_command", lambda: None)
    out = tmp_path / "planar2r.fmu"
    assert main(["export-fmu", "planar2r", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    host = host_platform().name
    assert (f"--platforms: only the host's binary ({host}): the cross compiler is missing "
            "(pip install 'manipulator-workbench[cross]' installs ziglang)") in err
    assert list(carried_platforms(out)) == [host]
    # asked for by name, a platform without its compiler is refused in one line before any work
    assert main(["export-fmu", "planar2r", "-o", str(tmp_path / "w.fmu"), "--platforms", "win64"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == ["manip export-fmu: error: x86_64-windows: cross-compiling needs the ziglang package "
                     "(pip install 'manipulator-workbench[cross]')"]
    assert not (tmp_path / "w.fmu").exists()


@pytest.mark.needs("llvm-objdump")
def test_place_binaries_uses_each_fmi_versions_folders(cross_export, tmp_path):
    """FMI 2.0: both Macs in one universal darwin64 binary; FMI 3.0: one thin binary per platform tuple."""
    from fmu.cross import place_binaries

    source = _extra_source(tmp_path)
    macs = [BY_NAME["x86_64-darwin"], BY_NAME["aarch64-darwin"]]
    two = place_binaries(macs, [source], tmp_path / "fmi2", "extra", fmi_version=2, work=tmp_path / "w2")
    three = place_binaries(macs, [source], tmp_path / "fmi3", "extra", fmi_version=3, work=tmp_path / "w3")
    assert two == {m.name: tmp_path / "fmi2/binaries/darwin64/extra.dylib" for m in macs}
    assert three == {m.name: tmp_path / f"fmi3/binaries/{m.name}/extra.dylib" for m in macs}
    assert sorted(p.relative_to(tmp_path).as_posix() for p in (tmp_path / "fmi3").rglob("*") if p.is_file()) == [
        "fmi3/binaries/aarch64-darwin/extra.dylib", "fmi3/binaries/x86_64-darwin/extra.dylib"]
    headers = subprocess.run([objdump(), "--macho", "--universal-headers", str(two["x86_64-darwin"])],
                             capture_output=True, text=True, check=True).stdout
    assert "nfat_arch 2" in headers
    for mac in macs:
        assert check_binary(three[mac.name], mac, objdump()).exports == ["fmi2GetVersion", "helper"]
        assert "no " in check_binary(three[mac.name], macs[1 - macs.index(mac)], objdump()).problems[0]


@pytest.mark.needs("llvm-objdump")
def test_the_validation_report_prints_the_platforms(cross_export):
    from fmu.validate import ValidationReport, binary_problems

    fmu_path, _, _ = cross_export
    text = ValidationReport(str(fmu_path), [], *binary_problems(fmu_path)).format()
    assert ("  platforms: x86_64-linux, x86_64-windows, x86_64-darwin, aarch64-darwin, aarch64-linux (this machine's "
            "loaded and run; others checked with llvm-objdump: x86_64-windows, x86_64-darwin, aarch64-darwin, "
            "aarch64-linux)") in text


@pytest.mark.fmi3
@pytest.mark.needs("llvm-objdump")
def test_an_fmi3_fmu_carries_every_platform_in_its_own_folders(tmp_path):
    """FMI 3.0 puts each binary in its platform tuple's folder; each exports only ``fmi3`` functions."""
    from fmu.build import export_fmu
    from fmu.validate import binary_problems

    path = export_fmu("scara", tmp_path / "scara3.fmu", fmi_version=3, platforms=PLATFORMS)
    carried = carried_platforms(path, 3)
    assert set(carried) == set(BY_NAME)
    assert all(member.startswith(f"binaries/{name}/") for name, member in carried.items())  # FMI 3.0 names
    problems, facts = binary_problems(path)
    assert problems == [] and facts["platforms"] == list(carried)
    tool = objdump()
    with zipfile.ZipFile(path) as zf:
        win = Path(zf.extract(carried["x86_64-windows"], tmp_path))
    assert check_binary(win, BY_NAME["x86_64-windows"], tool, prefix="fmi3").problems == []
    wrong = check_binary(win, BY_NAME["x86_64-windows"], tool, prefix="fmi2").problems  # negative control
    assert wrong and "fmi3DoStep" in " ".join(wrong)
