"""Independent reference models built from our robot descriptions, for tests and benchmarks.

* :func:`pinocchio_model`: a Pinocchio model from standard or modified DH data, base, tool and flip,
  or from the joint origins and axes of a urdf description.
* :func:`rtb_robot`: a Robotics Toolbox ``DHRobot`` with the same links (``RevoluteDH``/``PrismaticDH``
  or ``RevoluteMDH``/``PrismaticMDH``, ``flip``), base, tool and motor data; for a urdf description
  (coordinate joint axes) an ETS ``Robot`` of ``SE3(origin) * Rx|Ry|Rz``.

Standard DH to Pinocchio: joint i is a revolute (RZ) or prismatic (PZ) joint
about the z axis of DH frame i-1; its placement in the previous joint's frame
is the constant part of the previous link transform,
``M_i = Rz(theta_{i-1}) Tz(d_{i-1}) Tx(a_{i-1}) Rx(alpha_{i-1})`` (identity for
joint 1), with the joint variable replacing theta (revolute) or d (prismatic).
DH frame i is therefore body i's frame times ``M_{i+1}``; inertias given in
DH frame i are moved to body i by that placement.

Modified DH (Craig) to Pinocchio: ``A_i = Rx(alpha) Tx(a) Rz(theta + q) Tz(d)``
is read directly as joint i placed at ``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` in
the previous joint's frame, moving about its z; frame i is body i's frame and
inertias are used as given. The base multiplies the first placement, the tool
the tool frame's placement; a flipped joint moves about -z. A urdf link is a joint
placed at its ``origin`` in body i-1, moving about its unit ``axis``; body i is its
frame and the tool frame is body n's times ``tip`` and ``tool``. Motors enter
Pinocchio as ``armature = G^2 Jm`` (the reflected model); friction is not part of it.
"""

from __future__ import annotations

import numpy as np

from model.description import BUILTIN_DIR, BUILTIN_ROBOTS, RobotDescription, pose_matrix

__all__ = [
    "available_robots",
    "dh_constant_placement",
    "mdh_constant_placement",
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


def mdh_constant_placement(link):
    """``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` with the link's constant modified-DH values, as a pin.SE3."""
    import pinocchio as pin

    cal, sal = np.cos(link.alpha), np.sin(link.alpha)
    ct, st = np.cos(link.theta), np.sin(link.theta)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cal, -sal], [0.0, sal, cal]])
    Rz = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
    return pin.SE3(Rx @ Rz, np.array([link.a, 0.0, 0.0]) + Rx @ np.array([0.0, 0.0, link.d]))


def _pin_joint(link):
    import pinocchio as pin

    if not link.flip:
        return pin.JointModelRZ() if link.is_revolute else pin.JointModelPZ()
    axis = np.array([0.0, 0.0, -1.0])
    return pin.JointModelRevoluteUnaligned(axis) if link.is_revolute else pin.JointModelPrismaticUnaligned(axis)


def _pin_axis_joint(link):
    import pinocchio as pin

    axis = np.array(link.axis, dtype=float) * (-1.0 if link.flip else 1.0)
    return pin.JointModelRevoluteUnaligned(axis) if link.is_revolute else pin.JointModelPrismaticUnaligned(axis)


