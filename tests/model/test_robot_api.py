"""The Robot facade's toolbox-style accessors: links and payload.

Tolerance: the payload's gravity torque against ``-J_v^T m g`` computed here from ``jacob0``
(a physical invariant, not our dynamics code): 1e-10 N m on torques of ~10-100 N m, rounding
~1e-13; a payload in the wrong frame or with the wrong sign misses by O(1) N m.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from model import load_robot
from model.dynamics import Payload

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")


def test_links_are_the_description_links_read_only():
    robot = load_robot("puma560")
    assert robot.links is robot.description.links and len(robot.links) == robot.n
    assert robot.links[1].a == pytest.approx(0.4318)  # the Puma's upper arm, m
    with pytest.raises(dataclasses.FrozenInstanceError):
        robot.links[1].a = 1.0  # type: ignore[misc]
    with pytest.raises(AttributeError):
        robot.links = ()  # type: ignore[misc]


def test_payload_reads_the_parameters_and_with_payload_makes_a_new_robot():
    robot = load_robot("puma560")
    assert robot.payload.mass == 0.0 and np.all(robot.payload.com == 0) and np.all(robot.payload.inertia == 0)
    loaded = robot.with_payload(2.5, [0.01, -0.02, 0.1], [0.01, 0.02, 0.03, 0.001, 0.002, 0.003])
    pl = loaded.payload
    assert isinstance(pl, Payload) and pl.mass == 2.5 and pl.com.tolist() == [0.01, -0.02, 0.1]
    np.testing.assert_array_equal(pl.inertia, [[0.01, 0.001, 0.003], [0.001, 0.02, 0.002], [0.003, 0.002, 0.03]])
    np.testing.assert_array_equal(pl.inertia6, [0.01, 0.02, 0.03, 0.001, 0.002, 0.003])
    assert robot.payload.mass == 0.0  # unchanged
    assert loaded.parameters == robot.parameters.with_payload(2.5, [0.01, -0.02, 0.1], pl.inertia6)
    with pytest.raises(ValueError):
        pl.com[0] = 1.0  # read-only


def test_point_payload_gravity_is_the_jacobian_transpose_of_its_weight():
    robot = load_robot("puma560")
    assert np.array_equal(robot.description.T_tool, np.eye(4))  # the tool frame is frame n here
    m = 3.0
    loaded = robot.with_payload(m)
    rng = np.random.default_rng(5)
    Q = rng.uniform(*robot.qlim, size=(5, robot.n))
    dg = loaded.gravload_batch(Q) - robot.gravload_batch(Q)
    expected = np.array([-robot.jacob0(q)[:3].T @ (m * robot.parameters.gravity) for q in Q])
    assert np.abs(dg - expected).max() < 1e-10
    # negative control: the payload's weight with the wrong sign misses by its full size
    assert np.abs(dg + expected).max() > 1.0
