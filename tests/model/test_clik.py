"""CLIK of seed report 004: spherical RRP arm on a straight segment, Euler at 2 ms.

What the numbers show (measured with the defaults K = 50 /s, DLS damping 2.5e-3 m^2,
quintic time law):
* the segment leaves the reachable set (the cylinder x^2 + y^2 >= d2^2 = 1 m^2 about
  joint 1) at 10.3 % of its length, t = 1.0 s, and comes back only at p_f: no inversion
  can follow it; the error is at least the distance to that cylinder, up to 0.1302 m;
* plain inverse / pseudo-inverse: error < 4.5e-4 m until t = 1.0 s, then theta2 crosses
  0, joint rates of order 1e7-1e9 rad/s and the arm leaves the path by metres;
* damped least squares: peak joint rate 2.85 rad/s, error at most 3.8 mm above the
  unavoidable distance, ends 3.5e-7 m from p_f.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import load_robot
from model.clik import SEED_DT, SEED_P_FINAL, SEED_Q0, SEED_TF, CLIKResult, clik, seed_clik_task
from model.ik import ikine_a
from model.trajectory import straight_line

D2 = 1.0  # m, shoulder offset of the built-in spherical arm (seed 004)


@pytest.fixture(scope="module")
def runs() -> dict[str, CLIKResult]:
    return {inv: seed_clik_task(inv) for inv in ("inverse", "pinv", "dls", "transpose")}


def gap(res: CLIKResult) -> np.ndarray:
    """(N+1,) distance from the desired point to the reachable set (0 when reachable), m."""
    return np.maximum(D2 - np.hypot(res.p_d[:, 0], res.p_d[:, 1]), 0.0)


def test_seed_end_point_needs_d2_of_one_metre() -> None:
    """Seed 004: q_f = [pi/4, 0, 0.1] gives p_f = [-sqrt(2)/2, sqrt(2)/2, 0.1] m with d2 = 1 m, and only at theta2 = 0."""
    arm = load_robot("spherical")
    np.testing.assert_allclose(arm.fkine([math.pi / 4, 0.0, 0.1])[:3, 3], SEED_P_FINAL, atol=1e-12)
    # x^2 + y^2 = d2^2 + (s2 d3)^2 and p_f has x^2 + y^2 = 1: with d2 = 1, s2 d3 = 0
    T = np.eye(4)
    T[:3, 3] = SEED_P_FINAL
    for sol in ikine_a(arm, T):
        assert abs(math.sin(sol.q[1])) < 1e-12 and abs(sol.q[2]) == pytest.approx(0.1, abs=1e-12)
        if sol.q[2] > 0:
            assert sol.q == pytest.approx([math.pi / 4, 0.0, 0.1], abs=1e-12)


def test_seed_segment_leaves_the_workspace() -> None:
    """|a + s b|^2 = d2^2 at s = 0.10324 and s = 1 (a, b: start and direction of the segment in x-y)."""
    arm = load_robot("spherical")
    p0 = arm.fkine(SEED_Q0)[:3, 3]
    a, b = p0[:2], np.array(SEED_P_FINAL[:2]) - p0[:2]
    roots = np.sort(np.roots([b @ b, 2 * a @ b, a @ a - D2 ** 2]).real)
    assert roots == pytest.approx([0.10324, 1.0], abs=1e-5)
    s_closest = -(a @ b) / (b @ b)
    assert np.linalg.norm(a + s_closest * b) == pytest.approx(0.86981, abs=1e-5)  # 0.1302 m inside the cylinder


def test_time_grid_is_integer_steps(runs: dict[str, CLIKResult]) -> None:
    res = runs["dls"]
    N = round(SEED_TF / SEED_DT)
    assert res.t.shape == (N + 1,) and res.q.shape == (N + 1, 3) and res.qd.shape == (N + 1, 3)
    np.testing.assert_array_equal(res.t, SEED_DT * np.arange(N + 1))
    np.testing.assert_allclose(res.p_d[-1], SEED_P_FINAL, atol=1e-12)


@pytest.mark.parametrize("inversion", ["inverse", "pinv", "dls", "transpose"])
def test_error_never_below_distance_to_workspace(runs: dict[str, CLIKResult], inversion: str) -> None:
    """Physical bound: the tool is always in the workspace, so |e| >= distance of p_d from it (1e-12: rounding)."""
    res = runs[inversion]
    assert np.all(res.error_norm >= gap(res) - 1e-12)
    assert gap(res).max() == pytest.approx(0.13019, abs=1e-5)


@pytest.mark.parametrize("inversion", ["inverse", "pinv"])
def test_exact_inversion_tracks_until_the_path_leaves_the_workspace(runs: dict[str, CLIKResult], inversion: str) -> None:
    res = runs[inversion]
    inside = res.t < 1.0 - 1e-9  # the desired point is reachable until t = 1.0 s (s = 0.1033)
    assert np.all(gap(res)[inside] == 0.0)
    assert res.error_norm[inside].max() < 1e-3  # measured 4.4e-4 m
    # and then it cannot: theta2 passes 0 and the arm runs away by metres (measured 44-146 m)
    assert res.error_norm.max() > 1.0


def test_dls_bounds_joint_speed(runs: dict[str, CLIKResult]) -> None:
    inverse, pinv, dls = runs["inverse"], runs["pinv"], runs["dls"]
    assert dls.peak_joint_speed < 4.0  # measured 2.85 rad/s (joint 2)
    assert dls.qd_max.shape == (3,) and dls.qd_max.argmax() == 1
    # the plain inverse's spike: measured 3.5e9 rad/s (inverse) and 5.1e7 (pinv), > 1e7 x the DLS peak
    assert inverse.peak_joint_speed > 1e3 * dls.peak_joint_speed
    assert pinv.peak_joint_speed > 1e3 * dls.peak_joint_speed
    # the spike comes when theta2 reaches 0 at the workspace boundary, after t = 1.0 s, not near the end
    first_big = res_first(inverse, 100.0)
    assert 1.0 <= first_big < 1.2


def res_first(res: CLIKResult, speed: float) -> float:
    """Time (s) when some joint first exceeds ``speed``."""
    k = int(np.argmax(np.abs(res.qd).max(axis=1) > speed))
    return float(res.t[k])


def test_dls_leaves_the_line_by_the_unavoidable_amount(runs: dict[str, CLIKResult]) -> None:
    res = runs["dls"]
    assert res.error_norm.max() > 0.13  # the line passes 0.1302 m inside the unreachable cylinder
    assert (res.error_norm - gap(res)).max() < 5e-3  # measured 3.8 mm: it follows the nearest reachable point
    assert res.error_norm[res.t <= 0.9].max() < 1.5e-3  # measured 1.07e-3 m away from the boundary
    assert res.error_norm[-1] < 1e-5  # measured 3.5e-7 m: it ends on p_f ...
    assert abs(res.q[-1, 1]) < 0.01  # ... near theta2 = 0 (measured -0.0044 rad)


def test_transpose_is_bounded_but_lags(runs: dict[str, CLIKResult]) -> None:
    res = runs["transpose"]
    assert res.peak_joint_speed < 1.0  # measured 0.50 rad/s
    assert res.error_norm[res.t < 1.0].max() > 1e-2  # no feed-forward: measured 0.037 m lag


def test_clik_on_a_reachable_segment_converges() -> None:
    """Away from singularities every inversion keeps a straight segment to well under a millimetre."""
    arm = load_robot("spherical")
    q0 = np.array([0.2, 0.8, 0.6])
    p0 = arm.fkine(q0)[:3, 3]
    segment = straight_line(p0, p0 + [0.1, 0.05, -0.1], 1.0)
    for inversion in ("inverse", "pinv", "dls"):
        res = clik(arm, segment, q0, dt=2e-3, K=50.0, inversion=inversion, damping=1e-6)
        assert res.error_norm.max() < 1e-4  # measured ~1e-5 m: Euler lag of a 0.16 m, 1 s move
        assert res.t[-1] == pytest.approx(1.0, abs=1e-15)


def test_clik_argument_errors() -> None:
    arm = load_robot("spherical")
    segment = straight_line([0.3, 1.0, 0.3], [0.3, 1.0, 0.2], 1.0)
    with pytest.raises(ValueError, match=r"inversion: 'inverse' needs a square task Jacobian, got 2 components for 3 joints"):
        clik(arm, segment, SEED_Q0, dt=0.01, K=10.0, inversion="inverse", mask=[True, True, False])
    with pytest.raises(ValueError, match=r"inversion: expected one of"):
        clik(arm, segment, SEED_Q0, dt=0.01, K=10.0, inversion="svd")
    with pytest.raises(ValueError, match=r"tf - t0 = 1.0 s: expected a positive integer multiple of dt = 0.003 s"):
        clik(arm, segment, SEED_Q0, dt=0.003, K=10.0)


def test_clik_names_the_uncontrolled_components_and_their_miss() -> None:
    """z left out of the mask: x, y track; the z miss is reported and equals the one recomputed here."""
    arm = load_robot("spherical")
    q0 = np.array([0.2, 0.8, 0.6])
    p0 = arm.fkine(q0)[:3, 3]
    segment = straight_line(p0, p0 + [0.1, 0.05, -0.1], 1.0)
    res = clik(arm, segment, q0, dt=2e-3, K=50.0, inversion="pinv", mask=[True, True, False])
    assert res.solved == ("x", "y") and res.ignored == ("z",)
    assert res.error_norm.max() < 1e-4  # x and y as in the full task
    z_miss = max(abs(segment(float(t))[0][2] - arm.fkine(q)[2, 3]) for t, q in zip(res.t, res.q))
    assert res.ignored_error_max["z"] == pytest.approx(z_miss, rel=1e-12)
    assert z_miss > 1e-2  # the 0.1 m drop is not followed by an uncontrolled z
