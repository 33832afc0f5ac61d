"""The arms of the example-robot-data collection (``erd:NAME``, model/example_robots.py and its catalogue).

* every listed arm loads, and its Newton-Euler ``rne`` equals Pinocchio's ``rnea`` on the same URDF file
  (``buildModelFromUrdf`` + ``buildReducedModel``, every joint off the chain locked at 0) at random states:
  to 1e-10 of the torque scale (both are exact recursions in float64: the observed difference is about
  1e-14; 1e-10 leaves room for the rpy round trip of a base pose and fails on any modelling slip), and its
  ``fkine`` Pinocchio's tip-frame placement (m, to 1e-9: the base pose, which gravity alone may not reveal);
* base_link and tip_link are the arm's: the tip is a flange or tool frame, not a finger or jaw, and no mass
  is lost (what hangs below the tip, gripper and fingers, is lumped into the last link);
* every URDF of the package is either listed or excluded here with its reason (a new file fails the test);
* without the robots extra, ``erd:`` names are one line saying how to install it (exit status 2), and the
  built-ins panda and ur5 still load (their URDFs are vendored).
"""

from __future__ import annotations

import numpy as np
import pytest

from model.example_robots import ERD_PREFIX, collection_dir, erd_names, erd_urdf
from model.loading import load_description
from model.robot import load_robot
from model.urdf import read_urdf

pytest.importorskip("pinocchio", reason="Pinocchio is in the test extra")

from tests.support.urdf_references import pin_q, pinocchio_urdf_arm  # noqa: E402

#: Relative agreement with Pinocchio (see the module docstring).
RTOL = 1e-10
#: The package's URDF files that are not listed, and why (the catalogue's rule).
EXCLUDED = {
    **{f: "legged robot without an arm" for f in (
        "a1_description/urdf/a1.urdf", "anymal_b_simple_description/robots/anymal.urdf",
        "anymal_c_simple_description/urdf/anymal.urdf", "b1_description/urdf/b1.urdf", "bolt_description/robots/bolt.urdf",
        "go1_description/urdf/go1.urdf", "go2_description/urdf/go2.urdf", "hyq_description/robots/hyq_no_sensors.urdf",
        "laikago_description/urdf/laikago.urdf", "quadruped_description/urdf/quadruped.urdf",
        "solo_description/robots/solo.urdf", "solo_description/robots/solo12.urdf",
        "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf")},
    **{f: "a hand (fingers from a palm), not an arm" for f in (
        "allegro_hand_description/urdf/allegro_left_hand.urdf", "allegro_hand_description/urdf/allegro_right_hand.urdf")},
    **{f: "a flying base without an arm" for f in (
        "hector_description/robots/quadrotor_base.urdf", "iris_description/robots/iris.urdf",
        "iris_description/robots/iris_simple.urdf")},
    **{f: "a humanoid full body (only TALOS's arms are listed)" for f in (
        "alex_description/urdf/alex_nub_hands.urdf", "alex_description/urdf/alex_psyonic_hands.urdf",
        "alex_description/urdf/alex_sake_hands.urdf", "centauro_description/urdf/centauro.urdf",
        "g1_description/urdf/g1_29dof_rev_1_0.urdf", "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
        "human_description/robots/human.urdf", "icub_description/robots/icub.urdf",
        "icub_description/robots/icub_reduced.urdf", "romeo_description/urdf/romeo.urdf",
        "romeo_description/urdf/romeo_laas_small.urdf", "romeo_description/urdf/romeo_small.urdf",
        "simple_humanoid_description/urdf/simple_humanoid.urdf",
        "simple_humanoid_description/urdf/simple_humanoid_classical.urdf",
        "talos_data/robots/talos_full_v2_box.urdf", "talos_data/robots/talos_reduced.urdf",
        "talos_data/robots/talos_reduced_box.urdf", "talos_data/robots/talos_reduced_corrected.urdf")},
    "ur_description/urdf/ur3.urdf": "an empty <robot> (no links or joints: the xacro's leftover)",
}
#: Words of a finger, jaw or gripper link: never a tip.
HAND_WORDS = ("finger", "jaw", "thumb", "mover")


