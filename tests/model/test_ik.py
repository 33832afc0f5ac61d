"""Inverse kinematics: closed forms (round trips, branches, errors), numeric LM, seed errata.

Tolerances
----------
ROUND_TRIP = 1e-9 (m, rad): the closed forms are a few dozen floating-point operations
on lengths of 0.05-4 m; their rounding error is ~1e-14 (measured worst 3e-14). A wrong
sign or term in a formula gives errors of order the link lengths, so 1e-9 separates
the two by more than four orders of magnitude either way.
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest

from model import load_robot
from model.closed_form import POSE_TOL, Arm4, Scara, SphericalRRP, closed_form_for
from model.description import description_from_dict
from model.loading import load_description
from model.ik import IKSolution, NoClosedFormError, WorkspaceError, default_mask, ikine, ikine_a, pose_error
from model.robot import Robot

ROUND_TRIP = 1e-9
N_POSES = 250
CLOSED_FORM_ROBOTS = ("scara", "planar3r", "planar2r", "arm4", "spherical")

# Components of the pose each closed form uses (the rest is checked through reproduces_pose).
POSITION_ONLY = {"planar2r", "spherical"}


@pytest.fixture(scope="module")
def robots() -> dict[str, Robot]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scara and puma560 inertias break the triangle inequality (their files say so)
        return {name: load_robot(name) for name in (*CLOSED_FORM_ROBOTS, "puma560")}


def random_q(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    lo, hi = robot.qlim
    return rng.uniform(lo, hi)


def wrapped_distance(robot: Robot, qa: np.ndarray, qb: np.ndarray) -> float:
    """Largest joint difference, revolute differences taken modulo 2 pi."""
    d = qa - qb
    for i, lk in enumerate(robot.description.links):
        if lk.is_revolute:
            d[i] = math.remainder(d[i], 2 * math.pi)
    return float(np.abs(d).max())


# --------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("name", CLOSED_FORM_ROBOTS)
def test_closed_form_round_trip(robots: dict[str, Robot], name: str) -> None:
    """fkine -> ikine_a -> fkine on N_POSES seeded poses: every solution reaches the target; q is among them."""
    robot = robots[name]
    rng = np.random.default_rng(20240601)
    worst = 0.0
    for _ in range(N_POSES):
        q = random_q(robot, rng)
        T = robot.fkine(q)
        sols = ikine_a(robot, T)
        assert sols, "no solution for a pose fkine produced"
        for sol in sols:
            err = pose_error(robot.fkine(sol.q), T)
            used = err[:3] if name in POSITION_ONLY else err
            if name == "arm4":  # position and hand axis x_E are what arm4 uses
                used = np.r_[err[:3], robot.fkine(sol.q)[:3, 0] - T[:3, 0]]
            worst = max(worst, float(np.abs(used).max()))
            assert sol.reproduces_pose == bool(np.abs(err).max() <= 1e-6)
        # the configuration we started from is one of the solutions
        assert min(wrapped_distance(robot, s.q, q) for s in sols) < 1e-7  # sensitivity ~1e-15/|sin(elbow)|
    assert worst < ROUND_TRIP, f"{name}: worst round-trip error {worst:.3g}"


@pytest.mark.parametrize(
    "name, labels",
    [
        ("scara", [("lefty", "righty")]),
        ("planar3r", [("elbow-up", "elbow-down")]),
        ("planar2r", [("elbow-up", "elbow-down")]),
        ("arm4", [("front/elbow-up", "front/elbow-down", "back/elbow-up", "back/elbow-down"),
                  ("front/elbow-up", "front/elbow-down")]),
        ("spherical", [("shoulder-left", "shoulder-left/negative-stroke",
                        "shoulder-right", "shoulder-right/negative-stroke")]),
    ],
)
def test_branch_labels(robots: dict[str, Robot], name: str, labels: list[tuple[str, ...]]) -> None:
    robot = robots[name]
    rng = np.random.default_rng(7)
    seen = set()
    for _ in range(100):
        sols = ikine_a(robot, robot.fkine(random_q(robot, rng)))
        got = tuple(s.branch for s in sols)
        assert got in labels
        seen.add(got)
        assert all(isinstance(s, IKSolution) and s.q.shape == (robot.n,) for s in sols)
    assert seen == set(labels)


def test_branch_signs_follow_their_labels(robots: dict[str, Robot]) -> None:
    """elbow-up is the negative elbow angle (slides 47-48); righty is theta2 > 0; negative-stroke is d3 < 0."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        for name, joint in (("planar3r", 1), ("arm4", 2)):
            robot = robots[name]
            for s in ikine_a(robot, robot.fkine(random_q(robot, rng))):
                assert (s.q[joint] < 0) == s.branch.endswith("elbow-up")
        scara = robots["scara"]
        for s in ikine_a(scara, scara.fkine(random_q(scara, rng))):
            assert (s.q[1] > 0) == (s.branch == "righty")
        sph = robots["spherical"]
        for s in ikine_a(sph, sph.fkine(random_q(sph, rng))):
            assert (s.q[2] < 0) == s.branch.endswith("negative-stroke")
            # shoulder-left: seen from above, the offset point d2 z1 is counter-clockwise of the target
            p = sph.fkine(s.q)[:3, 3]
            offset = sph.fkine_all(s.q)[2][:3, 3]
            assert (p[0] * offset[1] - p[1] * offset[0] > 0) == s.branch.startswith("shoulder-left")


