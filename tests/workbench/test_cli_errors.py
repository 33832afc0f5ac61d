"""The command line's outcomes: expected errors in one line (exit 2), bugs with their traceback, Ctrl-C (exit 130).

Every case runs the real ``manip`` (``python -m workbench.cli``) in a subprocess
where the outcome is the process's: exit status, stderr, files left behind.
Unwritable places are taken from /proc (not writable even by root).
"""

from __future__ import annotations

import importlib
import inspect
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from model.errors import InputError, NumericalError, WorkbenchError
from workbench import cli

from tests.support.process_tree import interruptible

REPO = Path(__file__).resolve().parents[2]
LIBRARY = ("model", "control_design", "closed_loop", "fmu", "workbench")


def _manip(*argv: str, env: dict[str, str] | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "workbench.cli", *argv], cwd=REPO, capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, timeout=timeout)


def _error_classes() -> list[type]:
    """Every exception class defined in the project's packages (warnings excluded)."""
    found = {}
    for pkg in LIBRARY:
        for path in sorted((REPO / pkg).rglob("*.py")):
            parts = list(path.relative_to(REPO).with_suffix("").parts)
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            module = importlib.import_module(name)
            for obj in vars(module).values():
                if (inspect.isclass(obj) and issubclass(obj, BaseException) and not issubclass(obj, Warning)
                        and obj.__module__ == name):
                    found[f"{name}.{obj.__name__}"] = obj
    return sorted(found.items())


def test_every_expected_error_class_is_a_workbench_error():
    classes = _error_classes()
    names = [name for name, _ in classes]
    # negative control: the walk finds the classes of several packages
    for known in ("model.description.RobotDescriptionError", "control_design.errors.SimulationDivergedError",
                  "fmu.build.FmuBuildError", "model.codegen.CompilerNotFoundError", "workbench.args.UsageError"):
        assert known in names
    assert [name for name, cls in classes if not issubclass(cls, WorkbenchError)] == []


def test_a_diverged_simulation_is_numerical_not_bad_input():
    from control_design.errors import DesignSpecError, SimulationDivergedError

    assert issubclass(SimulationDivergedError, NumericalError) and not issubclass(SimulationDivergedError, ValueError)
    assert issubclass(DesignSpecError, InputError) and issubclass(DesignSpecError, ValueError)


@pytest.mark.parametrize("bug", [ValueError("a plain ValueError"), ZeroDivisionError("division by zero")])
def test_a_bug_keeps_its_traceback(monkeypatch, bug):
    """Only WorkbenchError is turned into exit status 2; a builtin error from a bug propagates."""
    def broken(args):
        raise bug

    monkeypatch.setattr("workbench.cmd_model._cmd_robots", broken)
    with pytest.raises(type(bug)):
        cli.main(["robots"])