def _catalogue() -> dict[str, dict[str, str]]:
    from model.example_robots import _catalogue

    return _catalogue()


def _states(robot, seed: int, count: int = 3):
    """(q, qd, qdd): q uniform within the joint limits (+-pi where there are none), qd and qdd in +-2."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(robot.qlim[0]), robot.qlim[0], -np.pi)
    hi = np.where(np.isfinite(robot.qlim[1]), robot.qlim[1], np.pi)
    return [(rng.uniform(lo, hi), rng.uniform(-2, 2, robot.n), rng.uniform(-2, 2, robot.n)) for _ in range(count)]


@pytest.mark.slow
@pytest.mark.parametrize("name", erd_names())
def test_every_listed_arm_matches_pinocchio_rnea(name):
    import pinocchio as pin

    robot = load_robot(name)
    entry = _catalogue()[name[len(ERD_PREFIX):]]
    joints = [link.name for link in robot.description.links]
    try:
        ref, fid = pinocchio_urdf_arm(erd_urdf(name), entry["tip_link"], joints)
        chain = None
    except ValueError:  # buildReducedModel refuses a link named like a joint (so100's "gripper"): the full
        ref = pin.buildModelFromUrdf(str(erd_urdf(name)))  # model with every other joint at 0, at rest, gives
        chain = [ref.joints[ref.getJointId(j)].idx_v for j in joints]  # the same torques on the chain's joints
        fid = ref.getFrameId(entry["tip_link"], pin.FrameType.BODY)
    data = ref.createData()
    rne = robot.dynamics.functions.rne  # the model the compiled C is generated from (tests/model/test_codegen.py)
    p = robot.dynamics.parameters.vector
    for k, (q, qd, qdd) in enumerate(_states(robot, seed=len(name))):
        # Pinocchio's rnea leaves out the URDF's <dynamics damping friction>, which our rne includes as the
        # joints' friction (tests/model/test_urdf.py): F = damping qd + friction sign(qd), from its model
        index = np.arange(robot.n) if chain is None else np.asarray(chain)
        friction = ref.damping[index] * qd + ref.friction[index] * np.sign(qd)
        if chain is None:
            qp = pin_q(ref, q)
            expected = pin.rnea(ref, data, qp, qd, qdd) + friction
        else:
            full = [np.zeros(ref.nv) for _ in range(3)]
            for f, ours_v in zip(full, (q, qd, qdd)):
                f[chain] = ours_v
            qp = pin_q(ref, full[0])
            expected = pin.rnea(ref, data, qp, full[1], full[2])[chain] + friction
        ours = np.array(rne(q, qd, qdd, p)).ravel()
        scale = max(1.0, float(np.max(np.abs(expected))))
        np.testing.assert_allclose(ours, expected, rtol=0, atol=RTOL * scale)
        if k == 0:  # the base pose and the tip: the tool pose in the URDF's root frame (gravity alone hides a yaw)
            pin.framesForwardKinematics(ref, data, qp)
            np.testing.assert_allclose(robot.fkine(q), data.oMf[fid].homogeneous, rtol=0, atol=RTOL * 10)
    assert np.max(np.abs(expected)) > 1e-3  # negative control: torques to compare, not zeros


def _subtree_mass(robot, base: str) -> float:
    children: dict[str, list[str]] = {}
    for joint in robot.joints:
        children.setdefault(joint.parent, []).append(joint.child)
    mass = {link.name: (link.inertial.mass or 0.0) if link.inertial else 0.0 for link in robot.links}
    total, stack = 0.0, list(children.get(base, []))
    while stack:
        link = stack.pop()
        total += mass[link]
        stack += children.get(link, [])
    return total


@pytest.mark.parametrize("name", [n for n in erd_names() if not n.startswith(("erd:tiago", "erd:talos_", "erd:pr2"))]
                         + ["erd:tiago", "erd:talos_left", "erd:pr2_left"])
def test_the_chain_ends_at_a_flange_and_keeps_every_mass_below_its_first_joint(name):
    """A tip that is the arm's flange or tool frame, and every body below the first joint in the model's links.

    For a platform's arm (base = a torso or mount) the other arm, the head and the legs hang off the base,
    not off the chain: only the mass below the arm's first joint is the arm's."""
    entry = _catalogue()[name[len(ERD_PREFIX):]]
    desc = load_description(name)
    urdf = read_urdf(erd_urdf(name))
    parents = {j.parent for j in urdf.joints}
    leaves = [lk.name for lk in urdf.links if lk.name not in parents]
    if len(leaves) > 1:  # a branching tree: the tip was chosen, and it is no finger, jaw or gripper mover
        assert not any(word in entry["tip_link"].lower() for word in HAND_WORDS), entry["tip_link"]
    first = next(j for j in urdf.joints if j.name == desc.links[0].name)
    expected = _subtree_mass(urdf, first.parent) - sum(
        _subtree_mass(urdf, j.child) + next(lk.inertial.mass or 0.0 for lk in urdf.links if lk.name == j.child)
        for j in urdf.joints if j.parent == first.parent and j.name != first.name)
    assert sum(link.mass for link in desc.links) == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert expected > 0  # negative control: there is mass to keep


def test_every_urdf_of_the_package_is_listed_or_excluded_with_a_reason():
    root = collection_dir()
    files = {p.relative_to(root).as_posix() for p in root.glob("*/*/*.urdf")}
    listed = {entry["urdf"] for entry in _catalogue().values()}
    assert len(files) > 60 and len(listed) > 30  # negative control: the package and the catalogue are read
    assert not listed - files, f"catalogue entries without a file: {sorted(listed - files)}"
    assert not listed & set(EXCLUDED), sorted(listed & set(EXCLUDED))
    unclassified = files - listed - set(EXCLUDED)
    assert not unclassified, f"URDFs of the package neither listed nor excluded: {sorted(unclassified)}"


def test_an_unknown_name_suggests_the_nearest_arm():
    from model.description import RobotDescriptionError

    with pytest.raises(RobotDescriptionError, match=r"robot 'erd:ur11': not an arm .* did you mean 'erd:ur10'"):
        load_description("erd:ur11")


@pytest.fixture
def without_the_extra(monkeypatch):
    """The example-robot-data package made invisible (as on a machine without the robots extra)."""
    import importlib.metadata

    import model.example_robots as erd

    real = importlib.metadata.distribution

    def distribution(name):
        if name == "example-robot-data":
            raise importlib.metadata.PackageNotFoundError(name)
        return real(name)

    monkeypatch.setattr(importlib.metadata, "distribution", distribution)
    erd.collection_dir.cache_clear()
    yield
    erd.collection_dir.cache_clear()


@pytest.mark.parametrize("argv", [["info", "erd:ur10"], ["robots", "--all"]])
def test_without_the_extra_an_erd_name_is_one_line_saying_how_to_install_it(without_the_extra, capsys, argv):
    from workbench.cli import main

    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err == (f"manip {argv[0]}: error: the example-robot-data robots need the robots extra: "
                   "pip install 'manipulator-workbench[robots]'\n")


def test_without_the_extra_the_builtin_panda_and_ur5_still_load(without_the_extra, capsys):
    from workbench.cli import main

    assert load_description("panda").n == 7 and load_description("ur5").n == 6
    assert main(["robots"]) == 0 and "ur5" in capsys.readouterr().out


def test_the_erd_panda_is_the_builtin_panda():
    """The built-in's URDF is the package's, unchanged (model/robots/URDF-SOURCES.md): same chain, same bodies."""
    ours, theirs = load_description("panda"), load_description("erd:panda")
    assert [lk.name for lk in ours.links] == [lk.name for lk in theirs.links]
    for a, b in zip(ours.links, theirs.links):
        assert (a.mass, a.com, a.inertia, a.origin, a.axis) == (b.mass, b.com, b.inertia, b.origin, b.axis)
