"""The ``manip`` command line: ``robots``, ``info`` and the one-line error with exit status 2."""

from __future__ import annotations

import pytest

from model.description import BUILTIN_ROBOTS
from workbench.cli import main

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")


def test_robots_lists_every_builtin(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].split()[:3] == ["robot", "joints", "types"]
    listed = [line.split()[0] for line in lines[1:] if line.strip()]
    assert listed == list(BUILTIN_ROBOTS)
    assert lines[1].split()[:4] == ["scara", "4", "RRPR", "SCARA"]


def test_info_scara_prints_the_dh_table_with_units_and_the_motor_data(capsys):
    assert main(["info", "scara"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    for heading in ("a [m]", "alpha [rad]", "alpha [deg]", "d [m]", "theta [rad]", "m [kg]", "com [m]",
                    "Jm [kg m^2]", "B [N m s/rad]", "gravity [m/s^2]", "tau_max [N m]"):
        assert heading in out, heading
    dh = [line.split() for line in lines if line.split()[:3] in (["1", "shoulder", "revolute"], ["2", "elbow", "revolute"],
                                                                 ["3", "quill", "prismatic"], ["4", "wrist", "revolute"])]
    assert [row[3:8] for row in dh] == [
        ["2.0", "0.0", "0", "0.0", "0.0"],
        ["2.0", "3.141592653589793", "180", "0.0", "0.0"],
        ["0.0", "0.0", "0", "0.0", "0.0"],
        ["0.0", "0.0", "0", "0.0", "0.0"],
    ]
    motor_header = lines.index(next(line for line in lines if "Jm [kg m^2]" in line))
    motors = [line.split() for line in lines[motor_header + 1: motor_header + 5]]
    assert [row[3] for row in motors] == ["-62.6111", "107.815", "-53.7063", "76.0364"]
    assert [row[2] for row in motors] == ["0.0002", "0.0002", "0.0002", "3.3e-05"]
    assert "[0.0, 3.5]" in out  # the prismatic joint's limits, as in the file (m)


def test_unknown_robot_is_a_one_line_error_with_status_2(capsys):
    assert main(["info", "no_such_robot"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err_lines = captured.err.strip().splitlines()
    assert len(err_lines) == 1
    assert err_lines[0].startswith("manip info: error: robot 'no_such_robot': expected a built-in name")
    assert "Traceback" not in captured.err


def test_bad_robot_file_is_a_one_line_error_with_status_2(tmp_path, capsys):
    path = tmp_path / "broken.toml"
    path.write_text('name = "broken"\n[[links]]\njoint = "revolute"\na = 1.0\nalpha = 0.0\nd = 0.0\ntheta = 0.0\ngear_ratio = 0.0\n')
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"manip info: error: {path}, link 1: field 'gear_ratio' = 0.0: expected a non-zero number"]


def test_build_reports_a_cold_build_then_a_cache_hit(capsys):
    assert main(["build", "planar2r", "--force"]) == 0
    cold = capsys.readouterr().out
    assert "planar2r (reflected motors): cold build in " in cold and "-Werror" in cold
    assert main(["build", "planar2r"]) == 0
    assert "loaded from the cache in " in capsys.readouterr().out
