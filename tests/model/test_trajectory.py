"""Trajectories: boundary conditions, derivatives, closed forms, the Robotics Toolbox, tasks.

Tolerances
----------
* Boundary values are compared for equality: the Hermite basis of
  :class:`model.trajectory.JointPath` has integer coefficients, so it is exactly
  0 or 1 at the ends of a piece in floating point.
* Closed forms and the Robotics Toolbox evaluate the same degree-5 polynomials
  in double precision with coefficients up to 360: ``RTOL_POLY = 1e-12``
  relative to the motion amplitude (about 1e3 machine epsilons).
* Central differences with step h: truncation error <= h^2/6 max|f'''| plus a
  rounding error <= ~eps max|f| / h; :func:`_fd_tol` states that bound.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import roboticstoolbox as rtb
from scipy.spatial.transform import Rotation
from spatialmath import SE3

from model.loading import load_description
from model.tasks import (
    BUILTIN_TASKS,
    PICK_AND_PLACE,
    WaypointError,
    check_waypoints,
    load_waypoints,
    pick_and_place,
)
from model.trajectory import (
    JointPath,
    Trajectory,
    ctraj,
    jtraj,
    straight_line,
    time_grid,
    trapezoidal,
    via_points,
)

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

EPS = np.finfo(float).eps
RTOL_POLY = 1e-12
H = 1e-4  # s, finite-difference step: truncation ~1e-8, rounding ~1e-12 for O(1) motions over seconds


def _fd_tol(h: float, third: float, scale: float) -> float:
    """Bound on |central difference - derivative|: h^2/6 max|f'''| + 8 eps max|f| / h."""
    return h * h / 6.0 * third + 8.0 * EPS * scale / h


def _central(f, t: np.ndarray, h: float = H) -> np.ndarray:
    return (f(t + h) - f(t - h)) / (2.0 * h)


def _quintic_closed_form(q0, qf, T, t):
    """q, qd, qdd of the rest-to-rest quintic, written out from p(s) = 10 s^3 - 15 s^4 + 6 s^5."""
    s = (np.asarray(t) - 0.0)[:, None] / T
    d = np.asarray(qf) - np.asarray(q0)
    q = np.asarray(q0) + d * (10 * s**3 - 15 * s**4 + 6 * s**5)
    qd = d * (30 * s**2 - 60 * s**3 + 30 * s**4) / T
    qdd = d * (60 * s - 180 * s**2 + 120 * s**3) / T**2
    return q, qd, qdd


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20240611)


# --------------------------------------------------------------------------- jtraj


def test_jtraj_boundary_conditions_are_exact(rng):
    q0, qf = rng.uniform(-2, 2, 4), rng.uniform(-2, 2, 4)
    tr = jtraj(q0, qf, 2.5, 0.01)
    np.testing.assert_array_equal(tr.q[0], q0)
    np.testing.assert_array_equal(tr.q[-1], qf)
    for arr in (tr.qd[0], tr.qd[-1], tr.qdd[0], tr.qdd[-1]):
        np.testing.assert_array_equal(arr, np.zeros(4))
    assert tr.t.shape == (251,) and tr.q.shape == tr.qd.shape == tr.qdd.shape == (251, 4)
    assert tr.t[-1] == 2.5 and tr.n_segments == 1


def test_jtraj_given_boundary_velocities_are_exact(rng):
    q0, qf, v0, vf = (rng.uniform(-1, 1, 3) for _ in range(4))
    tr = jtraj(q0, qf, 1.5, 0.01, qd0=v0, qdf=vf)
    np.testing.assert_array_equal(tr.qd[0], v0)
    np.testing.assert_array_equal(tr.qd[-1], vf)
    np.testing.assert_array_equal(tr.qdd[[0, -1]], np.zeros((2, 3)))


def test_jtraj_matches_the_10_15_6_closed_form(rng):
    q0, qf, T = rng.uniform(-3, 3, 5), rng.uniform(-3, 3, 5), 2.0
    tr = jtraj(q0, qf, T, 0.01)
    q, qd, qdd = _quintic_closed_form(q0, qf, T, tr.t)
    amp = np.abs(qf - q0).max()
    np.testing.assert_allclose(tr.q, q, rtol=0, atol=RTOL_POLY * (amp + np.abs(q0).max()))
    np.testing.assert_allclose(tr.qd, qd, rtol=0, atol=RTOL_POLY * 30 * amp / T)
    np.testing.assert_allclose(tr.qdd, qdd, rtol=0, atol=RTOL_POLY * 180 * amp / T**2)
    # Peak velocity 15/8 |d|/T at mid-time (a grid point); peak acceleration 10/sqrt(3) |d|/T^2.
    d = np.abs(qf - q0)
    np.testing.assert_allclose(np.abs(tr.qd).max(axis=0), 15 / 8 * d / T, rtol=1e-12)
    s_star = 0.5 - math.sqrt(3) / 6
    _, _, a_peak = tr.sample(s_star * T)
    np.testing.assert_allclose(np.abs(a_peak), 10 / math.sqrt(3) * d / T**2, rtol=1e-12)


def test_jtraj_matches_the_robotics_toolbox_with_boundary_velocities(rng):
    q0, qf, v0, vf = (rng.uniform(-1, 1, 4) for _ in range(4))
    tr = jtraj(q0, qf, 3.0, 0.01, qd0=v0, qdf=vf)
    ref = rtb.jtraj(q0, qf, tr.t, qd0=v0, qd1=vf)
    np.testing.assert_allclose(tr.q, ref.q, rtol=0, atol=RTOL_POLY * 10)
    np.testing.assert_allclose(tr.qd, ref.qd, rtol=0, atol=RTOL_POLY * 10)
    np.testing.assert_allclose(tr.qdd, ref.qdd, rtol=0, atol=RTOL_POLY * 10)


def test_jtraj_derivatives_match_central_differences(rng):
    q0, qf, T = rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3), 2.0
    tr = jtraj(q0, qf, T, 0.01)
    t = tr.t[1:-1]
    d = np.abs(qf - q0).max()
    fd_v = _central(lambda x: tr.path.batch(x)[0], t)
    fd_a = _central(lambda x: tr.path.batch(x)[1], t)
    # max|q'''| = 60 d / T^3 and max|q''''| = 360 d / T^4 for the 10-15-6 quintic.
    assert np.abs(fd_v - tr.qd[1:-1]).max() <= _fd_tol(H, 60 * d / T**3, 2.0 + d)
    assert np.abs(fd_a - tr.qdd[1:-1]).max() <= _fd_tol(H, 360 * d / T**4, 15 / 8 * d / T)


def test_time_is_t0_plus_k_dt_not_accumulated():
    t0, dt = 1.7, 0.1
    tr = jtraj([0.0], [1.0], 100.0, dt, t0=t0)
    k = np.arange(1001)
    np.testing.assert_array_equal(tr.t, t0 + k * dt)
    assert tr.t[-1] != t0 + np.cumsum(np.full(1000, dt))[-1]  # a running sum drifts here
    np.testing.assert_array_equal(time_grid(3.0, 0.01), np.arange(301) * 0.01)


def test_sample_resample_and_hold_outside_the_span(rng):
    q0, qf = rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2)
    tr = jtraj(q0, qf, 2.0, 0.01, t0=0.5)
    q, qd, qdd = tr.sample(1.2345)
    Q, QD, QDD = tr.path.batch([1.2345])
    np.testing.assert_array_equal(np.stack([q, qd, qdd]), np.stack([Q[0], QD[0], QDD[0]]))
    fast = tr.resample(1e-3)
    assert fast.t.shape == (2001,) and fast.dt == 1e-3 and fast.path is tr.path
    np.testing.assert_allclose(fast.q[::10], tr.q, rtol=0, atol=1e-12)
    for t_out, q_end in ((0.0, q0), (9.0, qf)):
        q, qd, qdd = tr.sample(t_out)
        np.testing.assert_array_equal(q, q_end)
        np.testing.assert_array_equal(np.concatenate([qd, qdd]), np.zeros(4))
    explicit = jtraj(q0, qf, 2.0, t=[0.5, 1.0, 2.5], t0=0.5)
    assert explicit.dt is None
    np.testing.assert_array_equal(explicit.q[[0, -1]], np.stack([q0, qf]))


def test_scalar_and_batch_evaluation_agree_everywhere(rng):
    tr = pick_and_place(profile="trapezoidal")
    t = np.concatenate([rng.uniform(-1.0, 16.0, 500), tr.path.breaks, [-0.0, 15.0 + 1e-12]])
    Q, QD, QDD = tr.path.batch(t)
    scalar = np.array([np.concatenate(tr.sample(x)) for x in t])
    np.testing.assert_array_equal(scalar, np.hstack([Q, QD, QDD]))  # same arithmetic, same bits


def test_trajectory_is_frozen():
    tr = jtraj([0.0, 1.0], [1.0, 0.0], 1.0, 0.1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        tr.q = np.zeros((11, 2))  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        tr.q[0, 0] = 5.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(q0=[0, 0], qf=[1, 1], T=-1.0, dt=0.01), r"T: expected a value > 0, got -1\.0"),
        (dict(q0=[0, 0], qf=[1, 1], T=0.0, dt=0.01), r"T: expected a value > 0, got 0\.0"),
        (dict(q0=[0, 0], qf=[1, 1, 1], T=1.0, dt=0.01), r"qf: expected 2 values, got 3"),
        (dict(q0=[0, np.nan], qf=[1, 1], T=1.0, dt=0.01), r"q0: expected finite values, got \[0\.0, nan\]"),
        (dict(q0=[0, 0], qf=[1, 1], T=np.inf, dt=0.01), r"T: expected a finite number, got inf"),
        (dict(q0=[0, 0], qf=[1, 1], T=1.0, dt=-0.01), r"dt: expected a value > 0, got -0\.01"),
        (dict(q0=[0, 0], qf=[1, 1], T=1.0, dt=0.3), r"dt: T = 1\.0 s is not an integer multiple of dt = 0\.3 s"),
        (dict(q0=[0, 0], qf=[1, 1], T=1.0), r"give exactly one of dt .* or t"),
        (dict(q0=[0, 0], qf=[1, 1], T=1.0, dt=0.1, t=[0.0, 1.0]), r"give exactly one of dt"),
        (dict(q0=[0, 0], qf=[1, 1], T=1.0, t=[0.0, 0.5, 0.2]), r"t: expected strictly increasing"),
        (dict(q0=[0, 0], qf=[1, 1], T=1.0, dt=0.1, qd0=[1.0]), r"qd0: expected 2 values, got 1"),
        (dict(q0=[[0, 0]], qf=[1, 1], T=1.0, dt=0.1), r"q0: expected a 1-D vector, got an array of shape \(1, 2\)"),
        (dict(q0=[0, 0], qf=[1, 1], T="2", dt=0.1), r"T: expected a number, got '2'"),
    ],
)
def test_jtraj_rejects_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        jtraj(**kwargs)


# --------------------------------------------------------------------------- trapezoidal


@pytest.mark.parametrize("c", [0.0, 1.0 / 3.0, 0.6])
def test_trapezoidal_peaks_match_the_closed_form(rng, c):
    q0, qf, T = rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3), 3.0
    tr = trapezoidal(q0, qf, T, 0.001, cruise_fraction=c)
    d = np.abs(qf - q0)
    ta = (1 - c) * T / 2
    v_peak = 2 * d / ((1 + c) * T)  # area of the trapezoid: v (T - ta) = d
    a_peak = 4 * d / ((1 - c * c) * T * T)  # v / ta
    np.testing.assert_allclose(np.abs(tr.qd).max(axis=0), v_peak, rtol=1e-12)
    np.testing.assert_allclose(np.abs(tr.qdd).max(axis=0), a_peak, rtol=1e-12)
    np.testing.assert_array_equal(tr.q[[0, -1]], np.stack([q0, qf]))
    np.testing.assert_array_equal(tr.qd[[0, -1]], np.zeros((2, 3)))
    # Synchronised: every joint cruises exactly on [ta, T - ta].
    cruise = (tr.t > ta + 1e-9) & (tr.t < T - ta - 1e-9)
    np.testing.assert_allclose(np.abs(tr.qd[cruise]), np.broadcast_to(v_peak, tr.qd[cruise].shape), rtol=1e-12)
    # The Robotics Toolbox, joint by joint, with the same cruise velocity. At the two
    # switch instants the acceleration jumps and either side is a valid value: leave them out.
    smooth = np.abs(tr.t[:, None] - tr.path.breaks[None, 1:-1]).min(axis=1) > 1e-9
    for j in range(3):
        ref = rtb.trapezoidal(q0[j], qf[j], tr.t, V=v_peak[j])
        np.testing.assert_allclose(tr.q[:, j], ref.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(tr.qd[:, j], ref.qd, rtol=0, atol=1e-12)
        np.testing.assert_allclose(tr.qdd[smooth, j], ref.qdd[smooth], rtol=0, atol=1e-12)


def test_trapezoidal_derivatives_match_central_differences(rng):
    q0, qf, T = rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3), 3.0
    tr = trapezoidal(q0, qf, T, 0.01)
    breaks = tr.path.breaks
    t = tr.t[1:-1]
    away = np.abs(t[:, None] - breaks[None, :]).min(axis=1) > 2 * H
    # Inside a piece q is quadratic: the central difference has no truncation error.
    fd_v = _central(lambda x: tr.path.batch(x)[0], t[away])
    fd_a = _central(lambda x: tr.path.batch(x)[1], t[away])
    assert np.abs(fd_v - tr.qd[1:-1][away]).max() <= _fd_tol(H, 0.0, 4.0)
    assert np.abs(fd_a - tr.qdd[1:-1][away]).max() <= _fd_tol(H, 0.0, 4.0)


def test_trapezoidal_v_max_cruises_the_limiting_joint_at_its_limit():
    q0, qf, T = np.array([0.0, 0.0, 0.0]), np.array([1.0, -2.0, 0.0]), 3.0
    v_max = np.array([10.0, 1.0, 0.1])  # joint 2 needs > 2/3; joint 3 does not move
    tr = trapezoidal(q0, qf, T, 0.01, v_max=v_max)
    peaks = np.abs(tr.qd).max(axis=0)
    np.testing.assert_allclose(peaks, [0.5, 1.0, 0.0], rtol=1e-12)
    assert np.all(peaks <= v_max * (1 + 1e-12))  # within rounding of the piece data
    loose = trapezoidal(q0, qf, T, 0.01, v_max=100.0)  # limits above the triangular peak
    np.testing.assert_allclose(np.abs(loose.qd).max(axis=0), 2 * np.abs(qf - q0) / T, rtol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        (dict(v_max=0.6), r"v_max: joint 2 must move 2 in T = 3 s, which needs a cruise velocity above its mean "
                          r"velocity \|qf - q0\|/T = 0\.666667 \(rad/s or m/s\); got v_max = 0\.6"),
        (dict(v_max=[1.0, -1.0]), r"v_max: expected velocities > 0, got \[1\.0, -1\.0\]"),
        (dict(v_max=[1.0]), r"v_max: expected 2 values, got 1"),
        (dict(cruise_fraction=1.0), r"cruise_fraction: expected a fraction of T in \[0, 1\), got 1\.0"),
        (dict(cruise_fraction=-0.1), r"cruise_fraction: expected a fraction of T in \[0, 1\), got -0\.1"),
        (dict(cruise_fraction=0.2, v_max=1.0), r"cruise_fraction, v_max: give at most one"),
    ],
)
def test_trapezoidal_rejects_infeasible_requests(kwargs, match):
    with pytest.raises(ValueError, match=match):
        trapezoidal([0.0, 0.0], [1.0, -2.0], 3.0, 0.01, **kwargs)


# --------------------------------------------------------------------------- via points


def test_via_points_quintic_segments_are_jtraj_segments(rng):
    points = rng.uniform(-1, 1, (4, 3))
    times = [1.0, 2.0, 0.5]
    tr = via_points(points, times, 0.01, t0=2.0)
    np.testing.assert_array_equal(tr.t_via, [2.0, 3.0, 5.0, 5.5])
    np.testing.assert_array_equal(tr.q_via, points)
    assert tr.n_segments == 3 and tr.t.shape == (351,)
    for k in range(3):
        seg = jtraj(points[k], points[k + 1], times[k], 0.01, t0=tr.t_via[k])
        idx = np.flatnonzero(np.isclose(tr.t, seg.t[:, None], rtol=0, atol=1e-9).any(axis=0))
        assert idx.size == seg.t.size
        np.testing.assert_allclose(tr.q[idx], seg.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(tr.qd[idx], seg.qd, rtol=0, atol=1e-12)


def test_via_points_heuristic_velocities_do_not_stop_and_match_the_toolbox():
    points = np.array([[0.0, 0.0], [1.0, 1.0], [3.0, 0.0], [4.0, 0.5]])
    times = np.array([1.0, 2.0, 1.0])
    tr = via_points(points, times, 0.01, via_velocities="heuristic")
    # Joint 1 keeps its direction: mean of the adjacent segment velocities; joint 2 reverses: 0.
    np.testing.assert_allclose(tr.path.qd, [[0, 0], [0.5 * (1 + 1), 0], [0.5 * (1 + 1), 0], [0, 0]], rtol=1e-15)
    for k in range(3):
        sel = (tr.t >= tr.t_via[k] - 1e-9) & (tr.t <= tr.t_via[k + 1] + 1e-9)
        local = tr.t[sel] - tr.t_via[k]
        ref = rtb.jtraj(points[k], points[k + 1], local, qd0=tr.path.qd[k], qd1=tr.path.qd[k + 1])
        np.testing.assert_allclose(tr.q[sel], ref.q, rtol=0, atol=1e-12)
        np.testing.assert_allclose(tr.qd[sel], ref.qd, rtol=0, atol=1e-12)
    vias = np.rint(tr.t_via / 0.01).astype(int)
    np.testing.assert_array_equal(tr.q[vias], points)


def test_via_points_trapezoidal_profile_stops_at_every_via():
    points = np.array([[0.0, 1.0], [1.0, 1.0], [-1.0, 2.0]])
    tr = via_points(points, 2.0, 0.01, profile="trapezoidal", cruise_fraction=0.5)
    vias = np.rint(tr.t_via / 0.01).astype(int)
    np.testing.assert_array_equal(tr.q[vias], points)
    np.testing.assert_array_equal(tr.qd[vias], np.zeros((3, 2)))
    np.testing.assert_allclose(np.abs(tr.qd[: vias[1] + 1]).max(axis=0), [2 / 1.5 / 2, 0.0], rtol=1e-12)


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        (([[0, 0]], 1.0, 0.1), {}, r"points: expected a \(K\+1, n\) array with at least 2 rows, got shape \(1, 2\)"),
        (([[0, 0], [1, np.nan]], 1.0, 0.1), {}, r"points: row 2, joint 2: expected a finite value, got nan"),
        (([[0, 0], [1, 1], [2, 2]], [1.0], 0.1), {}, r"segment_times: expected 2 values, got 1"),
        (([[0, 0], [1, 1], [2, 2]], [1.0, -2.0], 0.1), {}, r"segment_times: expected durations > 0 s, got \[1\.0, -2\.0\]"),
        (([[0, 0], [1, 1], [2, 2]], [1.0, 1.05], 0.1), {}, r"segment_times: segment 2 lasts 1\.05 s, not a multiple of dt = 0\.1 s"),
        (([[0, 0], [1, 1]], 1.0, 0.1), dict(profile="cubic"), r"profile: expected 'quintic' or 'trapezoidal', got 'cubic'"),
        (([[0, 0], [1, 1], [2, 2]], 1.0, 0.1), dict(via_velocities=[[1.0]]), r"via_velocities: expected a finite \(1, 2\) array"),
        (([[0, 0], [1, 1], [2, 2]], 1.0, 0.1), dict(via_velocities="smooth"), r"via_velocities: expected 'stop', 'heuristic'"),
        (([[0, 0], [1, 1], [2, 2]], 1.0, 0.1), dict(profile="trapezoidal", via_velocities="heuristic"),
         r"via_velocities: profile 'trapezoidal' stops at every via point"),
    ],
)
def test_via_points_rejects_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        via_points(*args, **kwargs)


def test_joint_path_rejects_inconsistent_data():
    with pytest.raises(ValueError, match=r"breaks: expected strictly increasing"):
        JointPath([0.0, 0.0], [[0.0], [1.0]], [[0.0], [0.0]], [[0.0]], [[0.0]])
    with pytest.raises(ValueError, match=r"qdd_end: expected shape \(1, n\), got \(2, 1\)"):
        JointPath([0.0, 1.0], [[0.0], [1.0]], [[0.0], [0.0]], [[0.0]], [[0.0], [0.0]])


# --------------------------------------------------------------------------- pick and place


def test_pick_and_place_passes_every_waypoint_every_3_s():
    tr = pick_and_place()
    assert isinstance(tr, Trajectory)
    assert tr.n_segments == 5 and tr.n == 4
    assert tr.t[0] == 0.0 and tr.t[-1] == 15.0 and tr.t.shape == (1501,) and tr.dt == 0.01
    h = math.pi / 2
    expected = np.array([[0, 0, 1, 0], [h, h, 1, 0], [h, h, 3, 0], [h, h, 1, 0], [h, 0, 1, 0], [h, 0, 3, 0]])
    at_vias = np.flatnonzero(np.isin(tr.t, 3.0 * np.arange(6)))
    np.testing.assert_array_equal(at_vias, 300 * np.arange(6))
    np.testing.assert_array_equal(tr.q[at_vias], expected)
    np.testing.assert_array_equal(tr.qd[at_vias], np.zeros((6, 4)))
    np.testing.assert_array_equal(tr.qdd[at_vias], np.zeros((6, 4)))
    np.testing.assert_array_equal(tr.t_via, 3.0 * np.arange(6))


def test_pick_and_place_segments_match_the_robotics_toolbox():
    tr = pick_and_place()
    local = np.arange(301) * 0.01
    for k in range(5):
        ref = rtb.jtraj(PICK_AND_PLACE.waypoints[k], PICK_AND_PLACE.waypoints[k + 1], local)
        sl = slice(300 * k, 300 * k + 301)
        np.testing.assert_allclose(tr.q[sl], ref.q, rtol=0, atol=RTOL_POLY * 4)
        np.testing.assert_allclose(tr.qd[sl], ref.qd, rtol=0, atol=RTOL_POLY * 4)
        np.testing.assert_allclose(tr.qdd[sl], ref.qdd, rtol=0, atol=RTOL_POLY * 4)


def test_pick_and_place_parameters_and_velocity_derivative():
    tr = pick_and_place(segment_time=2.0, dt=0.005)
    assert tr.t[-1] == 10.0 and tr.t.shape == (2001,)
    fd = _central(lambda x: tr.path.batch(x)[0], tr.t[1:-1])
    # Largest step is 2 m / 2 s: max|q'''| = 60 * 2 / 2^3.
    assert np.abs(fd - tr.qd[1:-1]).max() <= _fd_tol(H, 60 * 2.0 / 2.0**3, 3.0)
    assert BUILTIN_TASKS["pick_and_place"] is PICK_AND_PLACE
    with pytest.raises(WaypointError, match=r"pick_and_place \(robot 'puma560'\) row 1: expected 6 joint values"):
        pick_and_place("puma560")


