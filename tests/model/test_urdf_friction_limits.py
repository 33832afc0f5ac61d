"""What a URDF states survives: its joint friction when loaded, our limits and friction when exported.

The reference is Pinocchio reading the same file (``buildModelFromUrdf``: ``model.damping``,
``model.friction``, ``model.effortLimit``, ``model.velocityLimit``), which no one here wrote.

* Loading: ``<dynamics damping friction>`` is joint-side friction; the model's coefficients are motor side
  (joint friction ``G^2 B qd + |G| Tc sign(qd)``), so a robot file that adds gear ratios must not change the
  joint friction. Tolerance: one unit in the last place of the URDF's value (the motor-side double nearest to
  ``D / G^2`` reflects to D or its neighbour), exact for G = 1.
* Exporting: ``<limit effort velocity>`` carries ``|G| torque_limit`` and ``velocity_limit`` exactly (one
  multiplication, written with repr), and ``<dynamics>`` the joint friction; a limit the robot does not state is
  the largest double ("no limit"), never the 0 that ROS and Gazebo read as a joint that cannot move.
"""

from __future__ import annotations

import sys

import numpy as np
import pinocchio as pin
import pytest

from model.description import FROM_DEFAULT, FROM_FILE, FROM_URDF, description_from_dict
from model.loading import load_description
from model.robot import Robot
from model.urdf import NO_LIMIT
from model.urdf_export import export_urdf, urdf_text
from workbench.formatting import format_info

#: (type, damping, friction, (lower, upper, effort, velocity)) of the test arm's joints: a xarm7-like damping of
#: 10 N m s/rad on the first, none on the second, a prismatic third with both.
JOINTS = [("revolute", 10.0, 0.3, (-2.0, 2.0, 50.0, 3.14)),
          ("revolute", 0.5, 0.0, (-1.5, 1.0, 30.0, 2.5)),
          ("prismatic", 2.5, 1.2, (0.0, 0.4, 200.0, 0.75))]


def _link(name: str, mass: float = 1.0) -> str:
    return (f'<link name="{name}"><inertial><origin xyz="0.05 0 0.1"/><mass value="{mass}"/>'
            f'<inertia ixx="0.02" iyy="0.03" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>')


def arm_urdf(tmp_path, joints=JOINTS) -> str:
    """A 3-joint URDF with damping, friction, effort and velocity limits on its joints."""
    parts = [_link("base"), *(_link(f"l{i + 1}", 1.0 + i) for i in range(len(joints)))]
    for i, (kind, damping, friction, (lo, hi, effort, velocity)) in enumerate(joints):
        axis = "0 0 1" if i != 1 else "0 1 0"
        parent = "base" if i == 0 else f"l{i}"
        parts.append(f'<joint name="j{i + 1}" type="{kind}"><parent link="{parent}"/><child link="l{i + 1}"/>'
                     f'<origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="{axis}"/>'
                     f'<limit lower="{lo}" upper="{hi}" effort="{effort}" velocity="{velocity}"/>'
                     f'<dynamics damping="{damping}" friction="{friction}"/></joint>')
    path = tmp_path / "arm.urdf"
    path.write_text('<?xml version="1.0"?>\n<robot name="arm">' + "".join(parts) + "</robot>\n")
    return str(path)


def _joint_friction(desc) -> tuple[np.ndarray, np.ndarray]:
    """The model's joint-side viscous and Coulomb coefficients, as model.dynamics.motors reflects them."""
    G = np.array([lk.gear_ratio for lk in desc.links])
    B = np.array([lk.viscous_friction for lk in desc.links])
    Tc = np.array([lk.coulomb_friction[0] for lk in desc.links])
    return G * G * B, np.abs(G) * Tc


def _within_one_ulp(ours, reference):
    ours, reference = np.asarray(ours, dtype=float), np.asarray(reference, dtype=float)
    assert np.all(np.abs(ours - reference) <= np.spacing(np.abs(reference))), (ours.tolist(), reference.tolist())


