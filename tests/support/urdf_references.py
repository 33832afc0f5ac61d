"""Pinocchio references for URDF robots: the same URDF file read by Pinocchio, reduced to the arm.

* :func:`pinocchio_urdf_arm`: ``pin.buildModelFromUrdf`` of the file, reduced to the chain by
  ``pin.buildReducedModel`` with every joint off the chain locked at 0 (how the workbench lumps
  fingers and grippers), with the index of the tip link's frame.
* :func:`pin_q`: our joint vector as Pinocchio's configuration.

``references.pinocchio_model`` builds a ``pin.Model`` joint by joint from the ``origin``, ``axis``, mass,
com and inertia of a urdf description (not from the file); comparing it with
:func:`pinocchio_urdf_arm` checks our reading of the file (merged fixed joints, lumped bodies, rotated
inertial origins, joint axes) without our kinematics or dynamics code.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["pinocchio_urdf_arm", "pin_q"]


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
