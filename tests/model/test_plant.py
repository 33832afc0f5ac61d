"""The plant contract of model/plant.py: sizes, names, order, and values against the numeric API."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from model import InertiaConsistencyWarning, load_robot
from model.plant import build_plant


@pytest.fixture(scope="module", params=["scara", "puma560"])
def robot(request):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot(request.param)


def test_contract_names_and_sizes(robot):
    plant = build_plant(robot)
    n = robot.n
    assert (plant.n, plant.nx, plant.nu, plant.ny) == (n, 2 * n, n, 3 * n + 6)
    assert plant.ode.name() == "ode" and plant.out.name() == "out" and plant.nz == n
    assert plant.ode.name_in() == ["x", "u", "p", "m"] and plant.ode.name_out() == ["xdot"]
    assert plant.out.name_in() == ["x", "u", "p"] and plant.out.name_out() == ["y"]
    for name in ("events", "update", "start", "active", "pivots", "friction"):
        assert getattr(plant, name).name_in() == ["x", "u", "p", "m"], name
    expected = (
        ["payload_mass"] + [f"payload_com[{k}]" for k in (1, 2, 3)] + [f"payload_inertia[{k}]" for k in range(1, 7)]
        + [f"viscous_friction[{i}]" for i in range(1, n + 1)]
        + [f"coulomb_friction_pos[{i}]" for i in range(1, n + 1)]
        + [f"coulomb_friction_neg[{i}]" for i in range(1, n + 1)]
        + [f"gravity[{k}]" for k in (1, 2, 3)]
    )
    assert list(plant.param_names) == expected
    assert len(plant.param_defaults) == len(plant.param_units) == len(plant.param_descriptions) == len(expected)
    assert plant.ode.numel_in(2) == len(expected)
    np.testing.assert_array_equal(plant.param_defaults[-3:], robot.description.gravity)
    assert plant.output_names[2 * n] == "qm[1]" and plant.output_names[-1] == "tool_rpy[3]"
    np.testing.assert_array_equal(plant.x0, np.concatenate([robot.q_rest, np.zeros(n)]))


def test_ode_and_out_values(robot):
    plant = build_plant(robot)
    n = robot.n
    rng = np.random.default_rng(61)
    q, qd = rng.uniform(-1, 1, (2, n))
    u = rng.uniform(-0.5, 0.5, n)
    x = np.concatenate([q, qd])
    p = plant.param_defaults
    # in the sliding modes of qd, the plant's accelerations are the sign law of robot.accel
    xdot = np.array(plant.ode(x, u, p, plant.sliding_modes(qd))).ravel()
    np.testing.assert_allclose(xdot[:n], qd)
    np.testing.assert_allclose(xdot[n:], robot.accel(q, qd, robot.gear_ratio * u), rtol=1e-12, atol=1e-12)
    y = np.array(plant.out(x, u, p)).ravel()
    T = robot.fkine(q)
    np.testing.assert_allclose(y[:2 * n], x)
    np.testing.assert_allclose(y[2 * n:3 * n], robot.gear_ratio * q)
    np.testing.assert_allclose(y[3 * n:3 * n + 3], T[:3, 3], atol=1e-14)
    roll, pitch, yaw = y[-3:]
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    np.testing.assert_allclose(Rz @ Ry @ Rx, T[:3, :3], atol=1e-12)


def test_the_sliding_functions_are_the_law_where_nothing_is_stuck_bit_for_bit(robot):
    """ode_sliding and events_sliding (what the fixed-step rule evaluates while no joint is stuck) give ode's and
    events' numbers exactly there: the law's selections return their operands unchanged. With a joint stuck they
    differ (the negative control: they are not the full law)."""
    plant = build_plant(robot)
    n = robot.n
    rng = np.random.default_rng(7)
    p = plant.param_defaults
    for _ in range(20):
        x = np.concatenate([rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)])
        u = rng.uniform(-0.5, 0.5, n)
        m = rng.choice([-1.0, 1.0], n)
        np.testing.assert_array_equal(np.array(plant.ode_sliding(x, u, p, m)), np.array(plant.ode(x, u, p, m)))
        np.testing.assert_array_equal(np.array(plant.events_sliding(x, u, p, m)), np.array(plant.events(x, u, p, m)))
    m[0] = 0.0
    x[n] = 0.0
    assert not np.array_equal(np.array(plant.ode_sliding(x, u, p, m)), np.array(plant.ode(x, u, p, m)))


def test_active_and_quiet_say_when_the_modes_need_a_look(robot):
    """active: a mode can change (Coulomb friction somewhere, or a joint stuck); quiet: no update pass would change
    anything (nothing stuck, no joint with Coulomb friction within V_EPS of rest)."""
    from model.dynamics.stick_slip import V_EPS

    plant = build_plant(robot)
    n = robot.n
    p = plant.param_defaults
    has_coulomb = bool(np.any(robot.parameters.field("coulomb_friction_pos") > 0))
    x = np.concatenate([robot.q_rest, np.full(n, 0.3)])
    m = np.ones(n)
    assert np.array(plant.active(x, np.zeros(n), p, m)).ravel().tolist() == [float(has_coulomb), 1.0]
    x[n] = 0.5 * V_EPS                                               # joint 1 all but at rest
    assert np.array(plant.active(x, np.zeros(n), p, m)).ravel()[1] == (0.0 if has_coulomb else 1.0)
    m[0] = 0.0                                                       # stuck: always active, never quiet
    assert np.array(plant.active(x, np.zeros(n), p, m)).ravel().tolist() == [1.0, 0.0]