def test_planar3r_elbow_up_is_geometrically_up(robots: dict[str, Robot]) -> None:
    """With the wrist ahead of the shoulder (x > 0, base y up) elbow-up puts the elbow above the shoulder-wrist line."""
    robot = robots["planar3r"]
    T = robot.fkine([0.2, -0.9, 0.3])
    for s in ikine_a(robot, T):
        frames = robot.fkine_all(s.q)
        elbow, wrist = frames[1][:3, 3], frames[2][:3, 3]
        assert wrist[0] > 0
        above = elbow[1] > wrist[1] / wrist[0] * elbow[0]
        assert above == (s.branch == "elbow-up")


def test_arm4_back_branch_rolls_the_hand(robots: dict[str, Robot]) -> None:
    """Back solutions reach the same point and hand axis with the plane normal z_E reversed."""
    robot = robots["arm4"]
    T = robot.fkine([0.4, 1.2, -1.8, 0.2])  # wrist 0.48 m from the base axis: the back branch reaches it too
    sols = ikine_a(robot, T)
    assert len(sols) == 4
    for s in sols:
        Ts = robot.fkine(s.q)
        assert np.abs(Ts[:3, 3] - T[:3, 3]).max() < ROUND_TRIP
        assert np.abs(Ts[:3, 0] - T[:3, 0]).max() < ROUND_TRIP
        normal_dot = float(Ts[:3, 2] @ T[:3, 2])
        assert normal_dot == pytest.approx(1.0 if s.branch.startswith("front") else -1.0, abs=ROUND_TRIP)
        assert s.reproduces_pose == s.branch.startswith("front")


def test_within_limits_flag(robots: dict[str, Robot]) -> None:
    """Solutions outside qlim are kept and flagged; the flag agrees with qlim."""
    rng = np.random.default_rng(11)
    flagged = 0
    for name in CLOSED_FORM_ROBOTS:
        robot = robots[name]
        lo, hi = robot.qlim
        for _ in range(40):
            for s in ikine_a(robot, robot.fkine(random_q(robot, rng))):
                assert s.within_limits == bool(np.all(s.q >= lo) and np.all(s.q <= hi))
                flagged += not s.within_limits
    assert flagged > 0  # e.g. every spherical negative-stroke solution


def test_solutions_at_the_workspace_boundary(robots: dict[str, Robot]) -> None:
    """Stretched SCARA: both branches are returned and coincide."""
    scara = robots["scara"]
    sols = ikine_a(scara, scara.fkine([0.3, 0.0, 1.2, 0.1]))
    assert [s.branch for s in sols] == ["lefty", "righty"]
    assert np.abs(sols[0].q - sols[1].q).max() < 1e-7  # theta2 = +-sqrt(rounding) ~ 1e-8 at c2 = 1


def test_same_geometry_from_a_user_file_is_recognised() -> None:
    """Recognition is by DH numbers, not name: a renamed, rescaled SCARA with joint offsets gets the closed form."""
    data = {
        "name": "my_scara",
        "links": [
            {"joint": "revolute", "a": 0.35, "alpha": 0.0, "d": 0.4, "theta": 0.1},
            {"joint": "revolute", "a": 0.25, "alpha": -math.pi, "d": 0.02, "theta": -0.2},
            {"joint": "prismatic", "a": 0.0, "alpha": 0.0, "d": 0.05, "theta": 0.3, "qlim": [0.0, 0.3]},
            {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 0.08, "theta": 0.4},
        ],
    }
    robot = Robot(description_from_dict(data))
    assert isinstance(closed_form_for(robot.description), Scara)
    rng = np.random.default_rng(5)
    for _ in range(50):
        q = rng.uniform([-2, -2, 0, -2], [2, 2, 0.3, 2])
        T = robot.fkine(q)
        sols = ikine_a(robot, T)
        assert max(np.abs(pose_error(robot.fkine(s.q), T)).max() for s in sols) < ROUND_TRIP
        assert min(wrapped_distance(robot, s.q, q) for s in sols) < 1e-7


def test_structures_recognised_from_builtin_files(robots: dict[str, Robot]) -> None:
    kinds = {name: getattr(closed_form_for(robots[name].description), "kind", None) for name in robots}
    assert kinds == {"scara": "scara", "planar3r": "planar3r", "planar2r": "planar2r", "arm4": "arm4",
                     "spherical": "spherical", "puma560": None}


# --------------------------------------------------------------------------- errors


