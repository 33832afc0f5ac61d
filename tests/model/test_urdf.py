"""Robots from URDF against Pinocchio reading the SAME file (``pin.buildModelFromUrdf``, reduced to the arm).

Two comparisons per robot:

* our description rebuilt in Pinocchio joint by joint (``references.pinocchio_model``) against
  Pinocchio's own reading of the file: checks the reading (merged fixed joints, lumped bodies, axes,
  rotated inertial origins, the tip) without our kinematics or dynamics;
* :class:`model.Robot` end to end (fkine, jacob0, rne, inertia, gravload, coriolis, accel) against it.

Tolerance 1e-10 relative to the largest reference value (at least 1), as in
``test_dynamics_pinocchio.py``: both sides are double precision through O(100) operations
(~1e-14); a wrong frame, axis or inertia moves the numbers by >= 1e-3.
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

from model import Robot, load_robot
from model.description import BUILTIN_DIR, RobotDescriptionError
from model.loading import load_description
from model.urdf import description_from_urdf
from tests.support.urdf_cases import joint, link, write_urdf
from tests.support.references import pinocchio_model
from tests.support.urdf_references import pin_q, pinocchio_urdf_arm

RTOL = 1e-10


def close(actual, expected, rtol=RTOL):
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=rtol * scale)


def states(n, seed, count=4):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-2.0, 2.0, (3, n)) for _ in range(count)]


# ------------------------------------------------------------------ the robots compared

def tiny_fixed_mid(folder):
    """Revolute z, a FIXED joint with a massive link in the middle, revolute about y, prismatic along x, a fixed tip."""
    return write_urdf(
        folder, "fixed_mid.urdf",
        link("base", 2.0, "0 0 0.05", inertia=(0.1, 0.1, 0.1, 0, 0, 0)),
        link("l1", 1.5, "0.1 0.02 0.2", "0.1 -0.2 0.3", (0.02, 0.03, 0.025, 0.001, -0.002, 0.0015)),
        link("l1b", 0.7, "0.05 0 0", "0 0.4 0", (0.004, 0.006, 0.005, 0, 0.0005, 0)),
        link("l2", 1.1, "0.2 0 0", "0.3 0 -0.1", (0.01, 0.02, 0.015, 0.001, 0, 0.002)),
        link("l3", 0.4, "0 0 0.1", inertia=(0.002, 0.002, 0.001, 0, 0, 0)),
        link("tip"),
        joint("j1", "revolute", "base", "l1", "0 0 0.3"),
        joint("mid", "fixed", "l1", "l1b", "0.3 0 0.1", "0.2 0.1 -0.3"),
        joint("j2", "revolute", "l1b", "l2", "0.1 0 0", "0 0.5 0", axis="0 1 0"),
        joint("j3", "prismatic", "l2", "l3", "0.4 0 0", axis="1 0 0", limit=(0.0, 0.5)),
        joint("flange", "fixed", "l3", "tip", "0 0 0.12", "0 0 1.2"),
        name="fixed_mid",
    ), "tip"


def tiny_tilted(folder):
    """Joint axes off z (unit, tilted), a continuous joint, rotated inertial origins, a finger off the chain."""
    return write_urdf(
        folder, "tilted.urdf",
        link("base"),
        link("a", 2.0, "0.05 0.1 0.2", "0.7 -0.3 1.1", (0.03, 0.05, 0.04, 0.004, -0.003, 0.002)),
        link("b", 1.2, "0.3 -0.05 0", "-0.4 0.9 0.2", (0.02, 0.01, 0.025, -0.001, 0.002, 0.0)),
        link("c", 0.5, "0 0.02 0.08", "1.0 0 0", (0.003, 0.004, 0.002, 0, 0, 0.0005)),
        link("finger", 0.2, "0 0.01 0.03", "0 0 0.5", (0.0002, 0.0003, 0.0001, 0, 0, 0)),
        link("end"),
        joint("ja", "revolute", "base", "a", "0.01 0.02 0.25", "0.1 0.2 0.3", axis="0.6 0 0.8", limit=(-2.5, 2.5)),
        joint("jb", "continuous", "a", "b", "0.2 0.1 0.3", "-0.5 0.3 0", axis="0 0.6 -0.8"),
        joint("jc", "revolute", "b", "c", "0.5 0 0", axis="0.48 0.6 0.64"),
        joint("jf", "prismatic", "c", "finger", "0 0.05 0.1", axis="0 1 0", limit=(0.0, 0.04)),
        joint("je", "fixed", "c", "end", "0 0 0.15", "0.3 -0.2 0.1"),
        name="tilted",
    ), "end"


def builtin_urdf(filename, tip):
    return lambda folder: (BUILTIN_DIR / filename, tip)


CASES = {
    "panda": builtin_urdf("panda.urdf", "panda_link8"),
    "panda_hand_tcp": builtin_urdf("panda.urdf", "panda_hand_tcp"),
    "ur5": builtin_urdf("ur5_robot.urdf", "tool0"),
    "fixed_mid": tiny_fixed_mid,
    "tilted": tiny_tilted,
}


# End to end through compiled dynamics: the hand-TCP variant of the panda is left to the reading test
# (a second 7-joint build; its rotated fixed tip and lumped hand are covered by fixed_mid and tilted).
END_TO_END = ["panda", "ur5", "fixed_mid", "tilted"]


def load_case(name, tmp_path_factory):
    path, tip = CASES[name](tmp_path_factory.mktemp(name))
    desc = description_from_urdf(path, {"tip_link": tip})
    names = [lk.name for lk in desc.links]
    ref, tip_frame = pinocchio_urdf_arm(path, tip, names, desc.gravity)
    return desc, ref, tip_frame


@pytest.fixture(scope="module", params=list(CASES))
def case(request, tmp_path_factory):
    return load_case(request.param, tmp_path_factory)


# ------------------------------------------------------------------ the reading

def test_reading_matches_pinocchio_reading_the_file(case):
    desc, ref, fid = case
    mine = pinocchio_model(desc, armature=False)
    assert mine.nv == ref.nv == desc.n
    rd, md = ref.createData(), mine.createData()
    mid = mine.getFrameId("tool")
    for q, qd, qdd in states(desc.n, 1):
        qp = pin_q(ref, q)
        pin.framesForwardKinematics(ref, rd, qp)
        pin.framesForwardKinematics(mine, md, q)
        close(md.oMf[mid].homogeneous, rd.oMf[fid].homogeneous)
        close(pin.rnea(mine, md, q, qd, qdd), pin.rnea(ref, rd, qp, qd, qdd))
        close(pin.crba(mine, md, q), pin.crba(ref, rd, qp))


def test_panda_and_ur5_builtins_are_their_urdf():
    panda, ur5 = load_description("panda"), load_description("ur5")
    assert (panda.n, panda.convention, ur5.n, ur5.convention) == (7, "urdf", 6, "urdf")
    assert [lk.name for lk in panda.links] == [f"panda_joint{i}" for i in range(1, 8)]
    assert [lk.torque_limit for lk in panda.links] == [87.0] * 4 + [12.0] * 3
    # URDF limits become qlim: panda joint 4 is [-3.0718, -0.0698] rad in the file
    assert panda.links[3].qlim == (-3.0718, -0.0698)
    # the hand (0.73 kg) and both fingers (0.015 kg each) are lumped into link 7 (0.735522 kg)
    assert panda.links[6].mass == pytest.approx(0.735522 + 0.73 + 2 * 0.015, abs=1e-12)
    assert np.all(np.isfinite(panda.qlim)) and np.all(np.isfinite(ur5.qlim))


# ------------------------------------------------------------------ end to end

@pytest.fixture(scope="module", params=END_TO_END)
def robot_case(request, tmp_path_factory):
    desc, ref, fid = load_case(request.param, tmp_path_factory)
    return Robot(desc), ref, fid


def test_fkine_and_jacob0_match_pinocchio(robot_case):
    robot, ref, fid = robot_case
    data = ref.createData()
    for q, _, _ in states(robot.n, 2):
        qp = pin_q(ref, q)
        pin.computeJointJacobians(ref, data, qp)
        pin.updateFramePlacements(ref, data)
        close(robot.fkine(q), data.oMf[fid].homogeneous)
        J = pin.getFrameJacobian(ref, data, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        close(robot.jacob0(q), J)


def test_dynamics_match_pinocchio(robot_case):
    """B, C, g, RNE and forward dynamics as Pinocchio computes them from the same file, the URDF's joint friction
    included: our rne is ``B qdd + C qd + F(qd) + g`` with ``F = damping qd + friction sign(qd)`` (Pinocchio's
    ``model.damping`` and ``model.friction``, which its rnea leaves out); the panda's damping is 0.003 on every joint."""
    robot, ref, _ = robot_case
    data = ref.createData()
    for q, qd, qdd in states(robot.n, 3):
        qp = pin_q(ref, q)
        friction = ref.damping * qd + ref.friction * np.sign(qd)
        tau = pin.rnea(ref, data, qp, qd, qdd) + friction
        close(robot.rne(q, qd, qdd), tau)
        close(robot.friction(qd), friction)
        close(robot.inertia(q), np.triu(pin.crba(ref, data, qp)) + np.triu(pin.crba(ref, data, qp), 1).T)
        close(robot.gravload(q), pin.computeGeneralizedGravity(ref, data, qp))
        close(robot.coriolis(q, qd), pin.computeCoriolisMatrix(ref, data, qp, qd))
        close(robot.accel(q, qd, tau), pin.aba(ref, data, qp, qd, tau - friction))