def test_a_bare_urdf_keeps_its_damping_and_friction_as_pinocchio_reads_them(tmp_path):
    path = arm_urdf(tmp_path)
    ref = pin.buildModelFromUrdf(path)
    desc = load_description(path)
    viscous, coulomb = _joint_friction(desc)
    np.testing.assert_array_equal(viscous, ref.damping)  # G = 1: exact
    np.testing.assert_array_equal(coulomb, ref.friction)
    assert [desc.friction_source(i) for i in range(3)] == [(FROM_URDF, FROM_URDF), (FROM_URDF, FROM_DEFAULT),
                                                           (FROM_URDF, FROM_URDF)]
    # the compiled model's F(qd) is Pinocchio's damping qd + friction sign(qd)
    qd = np.array([0.7, -1.3, 0.2])
    np.testing.assert_allclose(Robot(desc).friction(qd), ref.damping * qd + ref.friction * np.sign(qd), rtol=1e-15)
    # the velocity limits are read too, as Pinocchio reads them
    np.testing.assert_array_equal([lk.velocity_limit for lk in desc.links], ref.velocityLimit)


def test_a_robot_file_adding_motor_data_keeps_the_urdf_joint_friction(tmp_path):
    """Today's bug: a TOML adding motor data dropped the URDF's damping (xarm7: 10 N m s/rad became 0)."""
    path = arm_urdf(tmp_path)
    ref = pin.buildModelFromUrdf(path)
    toml = tmp_path / "arm.toml"
    toml.write_text(f'name = "arm"\nurdf = "{path}"\n'
                    '[joints.j1]\nmotor_inertia = 3e-4\ngear_ratio = 101.0\n'
                    '[joints.j2]\ngear_ratio = -50.5\ntorque_limit = 0.4\n'
                    '[joints.j3]\ngear_ratio = 7.3\n')
    desc = load_description(toml)
    assert [lk.gear_ratio for lk in desc.links] == [101.0, -50.5, 7.3]
    viscous, coulomb = _joint_friction(desc)
    _within_one_ulp(viscous, ref.damping)
    _within_one_ulp(coulomb, ref.friction)
    assert desc.links[0].viscous_friction == pytest.approx(10.0 / 101.0 ** 2, rel=1e-15)  # the motor side
    assert desc.links[2].coulomb_friction == pytest.approx((1.2 / 7.3, -1.2 / 7.3), rel=1e-15)
    # negative control: read as motor-side numbers, the URDF's values would be G^2 and |G| times too large
    assert not np.allclose(np.array([101.0, -50.5, 7.3]) ** 2 * ref.damping, ref.damping)


def test_friction_the_robot_file_states_wins_and_info_says_where_each_value_comes_from(tmp_path):
    path = arm_urdf(tmp_path)
    toml = tmp_path / "arm.toml"
    toml.write_text(f'name = "arm"\nurdf = "{path}"\n[joints.j2]\ngear_ratio = 2.0\nviscous_friction = 0.01\n')
    desc = load_description(toml)
    assert desc.links[1].viscous_friction == 0.01 and desc.friction_source(1) == (FROM_FILE, FROM_DEFAULT)
    assert desc.friction_source(0) == (FROM_URDF, FROM_URDF)
    text = format_info(desc)
    table = text[text.index("Joint friction"):]
    rows = [line.split() for line in table.splitlines()[2:5]]
    assert [(row[1], row[3], row[-1]) for row in rows] == [("j1", "URDF", "URDF"), ("j2", "robot", "default"),
                                                           ("j3", "URDF", "URDF")], table
    # a DH robot: the file's keys, else the default
    dh = description_from_dict({"name": "x", "links": [
        {"joint": "revolute", "a": 1.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "viscous_friction": 0.1},
        {"joint": "revolute", "a": 1.0, "alpha": 0.0, "d": 0.0, "theta": 0.0}]})
    assert [dh.friction_source(i) for i in range(2)] == [(FROM_FILE, FROM_DEFAULT), (FROM_DEFAULT, FROM_DEFAULT)]