def test_scara_out_of_reach_message(robots: dict[str, Robot]) -> None:
    T = robots["scara"].fkine([0.0, 0.5, 1.0, 0.0])
    T[:3, 3] = [4.3, 0.0, -1.0]
    with pytest.raises(WorkspaceError, match=r"scara: target p = \[4.3, 0, -1\] m out of reach: wrist axis at "
                                             r"distance 4.3 m from the shoulder axis, reachable range \[0, 4\] m"):
        ikine_a(robots["scara"], T)


def test_scara_tilted_tool_message(robots: dict[str, Robot]) -> None:
    """A 4-DOF SCARA's tool z must point down (the DH table's alpha2 = pi)."""
    scara = robots["scara"]
    T = scara.fkine([0.3, 0.5, 1.0, 0.0])
    tilt = 0.01
    Rx = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
    T[:3, :3] = T[:3, :3] @ Rx
    with pytest.raises(WorkspaceError, match=r"tool z axis .* is tilted 0.01 rad from \[0, 0, -1\]; "
                                             r"a 4-DOF SCARA cannot roll or pitch"):
        ikine_a(scara, T)
    # below POSE_TOL the tilt is taken as rounding, and the pose is solved
    tiny = 0.1 * POSE_TOL
    T2 = scara.fkine([0.3, 0.5, 1.0, 0.0])
    T2[:3, :3] = T2[:3, :3] @ np.array([[1, 0, 0], [0, math.cos(tiny), -math.sin(tiny)], [0, math.sin(tiny), math.cos(tiny)]])
    assert len(ikine_a(scara, T2)) == 2


def test_planar3r_errors(robots: dict[str, Robot]) -> None:
    robot = robots["planar3r"]
    T = robot.fkine(robot.q_rest)
    T_far = T.copy()
    T_far[:3, 3] = [1.5, 0.0, 0.0]
    with pytest.raises(WorkspaceError, match=r"wrist point at distance 1.35 m from the shoulder axis, "
                                             r"reachable range \[0.1, 0.9\] m"):
        ikine_a(robot, T_far)
    T_off = T.copy()
    T_off[2, 3] = 0.01
    with pytest.raises(WorkspaceError, match=r"0.01 m off the arm plane z = 0 m"):
        ikine_a(robot, T_off)


def test_arm4_errors(robots: dict[str, Robot]) -> None:
    robot = robots["arm4"]
    T = robot.fkine(robot.q_rest)
    yaw = 0.2  # turn the hand axis out of the arm plane
    Rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    T_yaw = T.copy()
    T_yaw[:3, :3] = Rz @ T[:3, :3]
    with pytest.raises(WorkspaceError, match=r"hand axis .* leaves the vertical plane through the base axis .* by 0.2 rad"):
        ikine_a(robot, T_yaw)
    T_far = T.copy()
    T_far[:3, 3] = [2.0, 0.0, 0.35]
    with pytest.raises(WorkspaceError, match=r"wrist point at distance 1.95 m from the shoulder axis, reachable range "
                                             r"\[0.05, 0.75\] m \(joint 2; reaching over the base axis it would be at 2.05 m\)"):
        ikine_a(robot, T_far)


def test_spherical_inside_offset_cylinder(robots: dict[str, Robot]) -> None:
    robot = robots["spherical"]
    T = np.eye(4)
    T[:3, 3] = [0.3, 0.4, 0.2]
    with pytest.raises(WorkspaceError, match=r"at distance 0.5 m from the joint-1 axis, reachable range \[1, inf\) m: "
                                             r"the shoulder offset d2 = 1 m"):
        ikine_a(robot, T)


def test_no_closed_form(robots: dict[str, Robot]) -> None:
    with pytest.raises(NoClosedFormError, match=r"robot 'puma560' \(joints RRRRRR\): no closed-form inverse kinematics"):
        ikine_a(robots["puma560"], np.eye(4))
    assert issubclass(NoClosedFormError, LookupError) and issubclass(WorkspaceError, ValueError)


# --------------------------------------------------------------------------- numeric


def test_ikine_puma560_converges_from_random_starts(robots: dict[str, Robot]) -> None:
    robot = robots["puma560"]
    rng = np.random.default_rng(42)
    for _ in range(12):
        T = robot.fkine(random_q(robot, rng))
        res = ikine(robot, T, q0=random_q(robot, rng))
        assert res.success, res.reason
        assert res.reason == "converged" and res.residual < 1e-10
        # residual 1e-10 bounds the pose error; 1e-9 leaves room for the log-map rounding
        assert np.abs(pose_error(robot.fkine(res.q), T)).max() < 1e-9
        assert np.all(res.q >= robot.qlim[0]) and np.all(res.q <= robot.qlim[1])


def test_ikine_scara_with_mask(robots: dict[str, Robot]) -> None:
    robot = robots["scara"]
    assert default_mask(robot).tolist() == [1, 1, 1, 0, 0, 1]
    rng = np.random.default_rng(43)
    for mask in (None, [1, 1, 1, 0, 0, 1]):
        for _ in range(10):
            T = robot.fkine(random_q(robot, rng))
            res = ikine(robot, T, q0=random_q(robot, rng), mask=mask)
            assert res.success, res.reason
            assert np.abs(pose_error(robot.fkine(res.q), T)).max() < 1e-9


