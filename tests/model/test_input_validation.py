"""Bad input, as a user meets it: every problem of a robot file at once, misspelt keys, files that are
directories or binary, CSVs that are not comma-separated, flags named as typed, bounded sample counts.

CLI items run the real ``manip`` (``python -m workbench.cli``) in a subprocess: exit status 2, one
complete line per problem on stderr, no traceback.
"""

from __future__ import annotations

import argparse
import math
import os
import pickle
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from model.description import RobotDescriptionError, description_from_dict, rpy_matrix, tr2rpy
from model.errors import InputError, closest
from model.limits import MAX_SAMPLES
from model.loading import load_description
from model.tasks import WaypointError, load_waypoints
from model.trajectory import SampleLimitError, time_grid
from workbench.args import FLAG_OF, in_flag_terms

ROOT = Path(__file__).resolve().parents[2]

LINK = 'joint = "revolute"\na = 0.5\nalpha = 0.0\nd = 0.0\ntheta = 0.0\nqlim = [-2.0, 2.0]\n'
#: Three independent mistakes, each in a place of its own: a misspelt required key in link 1,
#: a negative mass in link 2, a gravity of two components.
MISTAKES = {
    "alpah": ("[[links]]\n" + LINK.replace("alpha", "alpah"), "link 1: field 'alpha' = None"),
    "mass": ("[[links]]\n" + LINK + "mass = -2.0\n", "link 2: field 'mass' = -2.0: expected a number >= 0"),
    "gravity": ("gravity = [0.0, -9.81]\n", "field 'gravity' = [0.0, -9.81]: expected a list of 3 numbers"),
}


