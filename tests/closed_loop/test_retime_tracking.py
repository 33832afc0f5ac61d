"""Computed-torque tracking of retimed motions on the nonlinear plant, motor limits on (the issue's "done").

The retime keeps every torque within ``0.9`` of the motor limits the design and ``manip track`` use (the robot
file's ``torque_limit`` or the default rule); the tracking loop then has 10 % left for its feedback. The
motion goes through its trajectory CSV and is read back as ``manip track --trajectory`` reads it.
"""

from __future__ import annotations

import numpy as np
import pytest

from model.retime import retime
from tests.support.topp_references import builtin as _robot
from tests.support.topp_references import design_limits as _limits
from tests.support.topp_references import reference_waypoints as _waypoints


@pytest.mark.parametrize("blend", [False, True], ids=["straight", "blend"])
@pytest.mark.parametrize("name", ["scara", "puma560", "panda", "ur5"])
def test_computed_torque_tracks_the_retimed_csv_without_saturating(name, blend, tmp_path):
    from closed_loop.simulate import simulate_tracking
    from control_design import design_robot
    from model.trajectory_file import read_trajectory, write_trajectory

    robot = _robot(name)
    motion = retime(robot, _waypoints(robot), _limits(robot, torque_margin=0.9), blend=blend)
    path = write_trajectory(tmp_path / "trajectory.csv", motion.trajectory(), robot.description.joint_names)
    traj = read_trajectory(path, robot.description)  # as manip track --trajectory reads it
    design = design_robot(robot, "ct", analyse=False)
    assert np.allclose(design.tau_m_max, motion.limits.tau_m_max, rtol=0, atol=0)  # tracked within the same limits
    met = simulate_tracking(robot, design.controller(1000.0), traj).metrics()
    assert np.all(met.saturated_fraction == 0.0)
    assert np.max(met.peak_motor_torque / design.tau_m_max) > 0.9  # the motion does use the motors


def test_without_a_torque_margin_the_tracking_loop_saturates():
    """Negative control: retimed at 100 % of the limits, the feedback has no room and the motors saturate."""
    from closed_loop.simulate import simulate_tracking
    from control_design import design_robot

    robot = _robot("scara")
    motion = retime(robot, _waypoints(robot), _limits(robot, torque_margin=1.0))
    design = design_robot(robot, "ct", analyse=False)
    met = simulate_tracking(robot, design.controller(1000.0), motion.trajectory()).metrics()
    assert np.max(met.saturated_fraction) > 0.0