def test_ikine_reports_unreachable_target(robots: dict[str, Robot]) -> None:
    puma = robots["puma560"]
    T = puma.fkine(puma.q_rest)
    T[:3, 3] = [2.0, 0.0, 0.0]  # the Puma reaches about 0.9 m from its shoulder
    res = ikine(puma, T, slimit=5)
    assert not res.success and res.searches == 5
    assert res.residual > 0.5
    assert re.search(r"no solution with residual < 1e-10 in 5 searches of 60 iterations.*"
                     r"the target is probably outside the workspace", res.reason)
    scara = robots["scara"]
    T = scara.fkine([0.0, 0.5, 1.0, 0.0])
    T[:3, 3] = [5.0, 0.0, -1.0]
    res = ikine(scara, T, slimit=3)
    assert not res.success and "position error 1 m" in res.reason  # the arm stretches to 4 m: 1 m short


def test_ikine_needs_a_mask_for_an_unknown_short_robot() -> None:
    data = {"name": "odd4", "links": [
        {"joint": "revolute", "a": 0.3, "alpha": 0.5, "d": 0.1, "theta": 0.0},
        {"joint": "revolute", "a": 0.3, "alpha": 0.0, "d": 0.0, "theta": 0.0},
        {"joint": "revolute", "a": 0.2, "alpha": 0.3, "d": 0.0, "theta": 0.0},
        {"joint": "prismatic", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0},
    ]}
    robot = Robot(description_from_dict(data))
    with pytest.raises(ValueError, match=r"mask: robot 'odd4' has 4 joints and no recognised structure.*give 6 weights"):
        ikine(robot, robot.fkine([0.1, 0.2, 0.3, 0.1]))
    with pytest.raises(NoClosedFormError, match="robot 'odd4'"):
        ikine_a(robot, np.eye(4))
    res = ikine(robot, robot.fkine([0.1, 0.2, 0.3, 0.1]), mask=[1, 1, 1, 0, 0, 0])
    assert res.success, res.reason


@pytest.mark.parametrize("name", ["scara", "planar3r", "arm4", "spherical"])
def test_closed_form_agrees_with_numeric(robots: dict[str, Robot], name: str) -> None:
    """The numeric solution from a random start is one of the closed-form solutions."""
    robot = robots[name]
    rng = np.random.default_rng(44)
    for _ in range(10):
        T = robot.fkine(random_q(robot, rng))
        res = ikine(robot, T, q0=random_q(robot, rng))
        assert res.success, res.reason
        # residual 1e-10 -> joint error ~1e-10 x cond(J) (< 1e4 away from singularities)
        assert min(wrapped_distance(robot, s.q, res.q) for s in ikine_a(robot, T)) < 1e-6


# --------------------------------------------------------------------------- seed errata


def test_seed000_scara_tool_position(robots: dict[str, Robot]) -> None:
    """Seed 000 o_4 = [a1 c1 + a2 c12, a1 s2 + a2 s12, d3 - d4] is wrong: it is [.., a1 s1 + a2 s12, -d3 - d4]."""
    scara = robots["scara"]
    a1 = a2 = 2.0
    q = np.array([0.7, -1.1, 1.3, 0.4])
    d4 = scara.description.links[3].d
    c1, s1, s2 = math.cos(q[0]), math.sin(q[0]), math.sin(q[1])
    c12, s12 = math.cos(q[0] + q[1]), math.sin(q[0] + q[1])
    p = scara.fkine(q)[:3, 3]
    np.testing.assert_allclose(p, [a1 * c1 + a2 * c12, a1 * s1 + a2 * s12, -q[2] - d4], atol=1e-12)
    seed = [a1 * c1 + a2 * c12, a1 * s2 + a2 * s12, q[2] - d4]
    assert abs(p[1] - seed[1]) > 0.1 and abs(p[2] - seed[2]) > 0.1


def test_seed000_scara_jacobian_yaw_sign(robots: dict[str, Robot]) -> None:
    """Seed 000 J[6, 4] = 1 (and J22 = [0 0 1]) is wrong: z3 = -k, so the wrist column's yaw entry is -1."""
    scara = robots["scara"]
    a1 = a2 = 2.0
    q = np.array([0.7, -1.1, 1.3, 0.4])
    s1, c1 = math.sin(q[0]), math.cos(q[0])
    s12, c12 = math.sin(q[0] + q[1]), math.cos(q[0] + q[1])
    corrected = np.array([
        [-a1 * s1 - a2 * s12, -a2 * s12, 0, 0],
        [a1 * c1 + a2 * c12, a2 * c12, 0, 0],
        [0, 0, -1, 0],
        [0, 0, 0, 0],
        [0, 0, 0, 0],
        [1, 1, 0, -1],
    ])
    np.testing.assert_allclose(scara.jacob0(q), corrected, atol=1e-12)
    # and the yaw rate of the tool is theta1' + theta2' - theta4', as R = Rz(theta1 + theta2 - theta4) diag(1, -1, -1)
    R = scara.fkine(q)[:3, :3]
    assert math.atan2(R[1, 0], R[0, 0]) == pytest.approx(q[0] + q[1] - q[3], abs=1e-12)


