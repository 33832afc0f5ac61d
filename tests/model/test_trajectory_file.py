"""Trajectory files (:mod:`model.trajectory_file`): exact round trip, the Hermite path through the samples, and
every malformed or mismatched file refused in one line naming the file, the line and the joint."""

from __future__ import annotations

import numpy as np
import pytest

from model.joint_table import JointTableError, write_joint_table
from model.trajectory import jtraj
from model.trajectory_file import (CONSISTENCY_TOL, TrajectoryFileError, check_consistency, read_trajectory,
                                   sampled_trajectory, write_trajectory)
from tests.support.topp_references import builtin


@pytest.fixture(scope="module")
def scara():
    return builtin("scara")


def _quintic(T: float = 2.0, dt: float = 1e-3):
    return jtraj([0.0, 0.0, 1.0, 0.0], [1.5, -1.0, 2.5, 0.5], T=T, dt=dt)


def test_round_trip_is_exact_and_the_path_reproduces_every_sample(scara, tmp_path):
    traj = _quintic()
    path = write_trajectory(tmp_path / "t.csv", traj, scara.description.joint_names)
    back = read_trajectory(path, scara.description)
    for name in ("t", "q", "qd", "qdd"):
        assert np.array_equal(getattr(back, name), getattr(traj, name))  # repr: every float as written
    Q, QD, QDD = back.path.batch(back.t)
    assert np.array_equal(Q, traj.q) and np.array_equal(QD, traj.qd) and np.array_equal(QDD, traj.qdd)
    # between the samples it is the motion itself, to the quintic Hermite's accuracy (the file's motion is a quintic)
    t = np.linspace(0.0, 2.0, 4001)
    assert np.max(np.abs(back.path.batch(t)[0] - traj.path.batch(t)[0])) < 1e-12
    assert back.dt == pytest.approx(1e-3, rel=1e-12)


def test_the_header_is_the_robot_s_joints(scara, tmp_path):
    traj = _quintic()
    names = ("a", "b", "c", "d")
    path = write_trajectory(tmp_path / "t.csv", traj, names)
    with pytest.raises(JointTableError, match=r"t\.csv line 1: unknown column 'q_a' \(column 2\)"):
        read_trajectory(path, scara.description)
    write_joint_table(tmp_path / "noqdd.csv", traj.t, {"q": traj.q, "qd": traj.qd}, scara.description.joint_names)
    with pytest.raises(JointTableError, match="missing columns qdd_shoulder .. qdd_wrist"):
        read_trajectory(tmp_path / "noqdd.csv", scara.description)


def test_degrees_instead_of_radians_are_refused(scara, tmp_path):
    traj = _quintic()
    deg = np.rad2deg(traj.qd)  # velocities in deg/s, positions in rad: they do not belong together
    write_joint_table(tmp_path / "deg.csv", traj.t, {"q": traj.q, "qd": deg, "qdd": traj.qdd},
                      scara.description.joint_names)
    with pytest.raises(TrajectoryFileError, match=r"deg\.csv lines \d+-\d+: joint \d's position change disagrees "
                                                  r"with the mean of qd .* tolerance 1 %"):
        read_trajectory(tmp_path / "deg.csv", scara.description)


def test_samples_too_sparse_for_the_motion_are_refused(scara, tmp_path):
    fine = _quintic(T=0.5, dt=1e-3)
    check_consistency(fine.t, fine.q, fine.qd, fine.qdd, "fine")  # passes
    coarse = _quintic(T=0.5, dt=0.125)  # 4 samples of a quintic: the cubic rule misses it by far more than 1 %
    with pytest.raises(TrajectoryFileError, match="sampled finely enough"):
        check_consistency(coarse.t, coarse.q, coarse.qd, coarse.qdd, "coarse")


def test_consistency_tolerance_is_what_it_says():
    t = np.linspace(0.0, 1.0, 101)
    q = np.column_stack([np.sin(t), t])
    qd = np.column_stack([np.cos(t), np.ones_like(t)])
    qdd = np.column_stack([-np.sin(t), np.zeros_like(t)])
    check_consistency(t, q, qd, qdd, "exact")
    off = qd.copy()
    off[50, 1] += 1.9 * CONSISTENCY_TOL  # joint 2's peak speed is 1: 1.9 % off at one sample -> > 1 % per interval
    with pytest.raises(TrajectoryFileError, match="lines 51-52: joint 2's"):
        check_consistency(t, q, off, qdd, "off")
    off[50, 1] = 1.0 + 1.9 * CONSISTENCY_TOL * 0.5  # 0.95 % at one sample: 0.475 % on each interval, accepted
    check_consistency(t, q, off, qdd, "off")


def test_limits_and_start_state_are_checked(scara, tmp_path):
    traj = _quintic()
    q = traj.q.copy()
    q[1000, 2] = 3.6  # the quill beyond qlim [0, 3.5] m
    write_joint_table(tmp_path / "far.csv", traj.t, {"q": q, "qd": traj.qd, "qdd": traj.qdd},
                      scara.description.joint_names)
    with pytest.raises(TrajectoryFileError, match=r"far\.csv line 1002: q_quill = 3\.6 outside qlim \[0, 3\.5\] of joint 3"):
        read_trajectory(tmp_path / "far.csv", scara.description)
    import dataclasses

    desc = scara.description
    slow = dataclasses.replace(desc, links=(dataclasses.replace(desc.links[0], velocity_limit=0.5),) + desc.links[1:])
    fast_start = traj.qd.copy()
    write_trajectory(tmp_path / "ok.csv", traj, desc.joint_names)
    with pytest.raises(TrajectoryFileError, match=r"ok\.csv line \d+: a sample is too fast: qd_shoulder = .* above "
                                                  r"velocity_limit 0\.5 of joint 1"):
        read_trajectory(tmp_path / "ok.csv", slow)
    fast_start[0, 0] = 0.7
    t2 = sampled_trajectory(traj.t[:2], traj.q[:2], fast_start[:2], traj.qdd[:2])
    write_trajectory(tmp_path / "start.csv", t2, desc.joint_names)
    with pytest.raises(TrajectoryFileError, match=r"start\.csv line 2: the start is too fast"):
        read_trajectory(tmp_path / "start.csv", slow)
