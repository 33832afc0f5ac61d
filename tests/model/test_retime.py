"""The retime (:mod:`model.retime`) against references no one here wrote.

* toppra (PyPI, TOPP-RA by its authors) on the same path (our :class:`~model.trajectory.JointPath` handed to it),
  the same grid and the same limits, friction off (its torque constraint has no viscous term; Coulomb
  friction, symmetric, through its ``fs_coef``): durations within 1e-6 (the issue asks 1 %).
* A direct CasADi/IPOPT transcription of the same discretised problem with the viscous term kept exact:
  our conservative bounds on it, once refined, must cost at most 1e-7 of the duration.
* The full inverse dynamics (``Robot.rne``, motors and friction): every torque, speed and acceleration at every
  grid point (both one-sided accelerations) within its bound to 1e-9 relative.
* The sampled motion is the time law (tracking it: ``tests/closed_loop/test_retime_tracking.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

import model
from model.retime import (PathLimitError, RetimeInfeasibleError, blended_path, retime, retime_limits, segment_grids,
                          straight_path, path_constraints, solve_segment)
from tests.support.topp_references import (builtin, design_limits, frictionless, ipopt_duration, reference_waypoints,
                                           toppra_durations)

toppra = pytest.importorskip("toppra", reason="toppra (the test extra) is the reference the retime is checked against")

#: Built-ins with the robot file's reference task (panda and ur5 are read from their published URDFs).
ROBOTS = ("scara", "planar2r", "planar3r", "arm4", "spherical", "puma560", "panda", "ur5")


_robot, _limits, _waypoints = builtin, design_limits, reference_waypoints


# --------------------------------------------------------------------------- paths


def test_straight_path_passes_the_waypoints_at_unit_speed_and_stops_there():
    W = np.array([[0.0, 0.0, 1.0], [1.0, -0.5, 1.5], [0.2, 0.3, 1.0]])
    path = straight_path(W)
    for k, seg in enumerate(path.segments):
        q, dq, ddq = seg.batch(np.array([seg.t_start, 0.5 * seg.t_end, seg.t_end]))
        assert np.allclose(q[0], W[k], atol=0, rtol=0) and np.allclose(q[-1], W[k + 1], rtol=1e-15, atol=1e-15)
        assert np.allclose(np.linalg.norm(dq, axis=1), 1.0, rtol=1e-14) and np.all(ddq == 0.0)
    with pytest.raises(PathLimitError, match="waypoint 2 repeats waypoint 1"):
        straight_path([[0.0, 1.0], [0.0, 1.0], [1.0, 1.0]])


def test_blended_path_is_c2_through_every_waypoint_with_natural_ends():
    rng = np.random.default_rng(3)
    W = rng.uniform(-1.0, 1.0, (6, 3))
    seg = blended_path(W).segments[0]
    q, dq, ddq = seg.batch(seg.breaks)
    assert np.allclose(q, W, rtol=0, atol=1e-15)  # through the waypoints, exactly (Hermite ends are exact)
    assert np.all(ddq[[0, -1]] == 0.0)  # natural end conditions
    # C2 at the inner knots: left and right limits of q, q', q'' agree (a cubic spline's defining property)
    eps = 1e-7
    left = seg.batch(seg.breaks[1:-1] - eps)
    right = seg.batch(seg.breaks[1:-1] + eps)
    for order, tol in ((0, 1e-6), (1, 1e-5), (2, 1e-4)):
        assert np.max(np.abs(left[order] - right[order])) < tol
    # negative control: the straight path's q' jumps at the same knots (the check above can fail)
    straight = straight_path(W)
    jump = np.abs(straight.segments[0].batch([straight.segments[0].t_end])[1]
                  - straight.segments[1].batch([0.0])[1]).max()
    assert jump > 0.1
    # against scipy's own spline at points between the knots (the Hermite pieces are that cubic)
    from scipy.interpolate import CubicSpline

    s = np.linspace(0.0, seg.t_end, 777)
    ref = CubicSpline(seg.breaks, W, bc_type="natural")
    for order in range(3):
        assert np.max(np.abs(seg.batch(s)[order] - ref(s, order))) < 1e-9 * max(1.0, np.abs(ref(s, order)).max())


def test_a_blended_path_that_leaves_the_joint_limits_is_refused():
    W = [[0.0, 0.0], [1.0, 0.1], [0.0, 2.0]]  # joint 1 swings out to 1.13 between waypoints 2 and 3
    blended_path(W, [[-2.0, -2.0], [2.0, 3.0]])
    with pytest.raises(PathLimitError, match=r"joint 1 reaches 1\.\d+ between waypoints .*outside qlim \[-1, 1\]"):
        blended_path(W, [[-1.0, -1.0], [1.0, 3.0]])


# --------------------------------------------------------------------------- constraints against rne


@pytest.mark.parametrize("name", ["puma560", "scara", "ur5"])
def test_constraint_rows_are_the_inverse_dynamics_with_motors_and_friction(name):
    robot = _robot(name)
    path = blended_path(_waypoints(robot))
    seg = path.segments[0]
    s = np.linspace(0.0, seg.t_end, 41)
    pc = path_constraints(robot, seg, s, _limits(robot))
    rng = np.random.default_rng(7)
    y, u = rng.uniform(0.05, 2.0, s.size), rng.uniform(-3.0, 3.0, s.size)
    tau = pc.values(y, u)[:, :robot.n]
    ref = robot.rne_batch(pc.q, pc.dq * y[:, None], pc.dq * u[:, None] + pc.ddq * (y * y)[:, None])
    # the rows are rne taken apart (a, b, c from rne with friction off, friction from the parameters): rounding only
    assert np.max(np.abs(tau - ref)) <= 1e-9 * np.max(np.abs(ref))
    if name == "puma560":  # negative control: the Coulomb and viscous terms matter here (so the test can fail)
        assert np.max(np.abs(ref - frictionless(robot).rne_batch(pc.q, pc.dq * y[:, None], pc.dq * u[:, None]
                                                                  + pc.ddq * (y * y)[:, None]))) > 1.0


# --------------------------------------------------------------------------- against toppra


@pytest.mark.parametrize("blend", [False, True], ids=["straight", "blend"])
@pytest.mark.parametrize("name", ROBOTS)
def test_durations_agree_with_toppra_on_the_same_path_grid_and_limits(name, blend):
    robot = frictionless(_robot(name))
    motion = retime(robot, _waypoints(robot), _limits(robot), blend=blend, grid=400)
    ref, profiles = toppra_durations(robot, motion)
    # same discretised problem (interpolation scheme, same grid): the durations agree to the LP solvers' rounding
    assert motion.duration == pytest.approx(ref, rel=1e-6)
    for sol, sd in zip(motion.segments, profiles):
        assert np.max(np.abs(sol.sd - sd)) <= 1e-5 * np.max(sd)


def test_toppra_agreement_is_a_real_check():
    """Negative control: 5 % less torque changes the duration by more than the 1e-6 the test above allows."""
    robot = frictionless(_robot("puma560"))
    lim = _limits(robot)
    motion = retime(robot, _waypoints(robot), lim, grid=300)
    weaker = retime(robot, _waypoints(robot), retime_limits(robot, 0.95 * lim.tau_m_max), grid=300)
    assert toppra_durations(robot, weaker)[0] == pytest.approx(weaker.duration, rel=1e-6)
    assert abs(weaker.duration / toppra_durations(robot, motion)[0] - 1.0) > 0.01


def test_coulomb_friction_agrees_with_toppras_dry_friction():
    robot = frictionless(_robot("puma560"), coulomb=0.3)  # symmetric +-0.3 N m at every motor
    motion = retime(robot, _waypoints(robot), _limits(robot), grid=300)
    assert motion.duration == pytest.approx(toppra_durations(robot, motion, coulomb=0.3)[0], rel=1e-6)
    bare = retime(frictionless(robot), _waypoints(robot), _limits(robot), grid=300)
    assert motion.duration > bare.duration * (1 + 1e-4)  # negative control: the friction is felt


def test_velocity_and_acceleration_limits_agree_with_toppra():
    robot = frictionless(_robot("panda"))
    lim = _limits(robot, velocity_limit=[2.1, 2.1, 2.1, 2.1, 2.6, 2.6, 2.6], acceleration_limit=15.0)
    for blend in (False, True):
        motion = retime(robot, _waypoints(robot), lim, blend=blend, grid=400)
        check = motion.check()
        assert check.velocity == pytest.approx(1.0, abs=1e-9) or check.acceleration == pytest.approx(1.0, abs=1e-9)
        assert motion.duration == pytest.approx(toppra_durations(robot, motion)[0], rel=1e-6)


# --------------------------------------------------------------------------- viscous friction


@pytest.mark.parametrize("name", ["scara", "planar2r", "puma560"])
def test_viscous_friction_costs_at_most_1e_7_against_the_exact_direct_transcription(name):
    robot = _robot(name)
    motion = retime(robot, _waypoints(robot), _limits(robot), grid=150)
    for pc, sol in zip(motion.constraints, motion.segments):
        assert np.any(pc.gamma != 0.0)  # the robot has viscous friction on this path
        T, _ = ipopt_duration(pc, 0.7 * sol.sd)
        # ours is feasible by construction (sound lines), IPOPT's local optimum of the exact problem is a
        # lower bound up to its tolerance: the gap is what the lines cost
        assert T * (1 - 1e-9) <= sol.duration <= T * (1 + 1e-7)


def test_the_refinement_never_lengthens_and_converges():
    robot = _robot("planar2r")  # 100 N m s/rad of viscous friction at each joint
    path = straight_path(_waypoints(robot))
    seg, grid = path.segments[0], segment_grids(path, 300)[0]
    pc = path_constraints(robot, seg, grid, _limits(robot))
    T = [solve_segment(pc, refine=k).duration for k in range(4)]
    assert T[3] <= T[2] <= T[1] <= T[0]
    assert T[0] / T[3] - 1 > 1e-2 and T[2] / T[3] - 1 < 1e-8  # the lines cost 1 % at first, nothing once refined


# --------------------------------------------------------------------------- limits at every grid point


@pytest.mark.parametrize("blend", [False, True], ids=["straight", "blend"])
@pytest.mark.parametrize("name", ROBOTS)
def test_every_limit_holds_at_every_grid_point_by_the_inverse_dynamics(name, blend):
    robot = _robot(name)
    vmax = 0.8 * np.array([2.0] * robot.n)
    lim = _limits(robot, velocity_limit=vmax, acceleration_limit=30.0)
    motion = retime(robot, _waypoints(robot), lim, blend=blend, grid=500)
    worst_tau = worst_v = worst_a = 0.0
    for k in range(len(motion.segments)):
        for end in (False, True):
            q, qd, qdd, s = motion.grid_states(k, end=end)
            # at a rest point (segment ends) the friction is that of the motion starting or ending there: rne's
            # sign law at exactly qd = 0 gives none, so it is asked at a speed 1e-12 along the path instead
            rest = np.all(qd == 0.0, axis=1)
            dq = motion.path.segments[k].batch(s[rest])[1]
            qd_dir = qd.copy()
            qd_dir[rest] = 1e-12 * dq
            tau = robot.rne_batch(q, qd_dir, qdd)
            worst_tau = max(worst_tau, float(np.max(np.abs(tau) / lim.tau_max)))
            worst_v = max(worst_v, float(np.max(np.abs(qd) / lim.velocity)))
            worst_a = max(worst_a, float(np.max(np.abs(qdd) / lim.acceleration)))
    assert max(worst_tau, worst_v, worst_a) <= 1.0 + 1e-9
    assert max(worst_tau, worst_v, worst_a) >= 1.0 - 1e-6  # time-optimal: some limit is reached
    assert motion.check().torque == pytest.approx(worst_tau, rel=1e-9, abs=1e-12)


def test_an_arm_that_cannot_hold_itself_is_refused_naming_the_joint():
    robot = _robot("planar2r")
    with pytest.raises(RetimeInfeasibleError, match="joint 1 needs .* to hold the arm still there, above its limit"):
        retime(robot, [[0.0, 0.0], [1.0, 0.5]], retime_limits(robot, [1.0, 1.0]), grid=50)


def test_limits_are_checked():
    robot = _robot("scara")
    with pytest.raises(model.InputError, match=r"torque_margin: expected a share .* in \(0, 1\], got 1.5"):
        retime_limits(robot, [1.0] * 4, torque_margin=1.5)
    with pytest.raises(model.InputError, match="velocity_limit: expected one value or 4 values"):
        retime_limits(robot, [1.0] * 4, velocity_limit=[1.0, 2.0])
    with pytest.raises(model.InputError, match="acceleration_limit: expected limits > 0"):
        retime_limits(robot, [1.0] * 4, acceleration_limit=-1.0)
    lim = retime_limits(robot, [1.0] * 4, velocity_limit=2.0, velocity_scale=0.5)
    assert np.all(lim.velocity == 1.0) and lim.velocity_source == ("given x 0.5",) * 4
    assert np.all(np.isinf(lim.acceleration)) and lim.acceleration_source == ("none",) * 4


def test_robot_file_limits_are_used(tmp_path):
    text = (model.description.BUILTIN_DIR / "planar3r.toml").read_text()
    text = text.replace("[[links]]\n", "[[links]]\nvelocity_limit = 1.5\nacceleration_limit = 12.0\n", 1)
    path = tmp_path / "limited.toml"
    path.write_text(text)
    robot = model.load_robot(path)
    lim = retime_limits(robot, [10.0, 10.0, 10.0])
    assert lim.velocity[0] == 1.5 and lim.acceleration[0] == 12.0 and lim.velocity_source[0] == "robot file"
    assert np.isinf(lim.velocity[1]) and lim.velocity_source[1] == "none"


def test_the_sampled_motion_is_the_time_law():
    robot = _robot("scara")
    motion = retime(robot, _waypoints(robot), _limits(robot), grid=300)
    traj = motion.trajectory(1e-3, smooth=0.0)
    q, qd, qdd = motion.batch(traj.t)
    interior = ~np.isin(np.arange(traj.t.size), np.searchsorted(traj.t, motion.segment_times[1:-1]))
    assert np.array_equal(traj.q, q) and np.array_equal(traj.qd[interior], qd[interior])
    # the time law integrates: positions against the trapezoidal rule of the velocities on a fine sampling
    t = np.linspace(0.0, motion.duration, 200_001)
    Q, QD, _ = motion.batch(t)
    integral = Q[0] + np.concatenate([np.zeros((1, robot.n)), np.cumsum(0.5 * (QD[1:] + QD[:-1]) * np.diff(t)[:, None],
                                                                       axis=0)])
    assert np.max(np.abs(integral - Q)) < 1e-6
    assert np.allclose(Q[-1], _waypoints(robot)[-1], atol=1e-12)


@pytest.mark.parametrize("blend", [False, True], ids=["straight", "blend"])
def test_the_smoothed_motion_stays_on_the_path_and_within_a_hair_of_the_bounds(blend):
    from model.trajectory_file import check_consistency

    robot = _robot("scara")
    W = _waypoints(robot)
    motion = retime(robot, W, _limits(robot), blend=blend, grid=1000)
    w = 1e-3
    traj = motion.trajectory(1e-3, smooth=w)
    K = len(motion.segments)
    assert traj.t[-1] == pytest.approx(motion.duration + K * w, rel=1e-12)  # each segment a window longer
    check_consistency(traj.t, traj.q, traj.qd, traj.qdd, "smoothed")  # q, qd, qdd are one motion
    assert np.allclose(traj.q[0], W[0], atol=0) and np.allclose(traj.q[-1], W[-1], atol=1e-12)
    assert np.max(np.abs(traj.qd[[0, -1]])) < 1e-12 and np.max(np.abs(traj.qdd[[0, -1]])) < 1e-9  # at rest
    # on the path: each sample is q(s) of its segment for some s (straight: on the segment's line)
    if not blend:
        for k, (a, b) in enumerate(zip(traj.t_via[:-1], traj.t_via[1:])):  # the smoothed segments
            inside = (traj.t >= a) & (traj.t <= b)
            d = (W[k + 1] - W[k]) / np.linalg.norm(W[k + 1] - W[k])
            rel = traj.q[inside] - W[k]
            assert np.max(np.abs(rel - np.outer(rel @ d, d))) < 1e-12
    # the acceleration is continuous: at a waypoint it ramps to 0 and up again (the exact law jumps there)
    boundary = np.searchsorted(traj.t, traj.t_via[1:-1])
    assert boundary.size == K - 1 and np.all(np.abs(traj.qdd[boundary]) < 1e-9)
    # torques: averages of admissible ones over 1 ms; measured within 0.1 % of the bound on this grid
    use = np.max(np.abs(robot.rne_batch(traj.q, traj.qd, traj.qdd)) / motion.limits.tau_max)
    assert 0.99 < use < 1.001