# --------------------------------------------------------------------------- waypoint files


def test_load_waypoints_toml_and_csv(tmp_path):
    toml = tmp_path / "task.toml"
    toml.write_text("segment_time = 2.0\nwaypoints = [[0, 0, 1, 0], [1.5, 0.5, 2.0, 0.1], [1.5, 0.0, 3.0, 0.0]]\n")
    task = load_waypoints(toml)
    assert task.segment_time == 2.0 and task.waypoints.shape == (3, 4) and task.robot == "scara"
    assert task.trajectory(dt=0.01).t[-1] == 4.0
    csv = tmp_path / "waypoints.csv"
    csv.write_text("# pick and place\ntheta1,theta2,d3,theta4\n0,0,1,0\n1.5, 0.5, 2.0, 0.1\n")
    task = load_waypoints(csv, segment_time=1.0)
    np.testing.assert_array_equal(task.waypoints, [[0, 0, 1, 0], [1.5, 0.5, 2.0, 0.1]])
    assert task.segment_time == 1.0


@pytest.mark.parametrize(
    ("name", "text", "match"),
    [
        ("waypoints.csv", "0,0,1,0\n0,0,1,0\n0,4.1,1,0\n", r"waypoints\.csv row 3, joint 2: 4\.1 rad outside qlim \[-3\.14159, 3\.14159\]"),
        ("waypoints.csv", "0,0,1,0\n0,0,5,0\n", r"waypoints\.csv row 2, joint 3: 5 m outside qlim \[0, 3\.5\]"),
        ("waypoints.csv", "0,0,1,0\n0,0,1\n", r"waypoints\.csv row 2: expected 4 joint values for robot 'scara', got 3"),
        ("waypoints.csv", "0,0,1,0\n0,x,1,0\n", r"waypoints\.csv row 2, joint 2: expected a number, got 'x'"),
        ("waypoints.csv", "0,0,1,0\nnan,0,1,0\n", r"waypoints\.csv row 2, joint 1: expected a finite value, got nan"),
        ("waypoints.csv", "0,0,1,0\n", r"waypoints\.csv: expected at least 2 waypoints, got 1"),
        ("w.toml", "waypoints = [[0, 0, 1, 0], [0, 0, 1, inf]]\n", r"w\.toml row 2, joint 4: expected a finite value, got inf"),
        ("w.toml", "waypoints = [[0, 0, 1, 0], [0, true, 1, 0]]\n", r"w\.toml row 2, joint 2: expected a number, got True"),
        ("w.toml", "points = [[0, 0, 1, 0]]\n", r"w\.toml: unknown key 'points'"),
        ("w.toml", "segment_time = 3.0\n", r"w\.toml: missing key 'waypoints'"),
        ("w.toml", "segment_time = -3.0\nwaypoints = [[0, 0, 1, 0], [0, 0, 2, 0]]\n", r"w\.toml: 'segment_time' = -3\.0: expected a duration > 0 s"),
        ("w.toml", "waypoints = [[0, 0, 1, 0]\n", r"w\.toml: not valid TOML"),
        ("w.txt", "0,0,1,0\n", r"w\.txt: expected a \.toml or \.csv waypoint file"),
    ],
)
def test_load_waypoints_rejects_bad_files(tmp_path, name, text, match):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(WaypointError, match=match):
        load_waypoints(path)


