"""Singularities and manipulability against closed forms derived by hand.

Closed forms (task Jacobian determinants, derived from the DH tables):
* SCARA, rows x y of joints 1-2: det [[-a1 s1 - a2 s12, -a2 s12], [a1 c1 + a2 c12, a2 c12]]
  = a1 a2 (s12 c1 - c12 s1) = a1 a2 sin(theta2); the task rows x y z yaw add a block
  with |det| = 1 (z from d3 alone, yaw from theta4 with coefficient -1), so the task
  manipulability is |a1 a2 sin(theta2)| too.
* planar3r, rows x y rz: the third column only adds the hand, |det| = |a1 a2 sin(theta2)|.
* spherical, rows x y z: in the frame turned by theta1 the columns are
  [-d2, s2 d3, 0], d3 [c2, 0, -s2], [s2, 0, c2]; the determinant is -d3^2 sin(theta2).
* arm4, rows x y z and the pitch rate about the plane normal: joint 1 moves the end
  only across the plane (speed r, its distance from the base axis), joints 2-4 only in
  the plane, as a planar 3R whose [x z pitch] determinant is a2 a3 sin(theta3):
  |det| = |r a2 a3 sin(theta3)|.

Tolerance MANIP = 1e-12: these are products of O(1) numbers computed from an SVD;
rounding is ~1e-15 and any wrong term changes the value by O(0.1).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from model import load_robot
from model.robot import Robot
from model.singularity import SingularityReport, manipulability, singularities, task_jacobian

MANIP = 1e-12


@pytest.fixture(scope="module")
def robots() -> dict[str, Robot]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scara and puma560 inertias break the triangle inequality (their files say so)
        return {name: load_robot(name) for name in ("scara", "planar3r", "arm4", "spherical", "puma560")}


def random_q(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(*robot.qlim)


@pytest.mark.parametrize("theta2, word", [(0.0, "stretched"), (math.pi, "folded"), (-math.pi, "folded")])
def test_scara_singular_at_elbow(robots: dict[str, Robot], theta2: float, word: str) -> None:
    scara = robots["scara"]
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = random_q(scara, rng)
        q[1] = theta2
        rep = singularities(scara, q)
        assert isinstance(rep, SingularityReport)
        assert rep.singular and rep.rank == 3 and rep.task == ("x", "y", "z", "rz")
        assert rep.reasons[0].startswith("task Jacobian (4 x 4, rows x y z rz) has rank 3 < 4")
        assert any(r.startswith(f"elbow {word} (theta2 = ") for r in rep.reasons)
        J, _ = task_jacobian(scara, q)
        # the reported joint motion moves nothing: |J v| ~ rounding of J (~1e-15 x 4 m)
        assert rep.null_space.shape == (1, 4) and np.abs(J @ rep.null_space[0]).max() < 1e-12


def test_scara_not_singular_elsewhere(robots: dict[str, Robot]) -> None:
    """Away from theta2 = 0, pi the SCARA is never singular, though its 6 x 4 jacob0 never has rank 6."""
    scara = robots["scara"]
    rng = np.random.default_rng(2)
    for _ in range(300):
        q = random_q(scara, rng)
        if abs(math.sin(q[1])) < 1e-3:
            continue
        rep = singularities(scara, q)
        assert not rep.singular and rep.rank == 4 and rep.reasons == [] and rep.null_space.shape == (0, 4)
        assert np.linalg.matrix_rank(scara.jacob0(q)) == 4
    # close to, but not at, the elbow singularity: sigma_min / sigma_max ~ 2e-4 >> tol 1e-6
    assert not singularities(scara, [0.3, 1e-3, 1.0, 0.0]).singular


def test_scara_manipulability_closed_form(robots: dict[str, Robot]) -> None:
    scara = robots["scara"]
    a1 = a2 = 2.0
    rng = np.random.default_rng(3)
    for _ in range(100):
        q = random_q(scara, rng)
        expected = abs(a1 * a2 * math.sin(q[1]))
        assert manipulability(scara, q, [True, True, False, False, False, False]) == pytest.approx(expected, abs=MANIP)
        assert manipulability(scara, q, "task") == pytest.approx(expected, abs=MANIP)
        assert scara.manipulability(q, "task") == pytest.approx(expected, abs=MANIP)
        assert singularities(scara, q).manipulability == pytest.approx(expected, abs=MANIP)
        # all six rows of a 4-joint arm: J J^T is 6 x 6 of rank <= 4, so Yoshikawa's measure is 0
        assert manipulability(scara, q, "all") == 0.0
        # rot rows: omega = (theta1' + theta2' - theta4') z0, a 3 x 4 of rank 1
        assert manipulability(scara, q, "rot") == pytest.approx(0.0, abs=MANIP)


def test_planar3r_manipulability_closed_form(robots: dict[str, Robot]) -> None:
    robot = robots["planar3r"]
    rng = np.random.default_rng(4)
    for _ in range(100):
        q = random_q(robot, rng)
        assert manipulability(robot, q, "task") == pytest.approx(abs(0.5 * 0.4 * math.sin(q[1])), abs=MANIP)
        assert manipulability(robot, q, [1, 1, 0, 0, 0, 1]) == pytest.approx(abs(0.5 * 0.4 * math.sin(q[1])), abs=MANIP)
    rep = singularities(robot, [0.3, 0.0, 0.5])
    assert rep.singular and any(r.startswith("elbow stretched (theta2 = 0)") for r in rep.reasons)


def test_spherical_manipulability_and_singularities(robots: dict[str, Robot]) -> None:
    robot = robots["spherical"]
    rng = np.random.default_rng(5)
    for _ in range(100):
        q = random_q(robot, rng)
        assert manipulability(robot, q, "trans") == pytest.approx(q[2] ** 2 * abs(math.sin(q[1])), abs=MANIP)
        assert not singularities(robot, q).singular
    for theta2, which in ((0.0, "0"), (math.pi, "pi")):
        rep = singularities(robot, [0.4, theta2, 0.3])
        assert rep.singular and rep.rank == 2
        assert any(r.startswith(f"boom parallel to the joint-1 axis (theta2 = {which})") for r in rep.reasons)
    rep = singularities(robot, [0.4, 0.7, 0.0])
    assert rep.singular and any(r.startswith("boom retracted to d3 = 0") for r in rep.reasons)


def test_seed004_end_point_is_singular(robots: dict[str, Robot]) -> None:
    """Seed 004: p_f is reached at q_f = [pi/4, 0, 0.1], where theta2 = 0 is singular."""
    robot = robots["spherical"]
    rep = singularities(robot, [math.pi / 4, 0.0, 0.1])
    assert rep.singular and rep.manipulability == pytest.approx(0.0, abs=MANIP)
    # the lost direction is along the shoulder offset z1 = [-s1, c1, 0]: no joint rate gives it
    J, _ = task_jacobian(robot, [math.pi / 4, 0.0, 0.1])
    z1 = np.array([-math.sqrt(0.5), math.sqrt(0.5), 0.0])
    assert np.abs(z1 @ J).max() < MANIP


def test_arm4_manipulability_closed_form(robots: dict[str, Robot]) -> None:
    robot = robots["arm4"]
    a1, a2, a3 = 0.05, 0.4, 0.35
    rng = np.random.default_rng(6)
    for _ in range(100):
        q = random_q(robot, rng)
        r = a1 + a2 * math.cos(q[1]) + a3 * math.cos(q[1] + q[2])
        assert manipulability(robot, q, "task") == pytest.approx(abs(r * a2 * a3 * math.sin(q[2])), abs=MANIP)
    rep = singularities(robot, [0.2, 0.5, 0.0, 0.3])
    assert rep.singular and any(r.startswith("elbow stretched (theta3 = 0)") for r in rep.reasons)
    # end point on the base axis: a1 + a2 c2 + a3 c23 = 0 with theta2 = pi/2: c23 = -a1 / a3
    t3 = math.acos(-a1 / a3) - math.pi / 2
    rep = singularities(robot, [0.2, math.pi / 2, t3, 0.1])
    assert rep.singular and any(r.startswith("end point on the base axis") for r in rep.reasons)


def test_puma560_generic_reason(robots: dict[str, Robot]) -> None:
    """No named conditions for an unrecognised structure, but the rank deficiency is reported (wrist theta5 = 0)."""
    puma = robots["puma560"]
    rep = singularities(puma, [0.1, 0.6, -2.5, 0.3, 0.0, 0.2])
    assert rep.singular and rep.rank == 5 and rep.task == ("x", "y", "z", "rx", "ry", "rz")
    assert len(rep.reasons) == 1 and rep.reasons[0].startswith("task Jacobian (6 x 6, rows x y z rx ry rz) has rank 5 < 6")
    assert not singularities(puma, [0.1, 0.6, -2.5, 0.3, 0.4, 0.2]).singular


@pytest.mark.parametrize("name", ["planar3r", "arm4", "spherical"])
def test_new_robot_rest_poses_not_singular(robots: dict[str, Robot], name: str) -> None:
    rep = singularities(robots[name], robots[name].q_rest)
    assert not rep.singular and rep.reasons == []


def test_seed000_rest_and_place_poses_are_singular(robots: dict[str, Robot]) -> None:
    """Seed 000's qRiposo = [0 0 1 0], qC and qD = [pi/2 0 (1|3) 0] all have the elbow stretched."""
    scara = robots["scara"]
    for q in ([0, 0, 1, 0], [math.pi / 2, 0, 1, 0], [math.pi / 2, 0, 3, 0]):
        rep = singularities(scara, q)
        assert rep.singular and any(r.startswith("elbow stretched") for r in rep.reasons)
    assert not singularities(scara, [math.pi / 2, math.pi / 2, 1, 0]).singular  # qA


def test_axes_validation(robots: dict[str, Robot]) -> None:
    scara = robots["scara"]
    with pytest.raises(ValueError, match=r"axes: expected 'all', 'trans', 'rot', 'task' or 6 booleans, got 'xyz'"):
        manipulability(scara, [0, 0.5, 1, 0], "xyz")
    with pytest.raises(ValueError, match=r"axes: expected 6 booleans"):
        manipulability(scara, [0, 0.5, 1, 0], [True, False])