def test_an_expected_error_is_one_line_and_exit_2(capsys):
    assert cli.main(["info", "no-such-robot"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("manip info: error: robot 'no-such-robot'") and err.count("\n") == 1


def test_version():
    res = _manip("--version")
    assert res.returncode == 0 and res.stdout.startswith("manip ")


#: Heavy packages a command that only reads or lists must not import (start-up: ``manip robots`` and
#: ``manip --help`` in at most 0.3 s; the URDF built-ins are read by model.urdf_xml, without yourdfpy's trimesh).
HEAVY = {"casadi", "control", "matplotlib", "fmpy", "dask", "distributed", "pandas", "viser", "yourdfpy", "trimesh"}


def _imported(*argv: str) -> set[str]:
    res = _manip(*argv, env={"PYTHONPROFILEIMPORTTIME": "1"})
    assert res.returncode == 0, res.stderr
    return {line.split("|")[-1].strip() for line in res.stderr.splitlines() if line.startswith("import time:")}


@pytest.mark.parametrize("argv, heavy", [(["robots"], HEAVY | {"scipy"}), (["--help"], HEAVY | {"scipy"}),
                                         (["info", "scara"], HEAVY | {"scipy"}), (["info", "panda"], HEAVY | {"scipy"}),
                                         (["info", "puma560"], HEAVY | {"scipy"})])
def test_read_only_commands_import_no_heavy_package(argv, heavy):
    """``manip robots``, ``--help`` and ``info`` read descriptions only (asserted on module names, not on time)."""
    imported = _imported(*argv)
    assert "workbench.cmd_model" in imported  # negative control: the import log is read
    assert sorted(imported & heavy) == []


def test_the_import_check_can_fail():
    """Negative control: the symbolic kinematics do import CasADi, and the log shows it."""
    imported = _imported("robots")
    assert "model.urdf_xml" in imported  # the URDF built-ins are read
    res = subprocess.run([sys.executable, "-X", "importtime", "-c", "import model.kinematics"], cwd=REPO,
                         capture_output=True, text=True)
    assert "casadi" in {line.split("|")[-1].strip() for line in res.stderr.splitlines()}


@pytest.mark.parametrize("argv", [
    ["design", "planar2r", "--out", "{bad}"],
    ["track", "planar2r", "--out", "{bad}"],
    ["demo", "--robot", "planar2r", "--no-gif", "--out", "{bad}"],
    ["export-fmu", "planar2r", "-o", "{bad}/planar2r.fmu"],
    ["export-urdf", "planar2r", "-o", "{bad}/planar2r.urdf"],
])
@pytest.mark.parametrize("bad", ["/proc", "/proc/manip-no-such-dir"])
def test_unwritable_output_is_refused_before_any_work(argv, bad):
    argv = [a.replace("{bad}", bad) for a in argv]
    start = time.perf_counter()
    res = _manip(*argv, timeout=120)
    flag = "--out" if "--out" in argv else "--output"
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"manip {argv[0]}: error: {flag}:") and "/proc" in lines[0], lines
    assert "Traceback" not in res.stderr
    del start  # no timing assert: the one line proves no work was reported


@pytest.mark.parametrize("cc", ["/nonexistent", "false"])
def test_no_or_broken_compiler_is_one_line(tmp_path, cc):
    res = _manip("build", "planar2r", "--force", env={"CC": cc, "MANIP_CACHE_DIR": str(tmp_path)})
    assert res.returncode == 2
    errors = [line for line in res.stderr.splitlines() if ": error:" in line]
    assert len(errors) == 1 and errors[0].startswith("manip build: error: ")
    assert "Traceback" not in res.stderr
    assert res.stderr.strip().splitlines()[-1] == errors[0]


def test_unwritable_cache_falls_back_to_a_temporary_one():
    res = _manip("build", "planar2r", env={"MANIP_CACHE_DIR": "/proc/manip-cache"})
    assert res.returncode == 0, res.stderr
    warning = [line for line in res.stderr.splitlines() if line.startswith("manip: warning: cache '/proc/manip-cache'")]
    assert len(warning) == 1 and "temporary cache" in warning[0]
    assert "/proc/manip-cache" not in res.stdout  # the library was built elsewhere


def test_readme_documents_the_cache_folder():
    assert "MANIP_CACHE_DIR" in (REPO / "README.md").read_text()


# track at 4 kHz simulates for about 3 s after its first progress line, so the interrupt lands mid-run
@pytest.mark.parametrize("argv", [["track", "scara", "--rate", "4000"],
                                  pytest.param(["demo", "--robot", "scara", "--no-gif"], marks=pytest.mark.slow)])
def test_ctrl_c_exits_130_and_leaves_no_partial_file(tmp_path, argv):
    out = tmp_path / "out"
    log_out, log_err = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
    with open(log_out, "w") as fo, open(log_err, "w") as fe:
        proc = subprocess.Popen([sys.executable, "-m", "workbench.cli", *argv, "--out", str(out)], cwd=REPO,
                                stdout=fo, stderr=fe, text=True, preexec_fn=interruptible)
        # wait until the command reports work (a progress line), then interrupt it shortly after
        deadline = time.monotonic() + 120
        while (log_out.stat().st_size + log_err.stat().st_size == 0 and time.monotonic() < deadline
               and proc.poll() is None):
            time.sleep(0.1)
        time.sleep(0.3)
        assert proc.poll() is None, log_err.read_text()  # still working when interrupted
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=120)
    err = log_err.read_text()
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == f"manip {argv[0]}: interrupted"
    files = list(out.rglob("*")) if out.exists() else []
    assert [p.name for p in files if ".tmp" in p.name or p.name.startswith(".")] == []
    for path in out.rglob("*.json"):
        json.loads(path.read_text())  # complete, or it would not parse
    for path in out.rglob("*.png"):
        assert path.read_bytes().endswith(b"IEND\xaeB`\x82")  # a PNG ends with its IEND chunk


def test_a_reader_that_leaves_early_is_no_traceback():
    """``manip info ur5 | head -1``: the pipe closes under the command; it stops quietly with 128 + SIGPIPE."""
    proc = subprocess.Popen([sys.executable, "-m", "workbench.cli", "info", "ur5"], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader leaves at once, long before the command (0.3 s of imports) writes
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141, err
    assert "Traceback" not in err