def test_a_bad_urdf_dynamics_value_is_refused_naming_the_joint(tmp_path):
    from model.description import RobotDescriptionError

    path = arm_urdf(tmp_path, [("revolute", -1.0, 0.0, (-1.0, 1.0, 1.0, 1.0))])
    with pytest.raises(RobotDescriptionError, match=r"joint 'j1': <dynamics damping='?-1.0'?>: expected a finite number >= 0"):
        load_description(path)


# ------------------------------------------------------------------ export


@pytest.fixture
def limited_arm():
    """A DH arm with gear ratios, motor friction, torque limits on joints 1 and 3 and velocity limits on 1 and 2."""
    link = {"joint": "revolute", "a": 0.4, "alpha": 0.0, "d": 0.1, "theta": 0.0, "mass": 2.0, "com": [-0.2, 0, 0],
            "inertia": [0.01, 0.03, 0.03, 0, 0, 0], "qlim": [-2.0, 2.0]}
    return description_from_dict({
        "name": "limited", "description": "a test arm -- with limits", "source": "made up for this test",
        "links": [{**link, "gear_ratio": 80.0, "viscous_friction": 1e-4, "coulomb_friction": 0.05,
                   "torque_limit": 0.9, "velocity_limit": 3.5},
                  {**link, "gear_ratio": -60.0, "velocity_limit": 2.0},
                  {**link, "joint": "prismatic", "qlim": [0.0, 0.3], "gear_ratio": 1000.0, "torque_limit": 0.25}]})


def test_pinocchio_reads_the_exported_limits_and_friction(tmp_path, limited_arm):
    path = tmp_path / "limited.urdf"
    export_urdf(limited_arm, path)
    ref = pin.buildModelFromUrdf(str(path))
    assert ref.effortLimit.tolist() == [80.0 * 0.9, sys.float_info.max, 1000.0 * 0.25]
    assert ref.velocityLimit.tolist() == [3.5, 2.0, sys.float_info.max]
    viscous, coulomb = _joint_friction(limited_arm)
    np.testing.assert_array_equal(ref.damping, viscous)
    np.testing.assert_array_equal(ref.friction, coulomb)
    text = path.read_text()
    assert 'effort="0.0"' not in text and 'velocity="0.0"' not in text
    assert "a test arm - - with limits" in text and "made up for this test" in text  # the comment, "--" escaped
    # read back bare: the stated velocity limits come back, "no limit" reads as none
    back = load_description(path)
    assert [lk.velocity_limit for lk in back.links] == [3.5, 2.0, None]
    assert NO_LIMIT == sys.float_info.max


def test_the_urdf_and_toml_round_trip_keeps_limits_friction_description_and_source(tmp_path, limited_arm):
    urdf, toml = tmp_path / "limited.urdf", tmp_path / "limited.toml"
    export_urdf(limited_arm, urdf, toml)
    back = load_description(toml)
    assert (back.description, back.source) == (limited_arm.description, limited_arm.source)
    for mine, theirs in zip(limited_arm.links, back.links):
        assert (theirs.torque_limit, theirs.velocity_limit, theirs.gear_ratio, theirs.viscous_friction,
                theirs.coulomb_friction) == (mine.torque_limit, mine.velocity_limit, mine.gear_ratio,
                                             mine.viscous_friction, mine.coulomb_friction)
    assert back.digest() == load_description(toml).digest()


def test_a_joint_without_limits_is_never_written_as_one_that_cannot_move():
    """Negative control of the export: the built-in SCARA states no velocity limits and no torque limits."""
    text = urdf_text(load_description("scara"))
    assert 'effort="0.0"' not in text and 'velocity="0.0"' not in text
    assert f'velocity="{sys.float_info.max!r}"' in text or "1.7976931348623157e+308" in text