def test_seed000_scara_inverse_kinematics(robots: dict[str, Robot]) -> None:
    """Seed 000 IK: d3 = o_z + d4 has the wrong sign (d3 = -o_z - d4), and theta2 = Atan(c2, +-sqrt(1 - c2))
    needs sqrt(1 - c2^2); theta1 and theta4 = theta1 + theta2 - Atan(r11, r12) are right (Atan(cos, sin))."""
    scara = robots["scara"]
    a1 = a2 = 2.0
    d4 = scara.description.links[3].d
    q = np.array([0.7, -1.1, 1.3, 0.4])
    T = scara.fkine(q)
    o, R = T[:3, 3], T[:3, :3]
    c2 = (o[0] ** 2 + o[1] ** 2 - a1 ** 2 - a2 ** 2) / (2 * a1 * a2)
    t2 = math.atan2(-math.sqrt(1 - c2 ** 2), c2)
    t1 = math.atan2(o[1], o[0]) - math.atan2(a2 * math.sin(t2), a1 + a2 * math.cos(t2))
    t4 = t1 + t2 - math.atan2(R[0, 1], R[0, 0])
    np.testing.assert_allclose([t1, t2, -o[2] - d4, t4], q, atol=1e-12)
    assert abs((o[2] + d4) - q[2]) > 1.0  # the seed's d3
    # the seed's theta2 does not even have the cosine c2 that the distance requires (measured 0.07 off)
    assert abs(math.cos(math.atan2(-math.sqrt(1 - c2), c2)) - c2) > 0.05
    sol = next(s for s in ikine_a(scara, T) if s.branch == "lefty")
    np.testing.assert_allclose(sol.q, q, atol=1e-12)


def test_seed000_pick_and_place_rest_pose(robots: dict[str, Robot]) -> None:
    """Seed 000 MATLAB: PosPinza0 = fkine(SCARA, q) uses the symbolic q, not qRiposo; the rest tool pose is this."""
    scara = robots["scara"]
    T = scara.fkine([0.0, 0.0, 1.0, 0.0])
    np.testing.assert_allclose(T, [[1, 0, 0, 4], [0, -1, 0, 0], [0, 0, -1, -1], [0, 0, 0, 1]], atol=1e-12)


def test_seed001_planar3r_slides_T3(robots: dict[str, Robot]) -> None:
    """Slides 43-46: T3 = [[c123, -s123, L1 c1 + L2 c12], [s123, c123, H + L1 s1 + L2 s12]] at the joint-3 axis."""
    robot = robots["planar3r"]
    L1, L2, L3, H = 0.5, 0.4, 0.15, 0.4
    rng = np.random.default_rng(8)
    for _ in range(20):
        q = random_q(robot, rng)
        t1, t12, t123 = q[0], q[0] + q[1], q.sum()
        T = robot.fkine(q)
        wrist = T[:3, 3] - L3 * T[:3, 0]  # the slides' frame is on the joint-3 axis
        np.testing.assert_allclose(
            [wrist[0], wrist[1] + H], [L1 * math.cos(t1) + L2 * math.cos(t12), H + L1 * math.sin(t1) + L2 * math.sin(t12)],
            atol=1e-12)
        np.testing.assert_allclose(T[:2, :2], [[math.cos(t123), -math.sin(t123)], [math.sin(t123), math.cos(t123)]], atol=1e-12)


def test_seed001_arm4_slides_T4(robots: dict[str, Robot]) -> None:
    """Slide 55: T4 of the 4-DOF arm equals our fkine (DH regrouping of A1..A4)."""
    robot = robots["arm4"]
    H, L1, L2, L3 = 0.35, 0.05, 0.4, 0.35
    rng = np.random.default_rng(9)
    for _ in range(20):
        t1, t2, t3, t4 = random_q(robot, rng)
        c1, s1 = math.cos(t1), math.sin(t1)
        c234, s234 = math.cos(t2 + t3 + t4), math.sin(t2 + t3 + t4)
        reach = L1 + L2 * math.cos(t2) + L3 * math.cos(t2 + t3)
        slides = np.array([
            [c1 * c234, -c1 * s234, s1, c1 * reach],
            [s1 * c234, -s1 * s234, -c1, s1 * reach],
            [s234, c234, 0, L2 * math.sin(t2) + L3 * math.sin(t2 + t3) + H],
            [0, 0, 0, 1],
        ])
        np.testing.assert_allclose(robot.fkine([t1, t2, t3, t4]), slides, atol=1e-12)