def test_check_waypoints_uses_the_robot_limits():
    desc = load_description("scara")
    check_waypoints(PICK_AND_PLACE.waypoints, desc, "pp")
    with pytest.raises(WaypointError, match=r"pp row 2, joint 3: -0\.5 m outside qlim \[0, 3\.5\]"):
        check_waypoints([[0, 0, 1, 0], [0, 0, -0.5, 0]], desc, "pp")


# --------------------------------------------------------------------------- Cartesian


def _pose(rng: np.random.Generator) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    T[:3, 3] = rng.uniform(-1, 1, 3)
    return T


def test_ctraj_ends_exact_and_positions_on_the_line(rng):
    T0, T1 = _pose(rng), _pose(rng)
    tr = ctraj(T0, T1, 2.0, 0.01)
    assert tr.poses.shape == (201, 4, 4) and tr.v.shape == tr.w.shape == (201, 3)
    np.testing.assert_array_equal(tr.poses[0], T0)
    np.testing.assert_array_equal(tr.poses[-1], T1)
    np.testing.assert_array_equal(np.concatenate([tr.v[[0, -1]], tr.w[[0, -1]]]), np.zeros((4, 3)))
    d = T1[:3, 3] - T0[:3, 3]
    rel = tr.p - T0[:3, 3]
    # On the line: no component across the segment; along it, s(t) of the 10-15-6 quintic.
    across = rel - np.outer(rel @ d / (d @ d), d)
    assert np.abs(across).max() <= 1e-14
    s = (rel @ d) / (d @ d)
    q, _, _ = _quintic_closed_form([0.0], [1.0], 2.0, tr.t)
    np.testing.assert_allclose(s, q[:, 0], rtol=0, atol=1e-14)


