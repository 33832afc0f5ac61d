"""Excitation trajectories: the Fourier series' own properties, the optimiser's limits and its objective.

* The series starts and ends every period at rest at q_start (qd = qdd = 0 to rounding), and its qd and qdd are
  the time derivatives of its q (central differences at 1 us, tolerance from their truncation error).
* The optimiser lowers the condition number of the base regressor (recomputed here with an SVD of the batch
  regressor, not the optimiser's value), and keeps every limit on a 1 kHz grid of the result; a torque limit
  chosen to bind is met (negative control: the unconstrained excitation breaks it).
* The sampled trajectory (:meth:`FourierTrajectory.trajectory`) is the series at its samples, bit for bit, and a
  joint table of it reads back with the shared reader.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from model.identification import Regressor, base_parameters, excitation_limits, optimise_excitation
from model.identification.excitation import FourierTrajectory
from model.joint_table import read_joint_table, write_joint_table
from model.robot import Robot
from tests.support.identification import robot


def _series(n: int = 3, L: int = 4, seed: int = 0) -> FourierTrajectory:
    rng = np.random.default_rng(seed)
    a, b = rng.standard_normal((n, L)), rng.standard_normal((n, L))
    l = np.arange(1, L + 1)
    a -= a.mean(axis=1, keepdims=True)
    b -= np.outer(b @ l / (l @ l), l)
    return FourierTrajectory(period=4.0, q_start=rng.standard_normal(n), a=a, b=b)


def test_series_rests_at_both_ends_of_every_period():
    traj = _series()
    q, qd, qdd = traj.evaluate(np.array([0.0, 4.0, 8.0]))
    np.testing.assert_allclose(q, np.tile(traj.q_start, (3, 1)), atol=1e-13)
    np.testing.assert_allclose(qd, 0.0, atol=1e-13)
    np.testing.assert_allclose(qdd, 0.0, atol=1e-12)


def test_series_derivatives_are_derivatives():
    traj = _series()
    t = np.linspace(0.1, 3.9, 17)
    h = 1e-6
    q_p, qd_p, _ = traj.evaluate(t + h)
    q_m, qd_m, _ = traj.evaluate(t - h)
    _, qd, qdd = traj.evaluate(t)
    # central differences: truncation h^2 |q'''| / 6 ~ 1e-11, rounding 1e-16 |q| / h ~ 1e-10
    np.testing.assert_allclose((q_p - q_m) / (2 * h), qd, atol=1e-8)
    np.testing.assert_allclose((qd_p - qd_m) / (2 * h), qdd, atol=1e-8)


def _cond(rob, base, traj, samples=400):
    t = np.arange(samples) * traj.period / samples
    Y = Regressor(rob.description).batch(*traj.evaluate(t))
    s = np.linalg.svd(base.columns(Y).reshape(-1, base.n_base), compute_uv=False)
    return s[0] / s[-1]


def _within(result, rate=1000.0):
    lim = result.limits
    t, q, qd, qdd = result.trajectory.sample(rate)
    assert np.all(q >= lim.q_min - 1e-12) and np.all(q <= lim.q_max + 1e-12)
    assert np.all(np.abs(qd) <= lim.qd_max + 1e-12)
    assert np.all(np.abs(qdd) <= lim.qdd_max + 1e-12)
    return t, q, qd, qdd


def test_optimiser_lowers_the_condition_number_within_the_limits():
    rob = robot("scara")
    base = base_parameters(Regressor(rob.description))
    result = optimise_excitation(rob, max_iter=60, seed=1)
    assert result.condition_number < 0.2 * result.initial_condition_number
    assert _cond(rob, base, result.trajectory) == pytest.approx(result.condition_number, rel=0.2)
    _within(result)
    assert any("no joint speed limit for shoulder, elbow, quill, wrist" in note for note in result.limits.notes)


def test_the_robot_files_speed_limits_are_used_where_stated():
    """The panda's URDF states each joint's <limit velocity> (2.175 and 2.61 rad/s): the excitation keeps to
    them; it states no acceleration limit, so those take the default and the note names every joint."""
    desc = robot("panda").description
    lim = excitation_limits(desc)
    stated = [lk.velocity_limit for lk in desc.links]
    assert None not in stated and sorted(set(stated)) == [2.175, 2.61]
    np.testing.assert_array_equal(lim.qd_max, stated)
    assert [n for n in lim.notes if "speed" in n] == []
    assert any(", ".join(desc.joint_names) in n for n in lim.notes if "acceleration" in n)


def test_given_limits_are_kept_and_no_default_is_announced():
    rob = robot("planar2r")
    lim = excitation_limits(rob.description, qd_max=[0.5, 0.8], qdd_max=2.0)
    assert lim.notes == ()
    result = optimise_excitation(rob, limits=lim, max_iter=30)
    _, _, qd, _ = _within(result)
    assert np.abs(qd).max(axis=0)[0] <= 0.5 + 1e-12


def test_a_rated_motor_keeps_its_torque_limit():
    """planar2r with joint 1 rated so that gravity alone nearly reaches the limit: the excitation's torque stays
    within 0.9 of it (the default margin); without the rating the same optimisation goes past it."""
    rob = robot("planar2r")
    free = optimise_excitation(rob, max_iter=30)
    t, q, qd, qdd = free.trajectory.sample(1000.0)
    peak = np.abs(rob.rne_batch(q, qd, qdd)[:, 0]).max()
    G = rob.description.links[0].gear_ratio
    limit = 0.8 * peak / abs(G)  # motor side, so that the free excitation breaks it
    rated = dataclasses.replace(rob.description, links=(dataclasses.replace(rob.description.links[0], torque_limit=limit),
                                                        rob.description.links[1]))
    rated_robot = Robot(rated)
    result = optimise_excitation(rated_robot, max_iter=30)
    _, q, qd, qdd = result.trajectory.sample(1000.0)
    tau = np.abs(rated_robot.rne_batch(q, qd, qdd)[:, 0]).max()
    assert tau <= 0.9 * abs(G) * limit * 1.01  # the grid's instants are 50 ms apart: 1 % between them
    assert peak > abs(G) * limit


def test_sampled_trajectory_is_the_series_and_round_trips_as_a_joint_table(tmp_path):
    rob = robot("scara")
    result = optimise_excitation(rob, max_iter=10)
    traj = result.trajectory.trajectory(1000.0, periods=2)
    t, q, qd, qdd = result.trajectory.sample(1000.0, periods=2)
    np.testing.assert_array_equal(traj.q, q)
    q_mid, qd_mid, _ = traj.sample(0.0105)
    q_ser, qd_ser, _ = result.trajectory.evaluate(np.array([0.0105]))
    np.testing.assert_allclose(q_mid, q_ser[0], atol=1e-12)  # quintic between samples: (w h)^6 ~ 1e-15
    np.testing.assert_allclose(qd_mid, qd_ser[0], atol=1e-10)
    path = write_joint_table(tmp_path / "excite.csv", t, {"q": q, "qd": qd, "qdd": qdd}, rob.description.joint_names)
    back = read_joint_table(path, rob.description.joint_names, ("q", "qd", "qdd"))
    np.testing.assert_array_equal(back["q"], q)
    np.testing.assert_array_equal(back.t, t)
