"""Memory check: a plain C importer (fmu/c/fmu_driver.c) runs the SCARA FMU 50 times under valgrind.

Each repetition: a refused instantiation (wrong GUID), a Co-Simulation instance
(250 steps, FMU state get / serialise / deserialise / set / free, a rejected
short buffer, a discarded non-finite step, a call out of order, reset, free) and
a Model Exchange instance (states, derivatives, a directional derivative, FMU
state, free). Three FMU states per repetition are never freed by the driver:
fmi2FreeInstance has to free them (FMI 2.0, 2.1.5). valgrind must report no
error and no leak.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from fmu.build import build_driver

from tests.support.fmu_support import build_root, scara_dir

REPEATS = 50


@pytest.fixture(scope="module")
def driver():
    return build_driver(build_root() / "fmu_driver")


def _driver_args(driver):
    from fmpy import read_model_description

    md = read_model_description(str(scara_dir()))
    inputs = [str(v.valueReference) for v in md.modelVariables if v.causality == "input"]
    lib = scara_dir() / "binaries" / "linux64" / "scara.so"
    return [str(driver), "soak", str(lib), md.guid, str(len(md.derivatives)), str(REPEATS), *inputs]


def test_driver_runs_cleanly_without_valgrind(driver):
    proc = subprocess.run(_driver_args(driver), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert f"soak: {REPEATS} repetitions, 0 failures" in proc.stdout


@pytest.mark.valgrind
@pytest.mark.needs("valgrind")
def test_valgrind_reports_no_errors_and_no_leaks(driver):
    proc = subprocess.run([shutil.which("valgrind"), "--leak-check=full", "--show-leak-kinds=definite,indirect,possible",
                           "--errors-for-leak-kinds=definite,indirect,possible", "--error-exitcode=1",
                           *_driver_args(driver)], capture_output=True, text=True, timeout=300)
    report = proc.stderr
    print(report[-1500:])
    assert proc.returncode == 0, report[-3000:]
    assert f"soak: {REPEATS} repetitions, 0 failures" in proc.stdout
    assert re.search(r"ERROR SUMMARY: 0 errors from 0 contexts", report)
    if "All heap blocks were freed -- no leaks are possible" not in report:
        for kind in ("definitely lost", "indirectly lost", "possibly lost"):
            assert re.search(rf"{kind}: 0 bytes in 0 blocks", report), kind
