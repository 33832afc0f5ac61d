"""A singular B(q) met in a closed loop is a NumericalError naming the joint and q in every engine.

The spinner (tests/support/singular_arm.py) is singular at ``d2 = 0`` only; a run that
starts there meets it at its first derivative. Before, the Python loop raised a bare
ValueError (non-finite joint values) or a divergence, and the kernel reported a
diverged run, neither naming the cause. The FMU's side is tests/fmu/test_singular_fmu.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from closed_loop import simulate_tracking
from closed_loop.kernel import closed_loop_kernel
from closed_loop.schedule import Schedule
from control_design.controllers import DecentralisedController
from control_design.errors import SimulationDivergedError
from model import SingularDynamicsError, jtraj

from tests.support.singular_arm import spinner

RATE = 1000.0


@pytest.fixture(scope="module")
def setup():
    robot = spinner()
    controller = DecentralisedController("pd", [0.5, 5.0], [0.01, 0.1], 0.0, robot.gear_ratio, RATE)
    return robot, controller


def test_python_loop_from_a_singular_start_names_the_joint(setup):
    robot, controller = setup
    traj = jtraj([0.0, 0.0], [0.5, 0.2], T=1.0, dt=0.01)
    with pytest.raises(SingularDynamicsError, match=r"singular at joint 1, q = \[0, 0\], in the plant's fixed-step"):
        simulate_tracking(robot, controller, traj, substeps=1)      # the rule meets it at its first derivative
    with pytest.raises(SingularDynamicsError, match=r"singular at joint 1, q = \[0, 0\], at the start of the closed"):
        simulate_tracking(robot, controller, traj)                  # the default sub-steps look at B(q0) first
    away = jtraj([0.0, 0.3], [0.5, 0.2], T=1.0, dt=0.01)        # negative control: off the singularity it runs
    assert np.all(np.isfinite(simulate_tracking(robot, controller, away).q))


def test_kernel_from_a_singular_start_names_the_joint_and_time(setup):
    robot, controller = setup
    traj = jtraj([0.0, 0.0], [0.5, 0.2], T=1.0, dt=0.01)
    sched = Schedule.build(robot, traj, controller.dt, substeps=1)
    kernel = closed_loop_kernel(robot, "pd")
    with pytest.raises(SingularDynamicsError, match=r"singular at joint 1, q = \[0, 0\], in the compiled closed loop, "
                                                    r"in the period from t = 0 s"):
        kernel.run(controller, sched, robot.parameters)
    away = Schedule.build(robot, jtraj([0.0, 0.3], [0.5, 0.2], T=1.0, dt=0.01), controller.dt)
    run = kernel.run(controller, away, robot.parameters)
    assert not run.diverged and np.all(np.isfinite(run.max_error))


def test_a_diverging_loop_is_still_a_divergence_not_a_singularity(setup):
    robot, controller = setup
    wild = DecentralisedController("pd", [-5e4, -5e4], [0.0, 0.0], 0.0, robot.gear_ratio, RATE)
    traj = jtraj([0.0, 0.3], [0.5, 0.2], T=1.0, dt=0.01)
    with pytest.raises(SimulationDivergedError):
        simulate_tracking(robot, wild, traj)
