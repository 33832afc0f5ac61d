"""The workbench's policy constants, pinned by value with their reason, and the rules built on them.

A test that imports a constant and recomputes the expectation from it survives any change of the
constant; these tests state the numbers, so changing a policy is a visible, deliberate edit here.
"""

from __future__ import annotations

import math

import pytest

from closed_loop.schedule import MAX_SUBSTEP, default_substeps
from control_design.decentralised import DEFAULT_BANDWIDTH, DEFAULT_DAMPING, DEFAULT_INTEGRAL_RATIO
from control_design.design import DEFAULT_RATE_HZ, design_robot
from control_design.joint_model import DEFAULT_SAMPLES, DEFAULT_SEED, TORQUE_LIMIT_FACTOR
from control_design.loops import MIN_RATE_PER_BANDWIDTH_HZ
from model.description import description_from_dict
from model.robot import Robot


def test_design_defaults():
    # the seed's design point: 50 rad/s, damping 0.7 (4.6 % overshoot), 1 kHz (20x the bandwidth in Hz)
    assert (DEFAULT_BANDWIDTH, DEFAULT_DAMPING, DEFAULT_RATE_HZ) == (50.0, 0.7, 1000.0)
    # the PID's real pole at 1 x wn: the three poles of a critically spaced third-order design
    assert DEFAULT_INTEGRAL_RATIO == 1.0
    # ZOH at 10 x the bandwidth in Hz costs ~18 deg of phase margin: the lowest rate still worth designing for
    assert MIN_RATE_PER_BANDWIDTH_HZ == 10.0
    # 256 seeded workspace samples bound the effective inertia to within a few % on the built-ins
    assert (DEFAULT_SAMPLES, DEFAULT_SEED) == (256, 0)
    # the default torque limit: twice what the reference task needs at the worst workspace inertia
    assert TORQUE_LIMIT_FACTOR == 2.0


def test_the_default_design_uses_the_stated_damping():
    robot = Robot(description_from_dict(_ONE_JOINT))
    design = design_robot(robot, "pd")
    assert design.damping == 0.7 and [loop.damping for loop in design.loops] == [0.7]


# One revolute joint about z: B = Izz + G^2 Jm exactly (the mass sits on the axis), so the
# friction eigenvalue of the sub-step rule is lambda = G^2 B_m / B in closed form.
_IZZ, _JM, _G = 0.05, 1e-4, 10.0
_ONE_JOINT = {"name": "one", "links": [{"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0,
                                          "mass": 1.0, "inertia": [0.05, 0.05, _IZZ, 0.0, 0.0, 0.0],
                                          "motor_inertia": _JM, "gear_ratio": _G, "viscous_friction": 0.0}]}


def _robot(viscous: float) -> Robot:
    data = {**_ONE_JOINT, "links": [{**_ONE_JOINT["links"][0], "viscous_friction": viscous}]}
    return Robot(description_from_dict(data))


def test_substep_rule_pinned():
    # h <= 1 ms and h * lambda <= 0.5 (RK4 is stable to |h lambda| < 2.78: a margin of 5.6)
    assert MAX_SUBSTEP == 1e-3
    B = _IZZ + _G ** 2 * _JM
    assert default_substeps(_robot(0.0), 1e-3, [0.0]) == 1
    assert default_substeps(_robot(0.0), 1e-2, [0.0]) == 10
    B_m = 3.2 * 0.5 * B / (_G ** 2 * 1e-3)  # lambda dt / 0.5 = 3.2 at dt = 1 ms -> 4 sub-steps
    assert default_substeps(_robot(B_m), 1e-3, [0.0]) == math.ceil(3.2) == 4
    B_m = 2.0 * 0.5 * B / (_G ** 2 * 1e-3)  # exactly 2.0 (to rounding): 2 sub-steps, not 3
    assert default_substeps(_robot(B_m), 1e-3, [0.0]) == 2


@pytest.mark.parametrize("dt, expected", [(1e-3, 1), (2e-3, 2), (2.5e-3, 3)])
def test_substeps_follow_the_1ms_ceiling(dt, expected):
    assert default_substeps(_robot(0.0), dt, [0.0]) == expected


def test_retime_defaults():
    from model.retime import DEFAULT_GRID, DEFAULT_SAMPLE_STEP, DEFAULT_SMOOTH, DEFAULT_TORQUE_MARGIN
    from model.retime.result import JUMP_STEP
    from model.retime.path import MIN_SEGMENT_INTERVALS
    from model.retime.solver import REFINE_RTOL
    from model.trajectory_file import CONSISTENCY_TOL, VELOCITY_RTOL

    # 10 % of each motor's torque left to the tracking loop: computed torque at 50 rad/s, 1 kHz needs ~7 %
    # of a switch (Kd h) once the switches are averaged over one period
    assert DEFAULT_TORQUE_MARGIN == 0.9
    # 1000 grid intervals: durations within 0.1 % of 2000's on the built-ins, a tenth of a second per retime
    assert (DEFAULT_GRID, MIN_SEGMENT_INTERVALS) == (1000, 8)
    # samples every 1 ms, the law averaged over one period of the default 1 kHz control rate
    assert (DEFAULT_SAMPLE_STEP, DEFAULT_SMOOTH) == (1e-3, 1e-3)
    # a jump between two samples 1 us apart: far below any control period, far above rounding of hours
    assert JUMP_STEP == 1e-6
    # refinement stops below 1e-7: the viscous lines then cost < 1e-7 against the exact problem
    assert REFINE_RTOL == 1e-7
    # a trajectory file's q, qd, qdd agree to 1 % of the joint's peak speed per interval (deg instead of rad: 5700 %)
    assert CONSISTENCY_TOL == 0.01
    # a sample on its speed limit, rounded (the retime's file slows a segment the 1 ms average would take past it)
    assert VELOCITY_RTOL == 1e-9
