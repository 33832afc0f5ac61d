"""A singular B(q) in accel and accel_batch is a NumericalError naming the joint and q, never NaN.

The spinner (tests/support/singular_arm.py) has ``B(q) = diag(m d2^2, m + G2^2 Jm2)``
by hand: singular at ``d2 = 0`` only. Before the check, ``accel`` there returned
``[nan, nan]``.
"""

from __future__ import annotations

import numpy as np
import pytest

from model import NumericalError, SingularDynamicsError

from tests.support.singular_arm import SPINNER_MASS, spinner


def test_the_spinner_inertia_is_the_hand_derived_one():
    robot = spinner()
    for d2 in (0.3, -0.2, 0.0):
        B = robot.inertia([0.7, d2])
        np.testing.assert_allclose(B, np.diag([SPINNER_MASS * d2 ** 2, SPINNER_MASS + 1e-4 * 100.0 ** 2]),
                                   rtol=1e-14, atol=1e-15)


def test_accel_at_a_singular_configuration_names_the_joint_and_q():
    robot = spinner()
    assert np.all(np.isfinite(robot.accel([0.1, 0.3], [0.0, 0.0], [1.0, 1.0])))   # negative control
    with pytest.raises(SingularDynamicsError, match=r"spinner: the inertia matrix B\(q\) is singular at joint 1, "
                                                    r"q = \[0\.1, 0\]") as info:
        robot.accel([0.1, 0.0], [0.0, 0.0], [1.0, 1.0])
    assert isinstance(info.value, NumericalError) and isinstance(info.value, ArithmeticError)
    assert info.value.joint == 1 and info.value.q == (0.1, 0.0)


def test_accel_batch_names_the_first_singular_row():
    robot = spinner()
    Q = np.array([[0.1, 0.3], [0.2, -0.1], [0.3, 0.0], [0.4, 0.0]])
    with pytest.raises(SingularDynamicsError, match=r"joint 1, q = \[0\.3, 0\], row 2 of accel_batch"):
        robot.accel_batch(Q, np.zeros_like(Q), np.ones_like(Q))
    good = robot.accel_batch(Q[:2], np.zeros((2, 2)), np.ones((2, 2)))
    assert np.all(np.isfinite(good))


def test_the_error_survives_pickling_with_its_fields():
    import pickle

    err = pickle.loads(pickle.dumps(SingularDynamicsError("x", 2, [0.5, 0.0])))
    assert (str(err), err.joint, err.q) == ("x", 2, (0.5, 0.0))