def test_ctraj_orientation_matches_toolbox_interpolation(rng):
    T0, T1 = _pose(rng), _pose(rng)
    tr = ctraj(T0, T1, 2.0, 0.05)
    s, _, _ = _quintic_closed_form([0.0], [1.0], 2.0, tr.t)
    ref = rtb.ctraj(SE3(T0, check=False), SE3(T1, check=False), s=s[:, 0])
    ref_poses = np.array([X.A for X in ref])
    # Unit-quaternion SLERP and the angle-axis exponential agree to rounding.
    np.testing.assert_allclose(tr.poses, ref_poses, rtol=0, atol=1e-12)


def test_ctraj_velocities_match_central_differences(rng):
    T0, T1 = _pose(rng), _pose(rng)
    T = 2.0
    tr = ctraj(T0, T1, T, 0.01)
    t = tr.t[1:-1]
    poses = lambda x: tr.path.batch(x)[0]  # noqa: E731
    dT = _central(poses, t)
    R = tr.poses[1:-1, :3, :3]
    W = dT[:, :3, :3] @ np.transpose(R, (0, 2, 1))  # Rdot R^T = [w]x
    w_fd = np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0], W[:, 1, 0] - W[:, 0, 1]], axis=1) / 2
    theta = tr.path.angle
    sd, sdd, sddd = 15 / 8 / T, 10 / math.sqrt(3) / T**2, 60 / T**3  # peaks of s', s'', s'''
    rot_third = (theta * sd) ** 3 + 3 * theta**2 * sd * sdd + theta * sddd  # bound on |R'''| entries
    assert np.abs(w_fd - tr.w[1:-1]).max() <= 3 * _fd_tol(H, rot_third, 1.0)
    d = np.linalg.norm(T1[:3, 3] - T0[:3, 3])
    assert np.abs(dT[:, :3, 3] - tr.v[1:-1]).max() <= _fd_tol(H, 60 * d / T**3, 2.0)
    vd_fd = _central(lambda x: tr.path.batch(x)[1], t)
    wd_fd = _central(lambda x: tr.path.batch(x)[2], t)
    assert np.abs(vd_fd - tr.vd[1:-1]).max() <= _fd_tol(H, 360 * d / T**4, 2.0)
    assert np.abs(wd_fd - tr.wd[1:-1]).max() <= _fd_tol(H, 360 * theta / T**4, 4.0)