def test_seed001_arm4_elbow_cosine_is_c3(robots: dict[str, Robot]) -> None:
    """Slide 57 writes c2 = ((rho - L1)^2 + (z - H)^2 - L2^2 - L3^2) / (2 L2 L3): that quotient is cos(theta3)."""
    robot = robots["arm4"]
    H, L1, L2, L3 = 0.35, 0.05, 0.4, 0.35
    q = np.array([0.3, 0.9, -1.2, 0.5])
    p = robot.fkine(q)[:3, 3]
    rho = math.hypot(p[0], p[1])
    quotient = ((rho - L1) ** 2 + (p[2] - H) ** 2 - L2 ** 2 - L3 ** 2) / (2 * L2 * L3)
    assert quotient == pytest.approx(math.cos(q[2]), abs=1e-12)
    assert abs(quotient - math.cos(q[1])) > 0.1


def test_seed001_homogeneous_inverse() -> None:
    """Slide 33 equates T with [n o a | -p.n -p.o -p.a]: that matrix is T^-1, not T."""
    rng = np.random.default_rng(10)
    A = rng.normal(size=(3, 3))
    R = np.linalg.qr(A)[0] * np.sign(np.linalg.det(np.linalg.qr(A)[0]))
    p = rng.normal(size=3)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    slide = np.eye(4)
    slide[:3, :3] = R.T
    slide[:3, 3] = [-p @ R[:, 0], -p @ R[:, 1], -p @ R[:, 2]]
    np.testing.assert_allclose(slide, np.linalg.inv(T), atol=1e-12)
    assert np.abs(slide - T).max() > 0.1


def test_seed001_matrix_product_example() -> None:
    """Slide 19: C = A B is right, its rule c_ij = c_i1 b_1j + ... must read a_i1 b_1j + ..."""
    A = np.array([[1, 0, 2], [0, 2, 1]])
    B = np.array([[2, 3, 0, 1], [4, 2, 1, 0], [0, 3, 2, 1]])
    C = np.array([[sum(A[i, k] * B[k, j] for k in range(3)) for j in range(4)] for i in range(2)])
    np.testing.assert_array_equal(C, [[2, 9, 4, 3], [8, 7, 4, 1]])


def test_seed004_spherical_forward_kinematics(robots: dict[str, Robot]) -> None:
    """Seed 004 T(q) (a product A1 A2 A3, which the seed writes as a sum) and p(q) with d2 = 1 m."""
    robot = robots["spherical"]
    rng = np.random.default_rng(12)
    for _ in range(20):
        t1, t2, d3 = random_q(robot, rng)
        c1, s1, c2, s2 = math.cos(t1), math.sin(t1), math.cos(t2), math.sin(t2)
        seed_T = np.array([
            [c1 * c2, -s1, c1 * s2, c1 * s2 * d3 - s1],
            [s1 * c2, c1, s1 * s2, s1 * s2 * d3 + c1],
            [-s2, 0, c2, c2 * d3],
            [0, 0, 0, 1],
        ])
        np.testing.assert_allclose(robot.fkine([t1, t2, d3]), seed_T, atol=1e-12)


def test_seed004_orientation_is_not_theta1_plus_theta2(robots: dict[str, Robot]) -> None:
    """Seed 004 sec. 2.2 gives phi_e = theta1 + theta2 as the Euler (ZYZ) orientation; it is (theta1, theta2, 0)."""
    robot = robots["spherical"]
    q = np.array([0.4, 0.7, 0.5])
    R = robot.fkine(q)[:3, :3]
    phi = math.atan2(R[1, 2], R[0, 2])
    theta = math.atan2(math.hypot(R[0, 2], R[1, 2]), R[2, 2])
    psi = math.atan2(R[2, 1], -R[2, 0])
    np.testing.assert_allclose([phi, theta, psi], [q[0], q[1], 0.0], atol=1e-12)


def test_seed004_initial_point(robots: dict[str, Robot]) -> None:
    """Seed 004 p_i = [sqrt(3/2), 1, sqrt(3/4)] m is not the tool position at q(0) = [0, pi/4, 0.5]: [sqrt(2)/4, 1, sqrt(2)/4]."""
    p = robots["spherical"].fkine([0.0, math.pi / 4, 0.5])[:3, 3]
    np.testing.assert_allclose(p, [math.sqrt(2) / 4, 1.0, math.sqrt(2) / 4], atol=1e-12)
    assert np.abs(p - [math.sqrt(1.5), 1.0, math.sqrt(0.75)]).max() > 0.5


# --------------------------------------------------------------------------- robot files