def manip(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, "-m", "workbench.cli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300, check=False)


def refused_lines(proc: subprocess.CompletedProcess, command: str) -> list[str]:
    """The stderr lines of a refused run (exit 2, no traceback), each ``manip COMMAND: error: ...``."""
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert lines and all(line.startswith(f"manip {command}: error: ") for line in lines), proc.stderr
    return [line.removeprefix(f"manip {command}: error: ") for line in lines]


def _robot_file(tmp_path: Path, *mistakes: str, name: str = "arm.toml") -> Path:
    """A two-link robot file holding the named mistakes of :data:`MISTAKES` (none: a valid file)."""
    parts = {key: text for key, (text, _) in MISTAKES.items() if key in mistakes}
    text = 'name = "arm"\n' + parts.get("gravity", "")
    text += parts.get("alpah", "[[links]]\n" + LINK)
    text += parts.get("mass", "[[links]]\n" + LINK)
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------ every problem of a robot file


def test_a_file_with_three_mistakes_reports_all_three_through_manip_info(tmp_path):
    path = _robot_file(tmp_path, *MISTAKES)
    lines = refused_lines(manip("info", str(path)), "info")
    assert lines[0] == f"{path}: 3 problems"
    assert len(lines) == 4
    for line in lines[1:]:
        assert line.startswith(str(path)), line  # each line a complete message: the file first
    for _, fragment in MISTAKES.values():
        assert sum(fragment in line for line in lines[1:]) == 1, (fragment, lines)


def test_the_collected_problems_are_the_messages_each_mistake_gives_alone(tmp_path):
    alone = []
    for key in MISTAKES:
        with pytest.raises(RobotDescriptionError) as info:
            load_description(_robot_file(tmp_path, key, name=f"{key}.toml").rename(tmp_path / "arm.toml"))
        assert len(info.value.problems) == 1 and "\n" not in str(info.value)
        alone.append(str(info.value))
    with pytest.raises(RobotDescriptionError) as info:
        load_description(_robot_file(tmp_path, *MISTAKES))
    assert sorted(info.value.problems) == sorted(alone)
    assert str(info.value).splitlines() == [f"{tmp_path / 'arm.toml'}: 3 problems", *info.value.problems]


def test_one_mistake_is_still_one_line(tmp_path):
    """Negative control of the count line: a single problem prints as before, one line, no count."""
    path = _robot_file(tmp_path, "mass")
    assert refused_lines(manip("info", str(path)), "info") == [
        f"{path}, link 2: field 'mass' = -2.0: expected a number >= 0"]


def test_problems_survive_pickling_to_a_worker_and_back(tmp_path):
    with pytest.raises(RobotDescriptionError) as info:
        load_description(_robot_file(tmp_path, *MISTAKES))
    again = pickle.loads(pickle.dumps(info.value))
    assert type(again) is RobotDescriptionError and again.problems == info.value.problems and str(again) == str(info.value)


def test_problems_of_links_and_tasks_are_collected_and_a_bad_document_stops_early():
    links = [{"joint": "hinge", "a": 0, "alpha": 0, "d": 0, "theta": 0},
             {"joint": "revolute", "a": "x", "alpha": 0, "d": 0, "theta": 0, "qlim": [1.0, -1.0]}]
    tasks = [{"name": "t", "waypoints": [[0.0, 0.0], [0.1]], "segment_time": -1.0}]
    with pytest.raises(RobotDescriptionError) as info:
        description_from_dict({"name": "", "links": links, "tasks": tasks, "units": {"length": "mm"}}, "x.toml")
    fields = [re.search(r"field '([^']+)'", p).group(1) for p in info.value.problems]
    assert fields == ["name", "joint", "a", "qlim", "units.length", "tasks[1].waypoints[2]", "tasks[1].segment_time"]
    with pytest.raises(RobotDescriptionError) as info:
        description_from_dict(["not", "a", "table"], "x.toml")  # nothing further can be checked
    assert info.value.problems == ("x.toml: field '<document>' = ['not', 'a', 'table']: expected a TOML table",)


def test_a_urdf_robot_file_collects_its_problems_too(tmp_path):
    (tmp_path / "arm.urdf").write_text(
        '<robot name="a"><link name="b"/><link name="l1"/><link name="l2"/>'
        '<joint name="j1" type="revolute"><parent link="b"/><child link="l1"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    path = tmp_path / "arm.toml"
    path.write_text('name = "a"\nurdf = "arm.urdf"\ngravty = [0.0, 0.0, -9.81]\n'
                    '[joints.j1]\ngear_ratio = 0.0\n[joints.j2]\nmotor_inertia = -1.0\n')
    with pytest.raises(RobotDescriptionError) as info:
        load_description(path)
    assert [p.removeprefix(f"{path}") for p in info.value.problems] == [
        ": field 'gravty' = [0.0, 0.0, -9.81]: expected one of the known keys of a URDF robot file (name, urdf, "
        "base_link, tip_link, joints, gravity, rest, description, source, units, tasks, base, tool, cascade); this key is "
        "unknown; did you mean 'gravity'?",
        ", joint 'j1': field 'gear_ratio' = 0.0: expected a non-zero number",
        ", joint 'j2': field 'motor_inertia' = -1.0: expected a number >= 0",
    ]


# ------------------------------------------------------------------ misspelt keys


def test_a_misspelt_required_key_is_named_with_the_key_it_misses_through_manip(tmp_path):
    path = _robot_file(tmp_path, "alpah")
    assert refused_lines(manip("info", str(path)), "info") == [
        f"{path}, link 1: field 'alpha' = None: expected this required key (it is missing; the file has "
        "'alpah' = 0.0: did you mean 'alpha'?)"]


@pytest.mark.parametrize(("key", "hint"), [("mas", "; did you mean 'mass'?"), ("viscous_fricton", "; did you mean "
                                           "'viscous_friction'?"), ("owner", "")])
def test_an_unknown_key_suggests_the_closest_known_one_or_none(key, hint):
    link = {"joint": "revolute", "a": 0, "alpha": 0, "d": 0, "theta": 0, key: 1.0}
    with pytest.raises(RobotDescriptionError) as info:
        description_from_dict({"name": "x", "links": [link]}, "x.toml")
    assert str(info.value).endswith(f"this key is unknown{hint}")


def test_a_misspelt_pose_task_and_waypoint_key_get_a_suggestion(tmp_path):
    link = {"joint": "revolute", "a": 0, "alpha": 0, "d": 0, "theta": 0}
    with pytest.raises(RobotDescriptionError) as info:
        description_from_dict({"name": "x", "links": [link], "base": {"xzy": [0, 0, 1]},
                               "tasks": [{"name": "t", "waypoint": [[0.0], [1.0]]}]}, "x.toml")
    messages = "\n".join(info.value.problems)
    assert "field 'base.xzy' = [0, 0, 1]: expected one of the known keys (xyz, rpy); this key is unknown; did you " \
           "mean 'xyz'?" in messages
    assert "field 'tasks[1].waypoints' = None: expected this required key (it is missing; the file has " \
           "'tasks[1].waypoint' = [[0.0], [1.0]]: did you mean 'tasks[1].waypoints'?)" in messages
    (tmp_path / "w.toml").write_text("waypionts = [[0, 0, 0, 0], [0.1, 0, 0, 0]]\n")
    with pytest.raises(WaypointError, match=re.escape("unknown key 'waypionts'; expected one of waypoints, "
                                                      "segment_time, description, labels; did you mean 'waypoints'?")):
        load_waypoints(tmp_path / "w.toml")


def test_closest_is_difflib_with_its_default_cutoff():
    assert closest("alpah", ["a", "alpha", "d", "theta"]) == "alpha"
    assert closest("owner", ["a", "alpha", "d", "theta"]) is None
    assert closest("x", []) is None


# ------------------------------------------------------------------ directories and binary files


@pytest.mark.parametrize(("command", "make"), [
    (["info"], "robot.toml"),
    (["info"], "robot.urdf"),
    (["export-urdf", "-o", "OUT/x.urdf"], "robot.urdf"),
    (["track", "scara", "--out", "OUT", "--waypoints"], "w.csv"),
    (["track", "scara", "--out", "OUT", "--waypoints"], "w.toml"),
])
def test_a_directory_is_named_as_a_directory(tmp_path, command, make):
    folder = tmp_path / make
    folder.mkdir()
    argv = [a.replace("OUT", str(tmp_path / "out")) for a in command] + [str(folder)]
    if command[0] == "export-urdf":
        argv = [command[0], str(folder), *argv[1:-1]]
    [line] = refused_lines(manip(*argv), command[0])
    assert line.startswith(f"{folder}: is a directory: expected a "), line


def test_a_urdf_key_naming_a_directory_says_so(tmp_path):
    (tmp_path / "arm.urdf").mkdir()
    path = tmp_path / "arm.toml"
    path.write_text('name = "a"\nurdf = "arm.urdf"\n')
    with pytest.raises(RobotDescriptionError, match=re.escape(f"{tmp_path / 'arm.urdf'} is a directory")):
        load_description(path)


@pytest.mark.parametrize(("command", "name", "fragment"), [
    (["info"], "robot.toml", "not UTF-8 text (byte 0): a TOML file is UTF-8"),
    (["info"], "robot.urdf", "not well-formed XML"),
    (["track", "scara", "--out", "OUT", "--waypoints"], "w.csv", "not UTF-8 text (byte 0): expected a CSV file of numbers"),
    (["track", "scara", "--out", "OUT", "--waypoints"], "w.toml", "not UTF-8 text (byte 0): a TOML file is UTF-8"),
])
def test_a_binary_file_is_named(tmp_path, command, name, fragment):
    """Every reader names the file of undecodable bytes (a regression guard: these already did)."""
    path = tmp_path / name
    path.write_bytes(bytes(range(128, 256)) + bytes(range(0, 128)))
    argv = [a.replace("OUT", str(tmp_path / "out")) for a in command] + [str(path)]
    [line] = refused_lines(manip(*argv), command[0])
    assert line.startswith(f"{path}: {fragment}"), line


# ------------------------------------------------------------------ CSV delimiters


@pytest.mark.parametrize(("text", "name"), [
    ("q1;q2;q3;q4\n0;0;0;0\n0.1;0.1;0.1;0.1\n", "';' (semicolons)"),
    ("0;0;0;0\n0.1;0.1;0.1;0.1\n", "';' (semicolons)"),
    ("0,5;0;0;0\n0,1;0,1;0,1;0,1\n", "';' (semicolons)"),
    ("0\t0\t0\t0\n0.1\t0.1\t0.1\t0.1\n", "tabs"),
    ("0 0 0 0\n0.1 0.1 0.1 0.1\n", "spaces"),
])
def test_a_csv_not_separated_by_commas_is_refused_naming_its_delimiter(tmp_path, text, name):
    path = tmp_path / "w.csv"
    path.write_text(text)
    with pytest.raises(WaypointError, match="^" + re.escape(f"{path} line 1: values separated by {name}: expected "
                                                            "comma-separated values")):
        load_waypoints(path)


def test_manip_track_refuses_a_semicolon_csv_instead_of_dropping_its_first_row(tmp_path):
    """Before, the first row ``0;0;0;0`` read as one text cell, was taken for a header and dropped."""
    path = tmp_path / "w.csv"
    path.write_text("0;0;0;0\n0.1;0.1;0.1;0.1\n0.2;0.1;0.1;0.1\n")
    [line] = refused_lines(manip("track", "scara", "--waypoints", str(path), "--out", str(tmp_path / "out")), "track")
    assert line.startswith(f"{path} line 1: values separated by ';' (semicolons): expected comma-separated values"), line
    assert not (tmp_path / "out").exists()


def test_a_comma_csv_keeps_every_row_and_skips_only_a_header_of_names(tmp_path):
    path = tmp_path / "w.csv"
    path.write_text("# a comment\nq1, q2, q3, q4\n0.0,\t0.0, 0.0, 0.0\n0.1, 0.1, 0.1, 0.1\n0.2, 0.1, 0.1, 0.1\n")
    np.testing.assert_array_equal(load_waypoints(path).waypoints[:, 0], [0.0, 0.1, 0.2])
    path.write_text("0.0, 0.0, 0.0, 0.0\n0.1, 0.1, 0.1, 0.1\n")
    assert load_waypoints(path).waypoints.shape == (2, 4)


# ------------------------------------------------------------------ flags as typed


@pytest.mark.parametrize(("argv", "flag", "internal"), [
    (["--mass-scale", "0"], "--mass-scale: expected a factor > 0, got 0.0", "link_mass_scale"),
    (["--friction-scale", "-1"], "--friction-scale: expected a finite value >= 0", "friction_scale"),
    (["--phase-margin", "100"], "--phase-margin: expected a phase margin in [5, 90) deg, got 100.0", "phase_margin"),
    (["--bandwidth", "-1"], "--bandwidth: expected a positive number of rad/s, got -1.0", " bandwidth:"),
    (["--segment-time", "1e-6"], "the task's duration (--segment-time): expected at least one control period", "t_final"),
])
def test_a_track_error_names_the_flag_the_user_typed(tmp_path, argv, flag, internal):
    [line] = refused_lines(manip("track", "scara", *argv, "--out", str(tmp_path / "out")), "track")
    assert line.startswith(flag) and internal not in line, line


def test_the_flag_table_names_real_flags_and_only_those_of_the_running_command():
    from workbench.cli import build_parser

    parser = build_parser()
    options = {opt for action in parser._subparsers._group_actions for sub in action.choices.values()
               for a in sub._actions for opt in a.option_strings}
    for name, flag in FLAG_OF.items():
        assert re.search(r"--[\w-]+", flag).group(0) in options, (name, flag)
    t_end = InputError("expected a whole number", parameter="t_end")
    assert in_flag_terms(t_end, argparse.Namespace(horizon=3.0)) == "--horizon: expected a whole number"
    assert in_flag_terms(t_end, argparse.Namespace(rate=1.0)) == "t_end: expected a whole number"
    assert in_flag_terms(InputError("/x/bandwidth: bad"), argparse.Namespace(bandwidth=1.0)) == "/x/bandwidth: bad"
    # the field, not the text: a message that merely starts with a parameter's name is left as it is
    assert in_flag_terms(InputError("bandwidth: bad"), argparse.Namespace(bandwidth=1.0)) == "bandwidth: bad"


# ------------------------------------------------------------------ bounded sample counts


def test_a_huge_segment_time_is_refused_naming_the_flag_value_and_limit(tmp_path):
    [line] = refused_lines(manip("track", "scara", "--segment-time", "1e9", "--out", str(tmp_path / "out")), "track")
    assert line.startswith("--segment-time: 1e+09 s per segment, 5 segments: "), line
    assert f"more than the sample limit of {MAX_SAMPLES}" in line and "MemoryError" not in line
    assert not (tmp_path / "out").exists()


def test_time_grid_and_schedule_refuse_more_samples_than_the_limit():
    from closed_loop.schedule import Schedule
    from model.robot import load_robot
    from model.trajectory import jtraj

    assert time_grid((MAX_SAMPLES - 1) * 1e-3, 1e-3).size == MAX_SAMPLES  # the limit itself passes
    with pytest.raises(SampleLimitError, match=f"more than the sample limit of {MAX_SAMPLES}"):
        time_grid(MAX_SAMPLES * 1e-3, 1e-3)
    robot = load_robot("planar2r")
    traj = jtraj([0.0, 0.0], [0.1, 0.1], 1e4, dt=10.0)  # 1001 samples of a 10,000 s path
    with pytest.raises(InputError, match=rf"t_final: 10000 s at 1000 Hz: 1e\+07 control instants, more than the "
                                         f"sample limit of {MAX_SAMPLES}"):
        Schedule.build(robot, traj, 1e-3)


# ------------------------------------------------------------------ roll-pitch-yaw


def _rotations(seed: int, count: int) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.random(count, random_state=seed).as_matrix()


def test_tr2rpy_matches_scipy_and_spatialmath_away_from_gimbal_lock():
    """Two independent implementations of the same convention (R = Rz(y) Ry(p) Rx(r)); 1e-12 rad:
    a few ulps of atan2 on entries of rounding error 1e-16, far from the lock where both are well-conditioned."""
    from scipy.spatial.transform import Rotation
    from spatialmath.base import tr2rpy as sm_tr2rpy

    for R in _rotations(3, 200):
        rpy = tr2rpy(R)
        np.testing.assert_allclose(rpy, Rotation.from_matrix(R).as_euler("xyz"), atol=1e-12)
        np.testing.assert_allclose(rpy, sm_tr2rpy(R, order="zyx"), atol=1e-12)
        np.testing.assert_allclose(rpy_matrix(rpy), R, atol=1e-14)


@pytest.mark.parametrize("pitch", [math.pi / 2, -math.pi / 2, 1.57079632679, math.pi / 2 - 1e-9, -math.pi / 2 + 1e-13])
def test_tr2rpy_at_and_near_gimbal_lock_reproduces_the_rotation_without_a_warning(pitch):
    """At the lock the convention is yaw = 0. The rotation is reproduced to 1e-14 (rounding of a few products
    of unit-size entries) near the lock, where roll and yaw alone are ill-conditioned, and to 1e-14 + 2 cos(pitch)
    where yaw = 0 is imposed (the part of the rotation the convention drops)."""
    rng = np.random.default_rng(11)
    for roll, yaw in rng.uniform(-math.pi, math.pi, size=(50, 2)):
        R = rpy_matrix([roll, pitch, yaw])
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rpy = tr2rpy(R)
        locked = math.hypot(R[0, 0], R[1, 0]) <= 1e-12
        np.testing.assert_allclose(rpy_matrix(rpy), R, atol=1e-14 + (2 * math.cos(pitch) if locked else 0.0))
        assert abs(rpy[1] - pitch) < 1e-7
        if locked:
            assert rpy[2] == 0.0
            # only roll -+ yaw is defined at the lock: roll carries it
            expected = roll - yaw if pitch > 0 else roll + yaw
            assert abs(math.remainder(rpy[0] - expected, 2 * math.pi)) < 1e-12


def test_manip_info_of_a_urdf_robot_at_gimbal_lock_warns_nothing(tmp_path):
    (tmp_path / "lock.urdf").write_text(
        '<robot name="lock"><link name="b"/><link name="l1"/>'
        '<joint name="j1" type="revolute"><parent link="b"/><child link="l1"/><axis xyz="0 0 1"/>'
        '<origin xyz="0 0 0.1" rpy="0.3 1.5707963267948966 0.2"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    env = {**os.environ, "PYTHONWARNINGS": "error", "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "workbench.cli", "info", str(tmp_path / "lock.urdf")], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    row = next(line for line in proc.stdout.splitlines() if line.split()[:3] == ["1", "j1", "revolute"])
    # rpy (0.3, pi/2, 0.2) is at the lock: roll - yaw = 0.1 rad = 5.72958 deg, yaw 0
    assert "[5.72958, 90, 0]" in row, row


def test_a_long_unknown_key_message_keeps_its_suggestion_on_the_cli_line(tmp_path):
    """The CLI's line limit (400 characters, for compiler output) would cut the suggestion after the key list."""
    from workbench.cli import error_lines

    link = {"joint": "revolute", "a": 0, "alpha": 0, "d": 0, "theta": 0, "viscous_fricton": 1.0}
    with pytest.raises(RobotDescriptionError) as info:
        description_from_dict({"name": "x", "links": [link]}, str(tmp_path / ("x" * 150) / "arm.toml"))
    [line] = error_lines(info.value)
    assert len(line) > 400 and line.endswith("did you mean 'viscous_friction'?")


def test_a_design_whose_sampled_loop_is_unstable_is_one_line_not_a_traceback(tmp_path):
    """A phase margin of 89 deg at 50 rad/s gives the SCARA's PD loop a gain that its 1 kHz sampled loop cannot
    hold (decay rate -606 1/s); the analysis used to end in a ValueError traceback."""
    [line] = refused_lines(manip("design", "scara", "--phase-margin", "89", "--out", str(tmp_path / "out")), "design")
    assert re.fullmatch(r"joint \w+: the sampled \(1000 Hz\) closed loop of this pd design is not asymptotically "
                        r"stable \(slowest decay rate -[\d.e+]+ 1/s\): expected targets the loop can meet .*", line), line
    assert not (tmp_path / "out").exists()


def test_a_huge_validation_horizon_is_refused_naming_the_flag_before_the_fmu_is_opened(tmp_path):
    [line] = refused_lines(manip("validate-fmu", str(tmp_path / "none.fmu"), "--horizon", "1e9"), "validate-fmu")
    assert line == f"--horizon: 1e+09 s at a step of 0.001 s: 1e+12 samples, more than the sample limit of {MAX_SAMPLES}"


def test_a_misspelt_builtin_robot_name_gets_a_suggestion_and_a_missing_path_none():
    with pytest.raises(RobotDescriptionError, match=r"robot 'scaara': .*; no such file; did you mean 'scara'\?$"):
        load_description("scaara")
    with pytest.raises(RobotDescriptionError, match=r"robot 'robots/scaara.toml': .*; no such file$"):
        load_description("robots/scaara.toml")


def test_the_bad_values_of_a_urdf_chain_are_collected(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(
        '<robot name="a"><link name="b"/>'
        '<link name="l1"><inertial><mass value="-1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>'
        '</inertial></link><link name="l2"/>'
        '<joint name="j1" type="revolute"><parent link="b"/><child link="l1"/><axis xyz="0 0 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><axis xyz="0 0 1"/>'
        '<limit lower="1" upper="-1" effort="1" velocity="1"/></joint></robot>')
    with pytest.raises(RobotDescriptionError) as info:
        load_description(path)
    assert [p.removeprefix(f"{path}, ") for p in info.value.problems] == [
        "joint 'j1': axis [0.0, 0.0, 0.0]: expected a non-zero axis xyz",
        "link 'l1': <inertial> mass -1.0: expected a finite mass >= 0 and a finite inertia",
        "joint 'j2': <limit lower=1.0 upper=-1.0>: expected finite lower <= upper",
    ]