def test_straight_line_segment_callable():
    p0, pf = np.array([0.0, 0.70710678, 0.35355339]), np.array([-0.70710678, 0.70710678, 0.1])
    seg = straight_line(p0, pf, 4.0)
    p, pdot = seg(0.0)
    np.testing.assert_array_equal(p, p0)
    np.testing.assert_array_equal(pdot, np.zeros(3))
    p, pdot = seg(4.0)
    np.testing.assert_array_equal(p, pf)
    p, pdot = seg(2.0)
    np.testing.assert_allclose(p, 0.5 * (p0 + pf), rtol=0, atol=1e-15)
    np.testing.assert_allclose(pdot, 15 / 8 * (pf - p0) / 4.0, rtol=1e-14)
    np.testing.assert_array_equal(seg(10.0)[0], pf)
    linear = straight_line(p0, pf, 4.0, profile="linear")
    t = np.arange(1, 400) * 0.01
    P, PD, PDD = linear.batch(t)
    np.testing.assert_allclose(PD, np.broadcast_to((pf - p0) / 4.0, PD.shape), rtol=1e-13)
    np.testing.assert_allclose(P, p0 + np.outer(t / 4.0, pf - p0), rtol=0, atol=1e-15)
    np.testing.assert_allclose(linear.acceleration(1.0), np.zeros(3), atol=1e-15)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: ctraj(np.eye(3), np.eye(4), 1.0, 0.1), r"T0: expected a \(4, 4\) homogeneous transform, got shape \(3, 3\)"),
        (lambda: ctraj(np.eye(4), 2 * np.eye(4), 1.0, 0.1), r"T1: expected a rigid transform"),
        (lambda: ctraj(np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0]), 1.0, 0.1), r"T1: expected a rigid transform"),
        (lambda: ctraj(np.eye(4), np.eye(4), -2.0, 0.1), r"T: expected a value > 0, got -2\.0"),
        (lambda: ctraj(np.eye(4), np.eye(4), 1.0, 0.1, profile="cubic"), r"profile: expected 'quintic', 'trapezoidal' or 'linear'"),
        (lambda: straight_line([0, 0, 0], [1, 1], 1.0), r"pf: expected 3 values, got 2"),
        (lambda: straight_line([0, 0, np.nan], [1, 1, 1], 1.0), r"p0: expected finite values"),
        (lambda: straight_line([0, 0, 0], [1, 1, 1], 1.0)(np.nan), r"t: expected a finite number, got nan"),
    ],
)
def test_cartesian_rejects_bad_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()


