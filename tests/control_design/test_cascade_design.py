"""The cascade's elastic joint model (control_design.cascade_design) against the plant's own linearisation.

Reference: the exact Jacobian of the whole nonlinear plant (model.linearise, CasADi) of a one-link elastic joint,
``u -> qd_m``: its frequency response must be the two-mass transfer function written by hand, to 1e-9 relative
(rounding of two different evaluations); a 1 % error in the stiffness moves the resonance and fails it.
"""

from __future__ import annotations

import math

import control
import numpy as np

from control_design.cascade_design import bode_figure, cascade_loops, motor_speed_tf
from model.description import description_from_dict
from model.robot import Robot, load_robot


def _one_link(c: float, d: float) -> Robot:
    link = {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "mass": 1.0,
            "inertia": [1.0, 1.0, 2.0, 0.0, 0.0, 0.0], "motor_inertia": 0.01, "gear_ratio": 10.0,
            "gear_stiffness": c, "gear_damping": d}
    return Robot(description_from_dict({"name": "flex1", "gravity": [0.0, 0.0, 0.0], "links": [link]}))


def test_two_mass_transfer_function_is_the_plants_linearisation():
    c, d = 50.0, 0.02
    robot = _one_link(c, d)
    C = np.array([[0.0, 0.0, 0.0, 1.0]])  # states q, qd, q_m, qd_m: the rotor speed
    lin = robot.linearise([0.0], outputs=C)
    w = np.logspace(0, 3, 50)
    full = np.array([complex(control.evalfr(lin, 1j * x)[0, 0]) if np.ndim(control.evalfr(lin, 1j * x)) else
                     complex(control.evalfr(lin, 1j * x)) for x in w])
    mine = motor_speed_tf(0.01, 2.0, 10.0, c, d)(1j * w)
    assert np.max(np.abs(mine - full) / np.abs(full)) < 1e-9
    off = motor_speed_tf(0.01, 2.0, 10.0, 1.01 * c, d)(1j * w)
    assert np.max(np.abs(off - full) / np.abs(full)) > 1e-2  # negative control
    # the resonance: the plant's oscillatory eigenvalue (undamped part) at w_r = sqrt(c (1/Jm + G^2/Jl))
    wr = math.sqrt(c * (1 / 0.01 + 100.0 / 2.0))
    eig = np.linalg.eigvals(_one_link(c, 0.0).linearise([0.0]).A)
    assert np.isclose(np.abs(eig).max(), wr, rtol=1e-9)


def test_r3_cascade_margins_and_resonances():
    loops = cascade_loops(load_robot("manutec_r3"))
    assert [round(c.resonance) for c in loops[:3]] == [198, 104, 234]
    for c in loops:
        gm, pm, _, wcp = c.margins["speed"]
        assert pm > 60 and gm > 5  # the MSL gains are stable with margin on the elastic model
        assert c.margins["position"][1] > 85  # the outer P loop is nearly an integrator at kp = 5 1/s
    # the elastic gear moves axis 2's speed-loop crossover far from the rigid model's (461 vs 195 rad/s)
    assert loops[1].margins["speed"][3] > 2 * loops[1].margins_rigid["speed"][3]
    assert bode_figure(loops).axes


def test_a_rigid_model_pd_verified_on_the_elastic_r3():
    """The decentralised PD designed on the rigid joint model (5 rad/s, 1 kHz) is stable on it, but closed around
    axis 1's elastic gear it is not (non-collocated: it measures G q behind the spring); the nonlinear elastic
    plant agrees: axis 1's motor sits at its torque limit for much of the run, the other axes' not at all."""
    from closed_loop.simulate import simulate_tracking
    from control_design.cascade_design import check_on_elastic
    from control_design.design import design_robot
    from model.tasks import robot_tasks

    robot = load_robot("manutec_r3")
    design = design_robot(robot, "pd", 5.0, 0.7, rate_hz=1000.0, analyse=False)
    checks = check_on_elastic(robot, design)
    assert all(c.stable_rigid for c in checks)
    assert [c.stable_elastic for c in checks] == [False, True, True, True, True, True]
    res = simulate_tracking(robot, design.controller(1000.0), robot_tasks(robot.description)["ptp"].trajectory(1e-3))
    saturated = res.metrics().saturated_fraction
    assert saturated[0] > 0.2 and np.all(saturated[1:] < 0.05), saturated