def test_load_robot_reads_a_urdf_path(tmp_path):
    path, _ = tiny_fixed_mid(tmp_path)
    robot = load_robot(path)  # one leaf: no tip_link needed
    assert robot.n == 3 and robot.description.convention == "urdf"
    assert robot.description.joint_types == "RRP"
    assert robot.qlim[:, 2].tolist() == [0.0, 0.5]


# ------------------------------------------------------------------ the TOML form

def panda_toml(tmp_path, body: str) -> str:
    path = tmp_path / "arm.toml"
    urdf = (BUILTIN_DIR / "panda.urdf").as_posix()
    path.write_text(f'name = "arm"\nurdf = "{urdf}"\ntip_link = "panda_link8"\n{body}')
    return str(path)


def test_toml_adds_motor_data_by_joint_name(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "arm.urdf").write_bytes((BUILTIN_DIR / "panda.urdf").read_bytes())
    toml = tmp_path / "arm.toml"
    toml.write_text('name = "arm"\nurdf = "sub/arm.urdf"\ntip_link = "panda_link8"\ngravity = [0.0, 0.0, -9.8]\n'
                    '[joints.panda_joint3]\nmotor_inertia = 2e-4\ngear_ratio = 100.0\nviscous_friction = 1e-3\n'
                    'coulomb_friction = 0.2\ntorque_limit = 0.5\n')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        desc = load_description(toml)
    third = desc.links[2]
    assert (third.motor_inertia, third.gear_ratio, third.viscous_friction, third.coulomb_friction, third.torque_limit) == \
        (2e-4, 100.0, 1e-3, (0.2, -0.2), 0.5)
    assert desc.links[1].gear_ratio == 1.0 and desc.gravity == (0.0, 0.0, -9.8) and desc.name == "arm"