# --------------------------------------------------------------------------- jtraj in the toolbox's form
#
# Against roboticstoolbox.jtraj: the same quintic in another basis (monomials in s), so the two differ
# by rounding, ~1e-14 times the size of the values (qdd reaches ~60 |qf - q0| = ~200 here);
# 1e-12 relative to the largest value leaves a margin of 10x. A wrong coefficient moves them by O(1).


def _toolbox_close(ours, ref) -> None:
    for name in ("q", "qd", "qdd"):
        a, b = getattr(ours, name), getattr(ref, name)
        assert a.shape == b.shape, name
        assert np.abs(a - b).max() <= 1e-12 * max(1.0, np.abs(b).max()), name


@pytest.mark.parametrize("velocities", [False, True])
def test_jtraj_sample_count_is_the_toolbox_form(rng, velocities):
    q0, qf = rng.uniform(-2, 2, 4), rng.uniform(-2, 2, 4)
    v = dict(qd0=rng.uniform(-1, 1, 4), qd1=rng.uniform(-1, 1, 4)) if velocities else {}
    tr = jtraj(q0, qf, 50, **v)
    ref = rtb.jtraj(q0, qf, 50, **v)
    assert tr.q.shape == (50, 4) and tr.t[0] == 0.0 and tr.t[-1] == 1.0  # normalised time
    np.testing.assert_allclose(ref.t, tr.t * 50, rtol=1e-15)  # the toolbox's .t is the grid times the count
    _toolbox_close(tr, ref)


