"""Our dynamics (reflected motor model, compiled) against Pinocchio and the Robotics Toolbox.

Tolerance: 1e-10 relative to the largest reference value (at least 1): both
sides compute the same quantities in double precision through O(100)
operations, so they may differ by ~1e-14 relative; 1e-10 leaves room for
cancellation while still catching any wrong term (a missing armature, a
misplaced inertia or a wrong sign is >= 1e-3 relative on these states).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from model import InertiaConsistencyWarning, load_robot
from tests.support.references import available_robots, friction_reference, pinocchio_model, rtb_robot, symmetric_from_upper

import pinocchio as pin  # a mandatory reference: a missing Pinocchio fails, never skips

RTOL = 1e-10
ROBOTS = available_robots()


def close(actual, expected, rtol=RTOL):
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * scale)


@pytest.fixture(scope="module", params=ROBOTS)
def setup(request):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        robot = load_robot(request.param)
    model = pinocchio_model(robot.description)
    return robot, model, model.createData()


def states(n, seed, count=5):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-2.0, 2.0, (3, n)) for _ in range(count)]


def test_fkine_matches_pinocchio(setup):
    robot, model, data = setup
    for q, _, _ in states(robot.n, 1):
        pin.framesForwardKinematics(model, data, q)
        close(robot.fkine(q), data.oMf[model.getFrameId("tool")].homogeneous)


def test_rigid_body_terms_match_pinocchio(setup):
    robot, model, data = setup
    robot = robot.with_parameters(robot.parameters.with_friction(np.zeros(robot.n), np.zeros(robot.n),
                                                                 np.zeros(robot.n)))
    for q, qd, qdd in states(robot.n, 2):
        close(robot.inertia(q), symmetric_from_upper(pin.crba(model, data, q)))
        g = pin.computeGeneralizedGravity(model, data, q)
        close(robot.gravload(q), g)
        C = robot.coriolis(q, qd)
        close(C @ qd, pin.nonLinearEffects(model, data, q, qd) - g)
        close(C, pin.computeCoriolisMatrix(model, data, q, qd))
        tau = pin.rnea(model, data, q, qd, qdd)
        close(robot.rne(q, qd, qdd), tau)
        close(robot.accel(q, qd, tau), pin.aba(model, data, q, qd, tau))


def test_rne_and_accel_include_friction(setup):
    robot, model, data = setup
    for q, qd, qdd in states(robot.n, 3):
        F = friction_reference(robot.description, qd)
        close(robot.friction(qd), F)
        tau = pin.rnea(model, data, q, qd, qdd) + F
        close(robot.rne(q, qd, qdd), tau)
        close(robot.accel(q, qd, tau), pin.aba(model, data, q, qd, tau - F))
        close(robot.accel(q, qd, tau), qdd, rtol=1e-9)


def test_batch_matches_single_calls(setup):
    robot, _, _ = setup
    rng = np.random.default_rng(4)
    Q, QD, QDD = rng.uniform(-2, 2, (3, 7, robot.n))
    TAU = robot.rne_batch(Q, QD, QDD)
    assert TAU.shape == (7, robot.n)
    for k in range(7):
        close(TAU[k], robot.rne(Q[k], QD[k], QDD[k]))
    close(robot.accel_batch(Q, QD, TAU), QDD, rtol=1e-9)


def test_friction_is_minus_rtb_link_friction(setup):
    robot, _, _ = setup
    rtb_links = rtb_robot(robot.description).links
    for qd in (*[s[1] for s in states(robot.n, 5)], np.zeros(robot.n)):
        expected = -np.array([link.friction(v) for link, v in zip(rtb_links, qd)])
        close(robot.friction(qd), expected)


def test_rne_matches_robotics_toolbox(setup):
    robot, _, _ = setup
    rtb = rtb_robot(robot.description)
    for q, qd, qdd in states(robot.n, 6):
        close(robot.rne(q, qd, qdd), rtb.rne(q, qd, qdd))


def test_shape_errors_name_the_argument(setup):
    robot, _, _ = setup
    n = robot.n
    with pytest.raises(ValueError, match=r"^qd: expected"):
        robot.dynamics.rne(np.zeros(n), np.zeros(n + 1), np.zeros(n))
    with pytest.raises(ValueError, match=r"^QDD: expected an \(N, "):
        robot.rne_batch(np.zeros((3, n)), np.zeros((3, n)), np.zeros((3, n + 1)))
    with pytest.raises(ValueError, match=r"^TAU: expected 3 rows"):
        robot.accel_batch(np.zeros((3, n)), np.zeros((3, n)), np.zeros((2, n)))
