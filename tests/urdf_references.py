"""Pinocchio references for URDF robots: the same URDF file read by Pinocchio, and a description rebuilt in Pinocchio.

* :func:`pinocchio_urdf_arm`: ``pin.buildModelFromUrdf`` of the file, reduced to the chain by
  ``pin.buildReducedModel`` with every joint off the chain locked at 0 (how the workbench lumps
  fingers and grippers), with the index of the tip link's frame.
* :func:`pinocchio_from_description`: a ``pin.Model`` built joint by joint from the ``origin``, ``axis``,
  mass, com and inertia of a ``convention = "urdf"`` description (not from the file), frame ``"tip"`` at
  the tip link. Comparing the two checks our reading of the file (merged fixed joints, lumped bodies,
  rotated inertial origins, joint axes) without our kinematics or dynamics code.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from model.description import RobotDescription

__all__ = ["pinocchio_urdf_arm", "pinocchio_from_description", "pin_q"]


def pinocchio_urdf_arm(path, tip_link: str, chain_joints, gravity=(0.0, 0.0, -9.81), armature=None):
    """(model, frame id of ``tip_link``): the URDF read by Pinocchio, every joint not in ``chain_joints`` locked at 0."""
    full = pin.buildModelFromUrdf(str(path))
    lock = [full.getJointId(name) for name in full.names[1:] if name not in chain_joints]
    model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
    assert [model.names[i] for i in range(1, model.njoints)] == list(chain_joints)
    model.gravity = pin.Motion(np.array(gravity, dtype=float), np.zeros(3))
    if armature is not None:
        model.armature = np.array(armature, dtype=float)
    return model, model.getFrameId(tip_link)


def pin_q(model, q):
    """Our joint vector as Pinocchio's configuration: a continuous joint is (cos q, sin q) there."""
    out = []
    for i, joint in enumerate(model.joints[1:]):
        if joint.nq == 2:
            out += [np.cos(q[joint.idx_v]), np.sin(q[joint.idx_v])]
        else:
            out.append(q[joint.idx_v])
    return np.array(out)


def _se3(pose16) -> pin.SE3:
    T = np.array(pose16, dtype=float).reshape(4, 4)
    return pin.SE3(T[:3, :3], T[:3, 3])


def pinocchio_from_description(desc: RobotDescription, armature: bool = True):
    """A ``pin.Model`` from the links of a URDF-convention description, frame ``"tip"`` at the tip link."""
    assert desc.convention == "urdf"
    model = pin.Model()
    model.gravity = pin.Motion(np.array(desc.gravity, dtype=float), np.zeros(3))
    parent = 0
    base = pin.SE3.Identity() if desc.base is None else _se3(desc.base)
    for i, link in enumerate(desc.links):
        axis = np.array(link.axis, dtype=float)
        joint = pin.JointModelRevoluteUnaligned(axis) if link.is_revolute else pin.JointModelPrismaticUnaligned(axis)
        placement = _se3(link.origin)
        if i == 0:
            placement = base * placement
        parent = model.addJoint(parent, joint, placement, link.name or f"joint{i + 1}")
        model.appendBodyToJoint(parent, pin.Inertia(link.mass, np.array(link.com), link.inertia_matrix), pin.SE3.Identity())
    tip = pin.SE3.Identity() if desc.tip is None else _se3(desc.tip)
    if desc.tool is not None:
        tip = tip * _se3(desc.tool)
    model.addFrame(pin.Frame("tip", parent, tip, pin.FrameType.OP_FRAME))
    model.armature = np.array([lk.gear_ratio ** 2 * lk.motor_inertia if armature else 0.0 for lk in desc.links])
    return model
