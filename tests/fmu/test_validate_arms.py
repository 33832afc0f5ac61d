"""``validate-fmu`` with default settings on arms other than the SCARA it was first tuned on.

The Puma 560 and a 7-joint standard-DH arm written here (an iiwa-like
geometry with made-up but plausible masses). Tolerances are relative to each
arm's motion and the horizon ends where its open loop diverges, so the same
defaults hold for all; the FMU alone (its ``resources/robot.json``) is enough
to validate it, and it names no path of the machine that built it.
"""

from __future__ import annotations

import os
import warnings
import zipfile
from functools import lru_cache
from pathlib import Path

import pytest

import fmu
from fmu.validate import DIVERGENCE_GAIN, TOLERANCES, validate_fmu
from model import InertiaConsistencyWarning

from tests.support.fmu_support import build_root, puma_fmu

ARM7_TOML = """
name = "arm7"
description = "7-joint standard-DH arm (iiwa-like geometry), test fixture of tests/fmu/test_validate_arms.py"
source = "made up for the test: plausible masses and inertias, not a real robot"
rest = [0.0, 0.3, 0.0, -0.6, 0.0, 0.4, 0.0]
"""
# (d, alpha, mass, com, inertia) per link; a = 0 and theta = 0 throughout
_ARM7_LINKS = [
    (0.34, -1.5707963267948966, 4.0, [0.0, -0.03, 0.12], [0.1, 0.09, 0.02]),
    (0.0, 1.5707963267948966, 4.0, [0.0, 0.06, 0.03], [0.05, 0.018, 0.044]),
    (0.40, 1.5707963267948966, 3.0, [0.0, 0.03, 0.13], [0.08, 0.075, 0.01]),
    (0.0, -1.5707963267948966, 2.7, [0.0, -0.07, 0.034], [0.03, 0.01, 0.029]),
    (0.40, -1.5707963267948966, 1.7, [0.0, -0.02, 0.076], [0.02, 0.018, 0.005]),
    (0.0, 1.5707963267948966, 1.8, [0.0, 0.0, 0.0], [0.005, 0.0036, 0.0047]),
    (0.126, 0.0, 0.3, [0.0, 0.0, 0.02], [0.001, 0.001, 0.001]),
]


def arm7_toml() -> str:
    text = ARM7_TOML
    for i, (d, alpha, mass, com, inertia) in enumerate(_ARM7_LINKS):
        text += (f"\n[[links]]\nname = \"j{i + 1}\"\njoint = \"revolute\"\na = 0.0\nalpha = {alpha!r}\nd = {d!r}\n"
                 f"theta = 0.0\nmass = {mass}\ncom = {com}\ninertia = [{inertia[0]}, {inertia[1]}, {inertia[2]}, "
                 f"0.0, 0.0, 0.0]\nmotor_inertia = 2e-5\ngear_ratio = 100.0\nviscous_friction = 2e-5\n"
                 f"qlim = [-2.9, 2.9]\n")
    return text


@lru_cache(maxsize=None)
def arm7_fmu() -> tuple[Path, Path]:
    """The 7-joint arm's FMU, built from a TOML file in its own folder; returns (fmu, toml)."""
    folder = build_root() / "arm7_source"
    folder.mkdir(exist_ok=True)
    toml = folder / "arm7.toml"
    toml.write_text(arm7_toml())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        path = fmu.export_fmu(str(toml), build_root() / "arm7.fmu")
    return path, toml


def _assert_valid(report) -> None:
    text = report.format()
    print(text)
    assert report.ok, report.problems()
    names = {c.name for c in report.checks}
    assert {"Co-Simulation q", "Co-Simulation qd", "Co-Simulation tool", "Model Exchange q", "Model Exchange qd",
            "Model Exchange tool", "FMU state round trips", "directional derivatives"} <= names
    assert all(c.passed for c in report.checks)
    # every check is printed with its figure and bound
    assert text.count("bound ") >= len(report.checks)
    assert report.horizon is not None and report.horizon >= 0.2   # long enough to say something
    assert report.errors[0].q_scale > 1e-3                       # the arm did move


def test_validate_the_puma_560_with_default_settings():
    _assert_valid(validate_fmu(puma_fmu(), with_cosim=False))


@pytest.mark.slow
def test_validate_a_7_joint_arm_from_the_fmu_alone(capsys):
    from workbench.cli import main

    path, toml = arm7_fmu()
    moved = toml.with_suffix(".gone")
    toml.rename(moved)                                 # the TOML is no longer where it was built from
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", InertiaConsistencyWarning)
            report = validate_fmu(path, with_cosim=False)
            _assert_valid(report)
            assert report.robot == ("arm7", "reflected")
            assert main(["validate-fmu", str(path), "--no-cosim"]) == 0
    finally:
        moved.rename(toml)
    out = capsys.readouterr().out
    assert "ok   Model Exchange qd:" in out and "result: OK" in out


@pytest.mark.slow
def test_the_fmu_names_no_path_of_the_build_machine():
    path, toml = arm7_fmu()
    forbidden = {str(toml.parent), str(toml.parent.resolve()), os.getcwd(), str(Path(fmu.__file__).resolve().parents[1]),
                 "/tmp/mw_fmu_"}
    with zipfile.ZipFile(path) as zf:
        assert "resources/robot.json" in zf.namelist()
        for name in zf.namelist():
            data = zf.read(name)
            for text in forbidden:
                assert text.encode() not in data, f"{name} contains {text}"


@pytest.mark.slow
def test_an_edited_robot_resource_is_refused(tmp_path):
    """The embedded description must match the digest recorded at export: an edited resource is not used."""
    path, _ = arm7_fmu()
    edited = tmp_path / "edited.fmu"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(edited, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "resources/robot.json":
                data = data.replace(b'"mass": 4.0', b'"mass": 4.5', 1)
            dst.writestr(item, data)
    report = validate_fmu(edited, with_cosim=False)
    assert report.robot_skipped is not None and "modified description" in report.robot_skipped
    # only the FMU's own FMI-LS-REF experiment is replayed: it needs no robot, the comparisons with one are skipped
    assert [c.name for c in report.checks] == ["FMI-LS-REF replay"]


def test_the_tolerances_are_relative_and_stated():
    # the ME bound: 1e3 x CVode's rtol x the divergence gain the horizon allows
    assert TOLERANCES["me"] == pytest.approx(1e3 * 1e-10 * DIVERGENCE_GAIN)
    assert TOLERANCES["cs_floor"] < TOLERANCES["me"]