@pytest.mark.parametrize("body, message", [
    ('[joints.panda_joint9]\ngear_ratio = 2.0\n',
     r"arm.toml: field 'joints.panda_joint9' .*expected a moving joint of the chain \(panda_joint1, .*panda_joint7\); 'panda_joint9' is not one"),
    ('[joints.panda_joint2]\nmass = 2.0\n', r"field 'joints.panda_joint2.mass' = 2.0: expected one of the motor keys"),
    ('[joints.panda_joint2]\ngear_ratio = 0.0\n', r"arm.toml, joint 'panda_joint2': field 'gear_ratio' = 0.0: expected a non-zero number"),
    ('links = []\n', r"arm.toml: field 'links' = \[\]: expected one of the known keys of a URDF robot file"),
])
def test_toml_errors_name_the_joint_or_key(tmp_path, body, message):
    with pytest.raises(RobotDescriptionError, match=message):
        load_description(panda_toml(tmp_path, body))


def test_limits_continuous_and_equal_bounds_have_none(tmp_path):
    path = write_urdf(tmp_path, "limits.urdf", link("b"), link("c1", 1.0), link("c2", 1.0), link("c3", 1.0),
                      joint("free", "continuous", "b", "c1"),
                      joint("same", "revolute", "c1", "c2", limit=(0.7, 0.7)),
                      joint("kept", "prismatic", "c2", "c3", limit=(-0.1, 0.2)))
    desc = description_from_urdf(path)
    assert [lk.qlim for lk in desc.links] == [None, None, (-0.1, 0.2)]


