"""Independent reference models built from our robot descriptions, for tests and benchmarks.

* :func:`pinocchio_model`: a Pinocchio model from standard DH data.
* :func:`rtb_robot`: a Robotics Toolbox ``DHRobot`` with the same links and motor data.

Standard DH to Pinocchio: joint i is a revolute (RZ) or prismatic (PZ) joint
about the z axis of DH frame i-1; its placement in the previous joint's frame
is the constant part of the previous link transform,
``M_i = Rz(theta_{i-1}) Tz(d_{i-1}) Tx(a_{i-1}) Rx(alpha_{i-1})`` (identity for
joint 1), with the joint variable replacing theta (revolute) or d (prismatic).
DH frame i is therefore body i's frame times ``M_{i+1}``; inertias given in
DH frame i are moved to body i by that placement. Motors enter Pinocchio as
``armature = G^2 Jm`` (the reflected model); friction is not part of it.
"""

from __future__ import annotations

import numpy as np

from model.description import BUILTIN_DIR, BUILTIN_ROBOTS, RobotDescription

__all__ = [
    "available_robots",
    "dh_constant_placement",
    "friction_reference",
    "pinocchio_model",
    "rtb_robot",
    "symmetric_from_upper",
]


def available_robots() -> list[str]:
    """The names in :data:`model.BUILTIN_ROBOTS` whose TOML file exists (others are being written)."""
    return [name for name in BUILTIN_ROBOTS if (BUILTIN_DIR / f"{name}.toml").is_file()]


def dh_constant_placement(link):
    """``Rz(theta) Tz(d) Tx(a) Rx(alpha)`` with the link's constant DH values, as a pin.SE3."""
    import pinocchio as pin

    ct, st = np.cos(link.theta), np.sin(link.theta)
    ca_, sa = np.cos(link.alpha), np.sin(link.alpha)
    R = np.array([[ct, -st * ca_, st * sa], [st, ct * ca_, -ct * sa], [0.0, sa, ca_]])
    p = np.array([link.a * ct, link.a * st, link.d])
    return pin.SE3(R, p)


def pinocchio_model(desc: RobotDescription, *, armature: bool = True, payload=None):
    """A ``pin.Model`` of ``desc`` with frame ``"tool"`` at DH frame n.

    Parameters
    ----------
    armature
        Add ``G^2 Jm`` per joint (the reflected motor model); False: rigid bodies only.
    payload
        Optional ``(mass, com (3,), inertia6)`` in frame n, added to the last body.
    """
    import pinocchio as pin

    model = pin.Model()
    model.gravity = pin.Motion(np.array(desc.gravity, dtype=float), np.zeros(3))
    parent = 0
    placement = pin.SE3.Identity()
    armatures = []
    for i, link in enumerate(desc.links):
        joint = pin.JointModelRZ() if link.is_revolute else pin.JointModelPZ()
        jid = model.addJoint(parent, joint, placement, f"joint{i + 1}")
        M_frame = dh_constant_placement(link)  # DH frame i in body i's frame
        inertia = pin.Inertia(link.mass, np.array(link.com, dtype=float), link.inertia_matrix)
        model.appendBodyToJoint(jid, M_frame.act(inertia), pin.SE3.Identity())
        armatures.append(link.gear_ratio ** 2 * link.motor_inertia if armature else 0.0)
        parent, placement = jid, M_frame
    if payload is not None:
        mass, com, inertia6 = payload
        ixx, iyy, izz, ixy, iyz, ixz = inertia6
        I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        model.appendBodyToJoint(parent, placement.act(pin.Inertia(mass, np.array(com, dtype=float), I)), pin.SE3.Identity())
    model.addFrame(pin.Frame("tool", parent, placement, pin.FrameType.OP_FRAME))
    model.armature = np.array(armatures)
    return model


def symmetric_from_upper(M: np.ndarray) -> np.ndarray:
    """Pinocchio's CRBA fills the upper triangle; mirror it."""
    return np.triu(M) + np.triu(M, 1).T


def friction_reference(desc: RobotDescription, qd: np.ndarray) -> np.ndarray:
    """F(qd) = G^2 B qd + |G| Tc(sign qd), written out from the definition (motor-side data)."""
    out = []
    for link, v in zip(desc.links, qd):
        G = link.gear_ratio
        tc = link.coulomb_friction[0] if v > 0 else link.coulomb_friction[1] if v < 0 else 0.0
        out.append(G * G * link.viscous_friction * v + abs(G) * tc)
    return np.array(out)


def rtb_robot(desc: RobotDescription):
    """A Robotics Toolbox ``DHRobot`` with the links, inertias and motor data of ``desc``."""
    import roboticstoolbox as rtb

    links = []
    for link in desc.links:
        kw = dict(
            a=link.a, alpha=link.alpha, m=link.mass, r=list(link.com), I=link.inertia_matrix,
            Jm=link.motor_inertia, G=link.gear_ratio, B=link.viscous_friction, Tc=list(link.coulomb_friction),
        )
        if link.is_revolute:
            links.append(rtb.RevoluteDH(d=link.d, offset=link.theta, **kw))
        else:
            links.append(rtb.PrismaticDH(theta=link.theta, offset=link.d, **kw))
    robot = rtb.DHRobot(links, name=desc.name)
    robot.gravity = np.array(desc.gravity, dtype=float)  # RTB: the gravity acceleration vector, base frame
    return robot