@pytest.mark.parametrize("name", ["planar3r", "arm4", "spherical"])
def test_new_robot_files_are_physical(name: str) -> None:
    """Loads without an inertia warning; every link has mass, motor data and limits."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        desc = load_description(name)
    for lk in desc.links:
        assert lk.mass > 0 and lk.motor_inertia > 0 and lk.gear_ratio != 0 and lk.viscous_friction > 0
        assert lk.qlim is not None and lk.qlim[0] < lk.qlim[1]
        eig = np.linalg.eigvalsh(lk.inertia_matrix)
        assert eig[0] > 0 and eig[0] + eig[1] >= eig[2]
    assert desc.rest is not None
    assert np.all(desc.q_rest >= desc.qlim[0]) and np.all(desc.q_rest <= desc.qlim[1])
    structure = {"planar3r": "planar3r", "arm4": Arm4.kind, "spherical": SphericalRRP.kind}[name]
    assert closed_form_for(desc).kind == structure


def _with(desc, **top):
    """``desc`` as a file dict with extra top-level keys (base, tool, convention) and flipped links."""
    import dataclasses

    flips = top.pop("flip", ())
    links = tuple(dataclasses.replace(lk, flip=i in flips) for i, lk in enumerate(desc.links))
    base = description_from_dict({"name": desc.name, "links": [{"joint": "revolute", "a": 0, "alpha": 0, "d": 0, "theta": 0}],
                                  **top}, "with.toml")
    return dataclasses.replace(desc, links=links, base=base.base, tool=base.tool, convention=base.convention)


@pytest.mark.parametrize("name", ["scara", "arm4", "spherical", "planar3r"])
def test_closed_form_with_base_tool_and_flip_reproduces_world_poses(name: str) -> None:
    """Targets are world poses of the tool: the solver moves them to base^-1 T tool^-1 (1e-9: round-trip of atan2/sqrt)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = load_description(name)
    base = {"xyz": [0.4, -0.3, 0.8], "rpy": [0.5, -0.2, 1.3]}
    tool = {"xyz": [0.0, 0.0, 0.15]} if name != "planar3r" else {"xyz": [0.1, 0.05, 0.0], "rpy": [0.0, 0.0, 0.4]}
    robot = Robot(_with(plain, base=base, tool=tool, flip=(0,)))
    assert closed_form_for(robot.description) is not None
    rng = np.random.default_rng(3)
    lo, hi = np.maximum(robot.qlim[0], -2.5), np.minimum(robot.qlim[1], 2.5)
    for _ in range(5):
        q = rng.uniform(lo, hi)
        T = robot.fkine(q)
        sols = ikine_a(robot, T)
        assert any(np.abs(s.q - q).max() <= 1e-9 or np.abs(pose_error(robot.fkine(s.q), T)).max() <= 1e-9 for s in sols)
        for s in sols:
            if s.reproduces_pose:
                assert np.abs(pose_error(robot.fkine(s.q), T)).max() <= 1e-9


def test_no_closed_form_for_modified_dh() -> None:
    robot = Robot(_with(load_description("planar2r"), convention="modified"))
    assert closed_form_for(robot.description) is None
    with pytest.raises(NoClosedFormError, match=r"robot 'planar2r' \(convention 'modified'\): closed-form inverse "
                                                 r"kinematics is recognised from standard DH tables only"):
        ikine_a(robot, robot.fkine([0.3, 0.4]))
    result = ikine(robot, robot.fkine([0.3, 0.4]), q0=[0.2, 0.5], mask=[1, 1, 0, 0, 0, 0])
    assert result.success and np.abs(robot.fkine(result.q)[:2, 3] - robot.fkine([0.3, 0.4])[:2, 3]).max() <= 1e-9