# ------------------------------------------------------------------ refused constructs

def chain(*extra: str) -> tuple[str, ...]:
    return (link("b"), link("l1", 1.0), link("l2", 1.0), joint("j1", "revolute", "b", "l1"), *extra)


@pytest.mark.parametrize("elements, message", [
    (chain(joint("free", "floating", "l1", "l2")), r"joint 'free': type 'floating' refused: a floating joint"),
    (chain(joint("flat", "planar", "l1", "l2")), r"joint 'flat': type 'planar' refused: a planar joint"),
    (chain(joint("copy", "revolute", "l1", "l2", extra='<mimic joint="j1" multiplier="2"/>')),
     r"joint 'copy': a mimic joint \(it follows 'j1'\) cannot be a joint of the serial model"),
    (chain(joint("j2", "revolute", "l1", "l2"), joint("back", "revolute", "b", "l2")),
     r"joint 'back': link 'l2' already has the parent joint 'j2': a closed chain"),
    (chain(joint("j2", "revolute", "l1", "l2"), link("l3"), joint("j3", "revolute", "l1", "l3")),
     r"the tree branches below 'b' into the leaves l2, l3: name the end of the arm with tip_link"),
    (chain(joint("j2", "ball", "l1", "l2")), r"joint 'j2': type 'ball': expected revolute, continuous, prismatic or fixed"),
    (chain(joint("j2", "revolute", "l1", "nowhere")), r"joint 'j2': child link 'nowhere' is not a <link> of the file"),
    (chain(joint("j2", "revolute", "l1", "l2", axis="0 0 0")), r"joint 'j2': axis \[0.0, 0.0, 0.0\]: expected a non-zero axis"),
    (chain(joint("j2", "revolute", "l1", "l2", limit=(1.0, -1.0))), r"joint 'j2': <limit lower=1.0 upper=-1.0>: expected finite lower <= upper"),
])
def test_refused_urdf_constructs_name_the_joint(tmp_path, elements, message):
    path = write_urdf(tmp_path, "bad.urdf", *elements)
    with pytest.raises(RobotDescriptionError, match=r"bad.urdf.*" + message):
        description_from_urdf(path)


def test_unknown_tip_link_lists_the_links(tmp_path):
    path = write_urdf(tmp_path, "arm.urdf", *chain(joint("j2", "revolute", "l1", "l2")))
    with pytest.raises(RobotDescriptionError, match=r"tip_link 'hand' is not a link of the file; the links below 'b' are b, l1, l2"):
        description_from_urdf(path, {"tip_link": "hand"})


def test_too_many_moving_joints(tmp_path):
    from model.urdf import MAX_MOVING_JOINTS

    n = MAX_MOVING_JOINTS + 1
    elements = [link(f"l{i}", 1.0) for i in range(n + 1)]
    elements += [joint(f"j{i}", "revolute", f"l{i - 1}", f"l{i}") for i in range(1, n + 1)]
    path = write_urdf(tmp_path, "long.urdf", *elements)
    with pytest.raises(RobotDescriptionError, match=rf"long.urdf: more than {MAX_MOVING_JOINTS} moving joints: above the joint-count limit"):
        description_from_urdf(path)


def test_oversized_file_is_refused_unread(tmp_path):
    from model.urdf import MAX_URDF_BYTES

    path = tmp_path / "huge.urdf"
    with open(path, "wb") as fh:  # sparse: nothing is written or read
        fh.truncate(MAX_URDF_BYTES + 1)
    with pytest.raises(RobotDescriptionError, match=rf"huge.urdf: {MAX_URDF_BYTES + 1} bytes: larger than the URDF size limit of {MAX_URDF_BYTES} bytes"):
        load_description(path)


DTD_REFUSED = r"refused: the file declares a document type \(<!DOCTYPE \.\.\.>\), whose entities could read other files"


