"""``manip retime`` and ``manip track --trajectory``: the files they write, the numbers in them, one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from model.joint_table import read_joint_table
from workbench.cli import main

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def retimed(tmp_path_factory):
    out = tmp_path_factory.mktemp("retime")
    assert main(["retime", "scara", "--task", "pick-and-place", "--grid", "300", "--out", str(out)]) == 0
    return out


def test_retime_writes_the_trajectory_json_and_figure(retimed, capsys):
    data = json.loads((retimed / "retime.json").read_text())
    assert data["robot"] == "scara" and data["path"] == "straight" and data["task"] == "pick_and_place"
    assert data["planned_duration_s"] == 15.0 and data["speed_up"] == pytest.approx(15.0 / data["duration_s"])
    assert 3.0 < data["duration_s"] < 4.5  # the seed's 15 s pick-and-place within 90 % of the motor limits
    assert data["grid_check"]["torque"] == pytest.approx(1.0, abs=1e-9)
    assert data["limits"]["torque_margin"] == 0.9 and data["limits"]["velocity"] == [None] * 4
    table = read_joint_table(retimed / "trajectory.csv", ("shoulder", "elbow", "quill", "wrist"), ("q", "qd", "qdd"))
    assert table.t[0] == 0.0 and table.t[-1] == data["file_duration_s"]
    assert data["smooth_s"] == 1e-3 and 0.99 < data["file_torque_use"] < 1.003
    assert np.all(np.diff(table.t) <= 1e-3 * (1 + 1e-12)) and table.t.size == data["samples"]
    assert np.allclose(table["q"][-1], [np.pi / 2, 0.0, 3.0, 0.0], atol=1e-12)  # the place waypoint qD
    assert (retimed / "retime.png").read_bytes()[:8] == PNG_MAGIC


def test_track_follows_the_file_without_saturating(retimed, tmp_path):
    out = tmp_path / "track"
    assert main(["track", "scara", "--controller", "ct", "--trajectory", str(retimed / "trajectory.csv"),
                 "--no-plots", "--out", str(out)]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    retime = json.loads((retimed / "retime.json").read_text())
    assert metrics["task"].endswith("trajectory.csv")
    assert metrics["duration_s"] == pytest.approx(retime["file_duration_s"], abs=1e-3)
    assert retime["file_duration_s"] == pytest.approx(retime["duration_s"] + 5 * 1e-3, rel=1e-12)  # 5 segments
    assert metrics["saturated_fraction"] == [0.0] * 4
    assert metrics["tau_m_max"] == retime["limits"]["tau_m_max"]  # held to the limits it was retimed within


def test_blend_and_flags(tmp_path):
    out = tmp_path / "blend"
    assert main(["retime", "panda", "--blend", "--velocity-limit", "2.0", "--acceleration-limit", "20",
                 "--velocity-scale", "0.5", "--grid", "200", "--no-plots", "--out", str(out)]) == 0
    data = json.loads((out / "retime.json").read_text())
    assert data["path"] == "blend" and data["limits"]["velocity"] == [1.0] * 7
    assert data["limits"]["velocity_source"] == ["given x 0.5"] * 7
    assert max(data["grid_check"]["velocity"], data["grid_check"]["acceleration"],
               data["grid_check"]["torque"]) == pytest.approx(1.0, abs=1e-9)
    assert not (out / "retime.png").exists()


@pytest.mark.parametrize("argv, message", [
    (["--torque-margin", "1.5"], r"--torque-margin: expected a share of the motor torque limits in \(0, 1\], got 1.5"),
    (["--torque-margin", "nan"], r"--torque-margin: expected a share"),
    (["--velocity-limit", "fast"], r"--velocity-limit: expected a number or 4 comma-separated numbers"),
    (["--velocity-limit", "1,2"], r"--velocity-limit: expected 1 or 4 values \(one per joint\), got 2"),
    (["--acceleration-limit", "-3"], r"--acceleration-limit: expected limits > 0"),
    (["--velocity-scale", "0"], r"--velocity-scale: expected a finite factor > 0, got 0.0"),
    (["--dt", "0"], r"--dt: expected a sampling period in \(0, 0.1\] s"),
    (["--smooth", "-1"], r"--smooth: expected a window in \[0, 0.1\] s"),
    (["--task", "dance"], r"task 'dance': robot 'scara' has no such task"),
])
def test_bad_input_is_one_line_and_exit_status_2(tmp_path, capsys, argv, message):
    import re

    out = tmp_path / "bad"
    assert main(["retime", "scara", *argv, "--out", str(out)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and re.search(message, err[0]), err
    assert not out.exists()  # nothing written, not even the folder


def test_a_bad_trajectory_file_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,q_shoulder\n0,0\n1,1\n")
    assert main(["track", "scara", "--controller", "ct", "--trajectory", str(bad), "--out", str(tmp_path / "t")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.csv line 1: missing column" in err[0]
    assert main(["track", "scara", "--trajectory", str(bad), "--segment-time", "2", "--out", str(tmp_path / "t")]) == 2
    assert "--segment-time: a --trajectory file carries its own times" in capsys.readouterr().err


def test_an_infeasible_retime_is_one_line(tmp_path, capsys):
    from model.description import BUILTIN_DIR

    robot = tmp_path / "weak.toml"  # planar2r (vertical, 2 x 50 kg) with 1 N m motors: cannot hold itself

    src = (BUILTIN_DIR / "planar2r.toml").read_text()
    robot.write_text(src.replace("gear_ratio = 100.0", "gear_ratio = 100.0\ntorque_limit = 1.0"))
    assert main(["retime", str(robot), "--out", str(tmp_path / "r")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and "needs" in err[0] and "to hold the arm still there, above its limit 90" in err[0]