def test_task_rows_of_a_rotated_base_are_those_of_the_chain() -> None:
    """manipulability('task') is invariant under base and tool (it is a property of the chain)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = Robot(load_description("scara"))
        moved = Robot(_with(plain.description, base={"rpy": [0.7, 0.3, -0.4]}, tool={"xyz": [0.02, 0.0, 0.3]}))
    for q in ([0.3, 0.8, 1.0, 0.2], [1.0, -1.2, 2.0, -0.5]):
        assert moved.manipulability(q) == pytest.approx(plain.manipulability(q), rel=1e-12)
    with pytest.raises(ValueError, match=r"mask: robot 'scara' has 4 joints and no recognised structure aligned"):
        default_mask(moved)


# --------------------------------------------------------------------------- solved and ignored components
#
# Tolerances: ikine stops at a masked residual below tol = 1e-10 (m, rad); 1e-9 on a component
# leaves room for the log-map rounding. The 0.3 rad tilt is checked to 1e-9 rad against the
# angle between the tool z axes computed here with arccos, not through pose_error.


def _tilted_about_world_x(T: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    out = T.copy()
    out[:3, :3] = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]) @ T[:3, :3]
    return out


def test_ikine_tilted_scara_target_is_not_a_success(robots: dict[str, Robot]) -> None:
    scara = robots["scara"]
    T = _tilted_about_world_x(scara.fkine([0.3, 0.5, 1.0, 0.2]), 0.3)
    res = ikine(scara, T, slimit=4)
    assert not res.success and not res.mask_given
    assert res.searches == 1  # every SCARA axis is vertical: no restart can tilt the tool
    assert res.solved == ("x", "y", "z", "rz") and res.ignored == ("rx", "ry")
    # the masked search converged: the old rule (masked residual < tol) called this a success
    assert res.residual < 1e-10
    assert np.abs(res.error[[0, 1, 2, 5]]).max() < 1e-9
    # the miss is the tilt, named and measured: 0.3 rad about x, nothing about y
    assert abs(res.ignored_error["rx"] - 0.3) < 1e-9 and abs(res.ignored_error["ry"]) < 1e-9
    z_reached, z_target = scara.fkine(res.q)[:3, 2], T[:3, 2]
    assert abs(math.acos(np.clip(z_reached @ z_target, -1, 1)) - 0.3) < 1e-9
    assert abs(res.rotation_error - 0.3) < 1e-9
    assert re.search(r"outside what the scara structure of 'scara' can reach: the search solved x, y, z, rz.*"
                     r"rx, ry, are missed by rx 0\.3 rad, ry .* rad \(no configuration changes them: every joint "
                     r"axis is along the world z axis\); pass mask=\[1\.0, 1\.0, 1\.0, 0\.0, 0\.0, 1\.0\]",
                     res.reason)
    assert res.summary().startswith("ikine failed: the target pose is outside")


def test_ikine_tilted_scara_target_with_a_given_mask_states_what_it_ignored(robots: dict[str, Robot]) -> None:
    scara = robots["scara"]
    T = _tilted_about_world_x(scara.fkine([0.3, 0.5, 1.0, 0.2]), 0.3)
    res = scara.ikine(T, mask=[1, 1, 1, 0, 0, 1])
    assert res.success and res.mask_given and res.searches == 1
    assert res.ignored == ("rx", "ry") and abs(res.ignored_error["rx"] - 0.3) < 1e-9
    assert re.fullmatch(r"converged on the masked components x, y, z, rz; ignored by the given mask: rx, ry, "
                        r"missed by rx 0\.3 rad, ry \S+ rad", res.reason)


def test_ikine_reachable_scara_target_succeeds(robots: dict[str, Robot]) -> None:
    scara = robots["scara"]
    T = scara.fkine([0.3, 0.5, 1.0, 0.2])
    res = ikine(scara, T, q0=[-0.4, 1.0, 0.5, 0.0])
    assert res.success and res.ignored == ("rx", "ry")
    assert np.abs(res.error).max() < 1e-9  # all six, the ignored ones too
    assert np.abs(pose_error(scara.fkine(res.q), T)).max() < 1e-9
    assert res.reason.startswith("converged on x, y, z, rz; the default mask ignored rx, ry")


def test_ikine_tilt_negative_control(robots: dict[str, Robot]) -> None:
    """The full-pose check is what separates the two: a tilt below tol passes, one just above it fails."""
    scara = robots["scara"]
    T = scara.fkine([0.3, 0.5, 1.0, 0.2])
    assert ikine(scara, _tilted_about_world_x(T, 1e-12), slimit=2).success
    res = ikine(scara, _tilted_about_world_x(T, 1e-8), slimit=2)
    assert not res.success and res.residual < 1e-10 and abs(res.ignored_error["rx"] - 1e-8) < 1e-11


def test_ikine_six_joint_arm_solves_every_component(robots: dict[str, Robot]) -> None:
    puma = robots["puma560"]
    T = puma.fkine([0.1, -0.4, 0.3, 0.4, 0.5, 0.6])
    res = puma.ikine(T)
    assert res.success and res.reason == "converged" and not res.mask_given
    assert res.solved == ("x", "y", "z", "rx", "ry", "rz") and res.ignored == () and res.ignored_error == {}
    assert res.position_error < 1e-9 and res.rotation_error < 1e-9


def test_ikine_restarts_past_a_branch_with_the_wrong_orientation(robots: dict[str, Robot]) -> None:
    """Spherical arm, position-only default mask: started on the branch with the same tool position
    but another orientation, the search solves the position at once, and keeps searching until it
    finds the branch that reaches the full pose."""
    arm = robots["spherical"]
    T = arm.fkine([0.4, 0.7, 0.6])
    other = next(s.q for s in ikine_a(arm, T) if s.branch == "shoulder-right")
    assert np.abs(arm.fkine(other)[:3, 3] - T[:3, 3]).max() < 1e-9 and np.abs(pose_error(arm.fkine(other), T)).max() > 0.1
    res = ikine(arm, T, q0=other)
    assert res.success and res.searches > 1
    assert np.abs(res.q - [0.4, 0.7, 0.6]).max() < 1e-6
    given = ikine(arm, T, q0=other, mask=[1, 1, 1, 0, 0, 0])  # a given mask accepts the first branch, and says so
    assert given.success and given.searches == 1 and given.rotation_error > 0.1 and "ignored by the given mask" in given.reason


def test_ikine_restarts_when_a_branch_can_change_an_ignored_component(robots: dict[str, Robot]) -> None:
    """Planar 2R, default mask x, y: the tool heading rz is ignored but differs between the elbow
    branches, so it is not fixed by the structure; from the wrong branch the search restarts."""
    arm = robots["planar2r"]
    T = arm.fkine([0.4, 0.7])
    other = next(s.q for s in ikine_a(arm, T) if abs(s.q[1] + 0.7) < 1e-9)
    assert abs(pose_error(arm.fkine(other), T)[5]) > 0.1
    res = ikine(arm, T, q0=other)
    assert res.success and res.searches > 1 and np.abs(res.error).max() < 1e-9