def test_external_entity_is_refused_and_nothing_read(tmp_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("TOP-SECRET-42")
    path = tmp_path / "xxe.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<!DOCTYPE robot [<!ENTITY leak SYSTEM "file://{secret.as_posix()}">]>\n'
                    '<robot name="&leak;"><link name="b"/></robot>\n')
    with pytest.raises(RobotDescriptionError, match=r"xxe.urdf: " + DTD_REFUSED) as info:
        load_description(path)
    assert "TOP-SECRET" not in str(info.value)


def test_billion_laughs_is_refused(tmp_path):
    entities = '<!ENTITY lol "lol">' + "".join(
        f'<!ENTITY lol{k} "{("&lol" + (str(k - 1) if k > 1 else "") + ";") * 10}">' for k in range(1, 10))
    path = tmp_path / "laughs.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<!DOCTYPE robot [{entities}]>\n<robot name="&lol9;"><link name="b"/></robot>\n')
    with pytest.raises(RobotDescriptionError, match=r"laughs.urdf: " + DTD_REFUSED):
        load_description(path)


def test_malformed_xml_and_other_root(tmp_path):
    bad = tmp_path / "broken.urdf"
    bad.write_text('<robot name="x"><link name="b"></robot>')
    with pytest.raises(RobotDescriptionError, match=r"broken.urdf: not well-formed XML: mismatched tag"):
        load_description(bad)
    other = tmp_path / "other.urdf"
    other.write_text('<sdf version="1.6"/>')
    with pytest.raises(RobotDescriptionError, match=r"other.urdf: the root element is <sdf>: expected a URDF <robot>"):
        load_description(other)


def test_docs_list_the_urdf_keys_the_reader_knows():
    import re
    from pathlib import Path

    from model import urdf

    text = (Path(__file__).resolve().parents[2] / "docs" / "robot-file.md").read_text()
    section = text[text.index("### URDF robot-file keys"):text.index("### How the URDF is read")]
    rows = dict(re.findall(r"^\| `([a-z_.A-Z]+)` \|(.*)$", section, flags=re.M))
    own = set(urdf._TOML_KEYS) - set(urdf._PASSED_ON)
    assert set(rows) == {"joints.NAME" if key == "joints" else key for key in own}
    assert all(f"`{key}`" in rows["joints.NAME"] for key in urdf.MOTOR_KEYS)


def test_base_link_inside_the_tree_starts_the_chain_there(tmp_path):
    """base_link = l1: the chain is j2, j3 and frame 0 is l1's frame, wherever j1 has turned it."""
    path, tip = tiny_fixed_mid(tmp_path)
    desc = description_from_urdf(path, {"base_link": "l1"})
    assert [lk.name for lk in desc.links] == ["j2", "j3"]
    mine = pinocchio_model(desc, armature=False)
    md, fid = mine.createData(), mine.getFrameId("tool")
    full = pin.buildModelFromUrdf(str(path))
    fd = full.createData()
    for q, _, _ in states(3, 9):
        pin.framesForwardKinematics(full, fd, q)
        pin.framesForwardKinematics(mine, md, q[1:])
        T_l1_tip = fd.oMf[full.getFrameId("l1")].inverse() * fd.oMf[full.getFrameId(tip)]
        close(md.oMf[fid].homogeneous, T_l1_tip.homogeneous)


def test_info_prints_joint_origins_and_axes_of_a_urdf_robot(capsys):
    from workbench.cli import main

    assert main(["info", "ur5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    header = lines.index("URDF joints: origin of joint i in link frame i-1 (xyz, rpy = URDF <origin>), unit axis")
    # shoulder_lift_joint: <origin rpy="0.0 1.57079632679 0.0" xyz="0.0 0.13585 0.0"/>, <axis xyz="0 1 0"/>
    # xyz, axis and limits exactly as in the file; rpy in deg to 6 digits
    assert lines[header + 3].split() == ["2", "shoulder_lift_joint", "revolute", "[0.0,", "0.13585,", "0.0]",
                                         "[0,", "90,", "0]", "[0.0,", "1.0,", "0.0]",
                                         "[-6.28318530718,", "6.28318530718]", "rad"]