def test_jtraj_time_vector_is_the_toolbox_form(rng):
    q0, qf, v0, v1 = (rng.uniform(-2, 2, 3) for _ in range(4))
    tv = np.linspace(0.0, 2.5, 26)
    tr = jtraj(q0, qf, tv, qd0=v0, qd1=v1)
    ref = rtb.jtraj(q0, qf, tv, qd0=v0, qd1=v1)
    np.testing.assert_array_equal(tr.t, ref.t)
    _toolbox_close(tr, ref)
    np.testing.assert_allclose(tr.qd[0], v0, atol=1e-14)  # velocities in rad/s: the vector is in seconds
    # same as the SI form, and qd1 is qdf
    si = jtraj(q0, qf, 2.5, t=tv, qd0=v0, qdf=v1)
    np.testing.assert_array_equal(si.q, tr.q)


def test_jtraj_toolbox_comparison_can_fail(rng):
    """Negative control: swapped boundary velocities are caught."""
    q0, qf, v0, v1 = (rng.uniform(-2, 2, 3) for _ in range(4))
    tr = jtraj(q0, qf, 20, qd0=v1, qd1=v0)
    with pytest.raises(AssertionError):
        _toolbox_close(tr, rtb.jtraj(q0, qf, 20, qd0=v0, qd1=v1))


@pytest.mark.parametrize(("args", "kwargs", "match"), [
    ((1,), {}, r"T: expected a sample count >= 2 \(the toolbox's form\), got 1"),
    ((True,), {}, r"T: expected a number, got True"),
    (([-1.0, 0.0, 1.0],), {}, r"T: expected a time vector from 0 s on"),
    (([0.0, 0.5, 0.2],), {}, r"T: expected strictly increasing"),
    ((10,), {"qd1": [0, 0], "qdf": [0, 0]}, r"qd1, qdf: two names for the end velocity"),
])
def test_jtraj_toolbox_form_rejects_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        jtraj([0.0, 0.0], [1.0, 1.0], *args, **kwargs)
