"""No hidden state: a Robot is a constant model and one immutable parameter value.

Making other parameter values (and evaluating with them, through the same
compiled model and workspaces) must leave a Robot's numbers bit for bit as
they were; the other values must change the numbers (negative control).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from model import InertiaConsistencyWarning, load_robot
from model.dynamics import Dynamics


def _robot(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot(name)


def _numbers(robot, q, qd, qdd, ws=None):
    return {
        "inertia": robot.inertia(q, ws=ws), "coriolis": robot.coriolis(q, qd, ws=ws),
        "gravload": robot.gravload(q, ws=ws), "friction": robot.friction(qd, ws=ws),
        "rne": robot.rne(q, qd, qdd, ws=ws), "accel": robot.accel(q, qd, qdd, ws=ws),
        "rne_batch": robot.rne_batch(np.tile(q, (2, 1)), np.tile(qd, (2, 1)), np.tile(qdd, (2, 1))),
    }


@pytest.mark.parametrize("name", ["scara", "puma560"])
def test_a_robots_numbers_do_not_change_after_making_other_parameters(name):
    robot = _robot(name)
    n = robot.n
    rng = np.random.default_rng(51)
    q, qd, qdd = rng.uniform(-2, 2, (3, n))
    before = _numbers(robot, q, qd, qdd)

    other_p = (robot.parameters.with_payload(3.0, (0.01, 0.0, 0.05), (0.01, 0.01, 0.02, 0, 0, 0))
               .with_friction(viscous=np.full(n, 0.5), coulomb_pos=np.full(n, 0.2), coulomb_neg=np.full(n, -0.3))
               .with_gravity([0.0, 9.81, 0.0]))
    other = robot.with_parameters(other_p)
    assert other.dynamics is robot.dynamics  # one compiled model, two parameter values
    ws = robot.dynamics.workspace()
    changed = _numbers(other, q, qd, qdd)
    changed_ws = _numbers(other, q, qd, qdd, ws)  # the explicit workspace now holds the other value's binding
    for key in before:
        assert np.abs(changed[key] - before[key]).max() > 1e-6, key
        np.testing.assert_array_equal(changed_ws[key], changed[key])

    after = _numbers(robot, q, qd, qdd)
    after_ws = _numbers(robot, q, qd, qdd, ws)
    for key in before:
        np.testing.assert_array_equal(after[key], before[key])
        np.testing.assert_array_equal(after_ws[key], before[key])
    # A parameter value can also be passed per call, leaving the robot's own untouched.
    np.testing.assert_array_equal(robot.rne(q, qd, qdd, other_p), changed["rne"])
    np.testing.assert_array_equal(robot.rne(q, qd, qdd), before["rne"])
    # A fresh model of the same description gives the same numbers: nothing was left behind.
    fresh = Dynamics(robot.description)
    np.testing.assert_array_equal(fresh.rne(q, qd, qdd), before["rne"])
    np.testing.assert_array_equal(fresh.accel(q, qd, qdd), before["accel"])


def test_parameter_values_are_immutable_and_compare_by_value():
    robot = _robot("planar2r")
    p = robot.parameters
    loaded = p.with_payload(1.0)
    assert p.payload_mass == 0.0 and loaded.payload_mass == 1.0
    assert loaded == p.with_payload(1.0) and loaded != p
    with pytest.raises(ValueError, match="read-only"):
        p.vector[0] = 2.0
    with pytest.raises(AttributeError):
        p.vector = np.zeros(p.layout.size)  # type: ignore[misc]
    assert robot.with_parameters(loaded).parameters is loaded and robot.parameters is p


def test_a_workspace_of_another_library_is_refused():
    a, b = _robot("planar2r"), _robot("scara")
    ws = b.dynamics.workspace()
    with pytest.raises(ValueError, match="ws: expected a workspace of this model"):
        a.rne(np.zeros(2), np.zeros(2), np.zeros(2), ws=ws)
