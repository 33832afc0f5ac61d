"""The Manutec r3 (Modelica's RobotR3.fullRobot) under its P-PI cascade against Dymola's result (issue 23).

Reference: Dymola 2019 FD01's ``fullRobot_ref.csv`` (FMI cross-check; ``model/robots/manutec_r3_dymola.csv``), link-side
speeds of the six axes, 0..1 s. The workbench's run: ``manutec_r3``'s drive trains in the one plant (the
Python loop, the C fixed-step rule), the cascade sampled at the robot file's 20 kHz, the ``ptp`` task.

Pass rules (the issue's): every axis within 1 % of its range at each reference time outside +-2 ms of a friction
event; every break-away within 0.5 ms of the reference's; ``fmpy.cross_check.validate_result`` passing. Measured
here: worst 0.022 % of range (axis 6), link-side break-aways 0.033-0.039 ms after Dymola's, rotor break-aways
within 0.05-0.07 ms (the 0.05 ms control period bounds how finely a sampled run can see one).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from closed_loop.simulate import simulate_tracking
from control_design.cascade import cascade_from_robot
from model.robot import Robot, load_robot
from model.tasks import robot_tasks
from tests.support import robotr3 as R3

fmpy_cross_check = pytest.importorskip("fmpy.cross_check")


def _run(robot: Robot):
    controller = cascade_from_robot(robot)
    traj = robot_tasks(robot.description)["ptp"].trajectory(controller.dt)
    return simulate_tracking(robot, controller, traj, t_final=1.0)


def _perturbed(robot: Robot, joint: int, **fields: float) -> Robot:
    desc = robot.description
    links = list(desc.links)
    links[joint] = dataclasses.replace(links[joint], **fields)
    return Robot(dataclasses.replace(desc, links=tuple(links)))


@pytest.fixture(scope="module")
def r3() -> Robot:
    return load_robot("manutec_r3")


@pytest.fixture(scope="module")
def run(r3):
    return _run(r3)


def test_speeds_within_one_percent_of_range(run):
    cmp = R3.compare(run.t, run.qd)
    assert np.all(cmp.worst < 0.01), cmp.worst
    assert np.all(cmp.worst < 1e-3), cmp.worst  # what it reaches (0.022 % at most): a regression shows at once


def test_breakaways_within_half_a_millisecond(run):
    cmp = R3.compare(run.t, run.qd)
    assert np.all(np.abs(cmp.breakaway[3:]) < 5e-4), cmp.breakaway
    for j in range(3):  # the rotors of the elastic axes, motor-side friction
        t_first = run.t[np.flatnonzero(run.rotor_qd[:, j] != 0.0)[0]]
        assert abs(t_first - R3.ROTOR_BREAKAWAY[j]) < 5e-4, (j + 1, t_first)


def test_fmpy_cross_check_passes(run):
    result = R3.as_result(run.t, run.qd)
    assert fmpy_cross_check.validate_result(result, R3.reference(), 0.0, 1.0) is None
    # the check can fail: axis 2 at 70 % of its speed leaves the band (10 % of the range) for most of the run
    bad = result.copy()
    bad["axis2_w"] *= 0.7
    assert "axis2_w" in (fmpy_cross_check.validate_result(bad, R3.reference(), 0.0, 1.0) or "")


@pytest.mark.parametrize("joint, fields, axis", [
    (1, {"gear_stiffness": 4.0}, 1),      # axis 2's gear half as stiff: its speed off by 9.8 % of its range
    (0, {"motor_inertia": 0.0026}, 0),    # axis 1's rotor twice as heavy: 1.7 %
])
def test_negative_control_a_perturbed_drive_train_fails(r3, joint, fields, axis):
    cmp = R3.compare(*(lambda res: (res.t, res.qd))(_run(_perturbed(r3, joint, **fields))))
    assert cmp.worst[axis] > 0.01, cmp.worst


def test_negative_control_the_peak_moves_the_breakaway(r3, run):
    """Without axis 5's break-away peak (39.6/30.1) the joint leaves rest 0.4 ms earlier than with it."""
    res = _run(_perturbed(r3, 4, friction_peak=1.0))
    shift = R3.compare(res.t, res.qd).breakaway[4] - R3.compare(run.t, run.qd).breakaway[4]
    assert shift < -3e-4, shift