def pinocchio_model(desc: RobotDescription, *, armature: bool = True, payload=None):
    """A ``pin.Model`` of ``desc`` (standard or modified DH, or urdf) with frame ``"tool"`` at the tool frame.

    The payload is placed in frame n (DH frame n; for urdf body n, before the tip and the tool).

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
    modified, urdf = desc.convention == "modified", desc.convention == "urdf"
    if desc.convention not in ("standard", "modified", "urdf"):
        raise ValueError(f"pinocchio_model: standard, modified or urdf convention, got {desc.convention!r}")
    parent = 0
    placement = pin.SE3(desc.T_base)
    armatures = []
    for i, link in enumerate(desc.links):
        if modified:
            placement = placement * mdh_constant_placement(link)
        elif urdf:  # the joint frame's pose in body i-1, a unit axis in it
            placement = placement * pin.SE3(pose_matrix(link.origin))
        jid = model.addJoint(parent, _pin_axis_joint(link) if urdf else _pin_joint(link), placement, f"joint{i + 1}")
        M_frame = pin.SE3.Identity() if modified or urdf else dh_constant_placement(link)  # frame i in body i's frame
        inertia = pin.Inertia(link.mass, np.array(link.com, dtype=float), link.inertia_matrix)
        model.appendBodyToJoint(jid, M_frame.act(inertia), pin.SE3.Identity())
        armatures.append(link.gear_ratio ** 2 * link.motor_inertia if armature else 0.0)
        parent, placement = jid, M_frame
    if payload is not None:
        mass, com, inertia6 = payload
        ixx, iyy, izz, ixy, iyz, ixz = inertia6
        I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        model.appendBodyToJoint(parent, placement.act(pin.Inertia(mass, np.array(com, dtype=float), I)), pin.SE3.Identity())
    tip = pin.SE3(pose_matrix(desc.tip)) if urdf else pin.SE3.Identity()
    model.addFrame(pin.Frame("tool", parent, placement * tip * pin.SE3(desc.T_tool), pin.FrameType.OP_FRAME))
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

    from spatialmath import SE3

    if desc.convention == "urdf":
        return _rtb_urdf_robot(desc)
    modified = desc.convention == "modified"
    if desc.convention not in ("standard", "modified"):
        raise ValueError(f"rtb_robot: DH conventions or urdf, got {desc.convention!r}")
    revolute, prismatic = (rtb.RevoluteMDH, rtb.PrismaticMDH) if modified else (rtb.RevoluteDH, rtb.PrismaticDH)
    links = []
    for link in desc.links:
        kw = dict(
            a=link.a, alpha=link.alpha, m=link.mass, r=list(link.com), I=link.inertia_matrix,
            Jm=link.motor_inertia, G=link.gear_ratio, B=link.viscous_friction, Tc=list(link.coulomb_friction),
            flip=link.flip,
        )
        if link.is_revolute:
            links.append(revolute(d=link.d, offset=link.theta, **kw))
        else:
            links.append(prismatic(theta=link.theta, offset=link.d, **kw))
    robot = rtb.DHRobot(links, name=desc.name, base=SE3(desc.T_base, check=False), tool=SE3(desc.T_tool, check=False))
    robot.gravity = np.array(desc.gravity, dtype=float)  # RTB: the gravity acceleration vector, world frame
    return robot


def _rtb_urdf_robot(desc: RobotDescription):
    """A Robotics Toolbox ``Robot`` of ETS links ``SE3(origin) * R{x,y,z}`` (or ``t{x,y,z}``) for a urdf
    description whose joint axes are coordinate axes (as the Panda's and the UR5's)."""
    import roboticstoolbox as rtb
    from roboticstoolbox import ET
    from spatialmath import SE3

    links, parent = [], None
    for i, lk in enumerate(desc.links):
        axis = np.array(lk.axis, dtype=float) * (-1.0 if lk.flip else 1.0)
        k = int(np.argmax(np.abs(axis)))
        if abs(abs(axis[k]) - 1.0) > 1e-12:
            raise ValueError(f"rtb_robot: joint {i + 1} axis {axis.tolist()} is not a coordinate axis")
        motion = ((ET.Rx, ET.Ry, ET.Rz) if lk.is_revolute else (ET.tx, ET.ty, ET.tz))[k](flip=bool(axis[k] < 0))
        parent = rtb.Link(ET.SE3(SE3(pose_matrix(lk.origin), check=False)) * motion, name=f"link{i + 1}", parent=parent,
                          m=lk.mass, r=list(lk.com), I=lk.inertia_matrix, Jm=lk.motor_inertia, G=lk.gear_ratio,
                          B=lk.viscous_friction, Tc=list(lk.coulomb_friction))
        links.append(parent)
    robot = rtb.Robot(links, name=desc.name, base=SE3(desc.T_base, check=False),
                      tool=SE3(pose_matrix(desc.tip) @ desc.T_tool, check=False))
    robot.gravity = np.array(desc.gravity, dtype=float)
    return robot


def random_payload_parameters(desc, rng):
    """The description's parameter vector with a seeded random rigid payload (mass, com, a valid inertia)."""
    from model.dynamics import parameter_layout

    layout = parameter_layout(desc)
    p = layout.defaults.copy()
    s = layout.slices
    p[s["payload_mass"]] = rng.uniform(0.5, 3.0)
    p[s["payload_com"]] = rng.uniform(-0.1, 0.1, 3)
    A = rng.standard_normal((3, 3))
    I = 0.01 * (A @ A.T + np.eye(3))
    p[s["payload_inertia"]] = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2]]
    return p
