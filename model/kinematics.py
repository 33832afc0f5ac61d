"""Forward kinematics and geometric Jacobians of the chain (:mod:`model.chain`), built with CasADi.

Frames: the world frame W; frame 0, the robot base, at pose ``base`` in W;
body frame i (joint frame i moved by q_i), reported link frame i (DH frame i
at the far end of link i for standard DH, the body frame otherwise), and the
tool frame E: ``T_WE = base T_{0,n} tip tool``. Jacobians have rows
``[v; w]``: linear velocity of the E origin, then angular velocity;
``jacob0`` expresses both in W, ``jacobe`` in E.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from .chain import Chain, build_chain
from .description import RobotDescription

__all__ = [
    "ChainFrames",
    "joint_motion",
    "chain_frames_sym",
    "point_jacobian_sym",
    "fkine_all_sym",
    "KinematicsFunctions",
    "build_kinematics",
]


def joint_motion(axis: np.ndarray, q, revolute: bool) -> ca.SX:
    """(4, 4) motion of a joint: rotation by q about the unit ``axis`` (revolute) or translation q along it.

    An axis along a coordinate axis (the DH case) gives the plain Rx/Ry/Rz or Tx/Ty/Tz.
    """
    u = np.asarray(axis, dtype=float)
    if not revolute:
        T = ca.SX.eye(4)
        for k in range(3):
            if u[k] != 0.0:
                T[k, 3] = float(u[k]) * q
        return T
    nonzero = np.flatnonzero(u)
    c = ca.cos(q)
    if len(nonzero) == 1:  # +-x, +-y or +-z: Rot(-e, q) = Rot(e, -q)
        k = int(nonzero[0])
        s = float(np.sign(u[k])) * ca.sin(q)
        i, j = (k + 1) % 3, (k + 2) % 3
        T = ca.SX.eye(4)
        T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
        return T
    s = ca.sin(q)
    K = ca.DM([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    R = ca.DM.eye(3) + s * K + (1 - c) * (K @ K)  # Rodrigues
    return ca.vertcat(ca.horzcat(R, ca.SX.zeros(3, 1)), ca.horzcat(ca.SX.zeros(1, 3), 1))


def _mul(A: ca.SX, B: np.ndarray) -> ca.SX:
    """``A @ B`` skipping an identity B."""
    return A if np.array_equal(B, np.eye(4)) else A @ ca.DM(B)


@dataclass(frozen=True)
class ChainFrames:
    """Symbolic poses in frame 0: ``body[i]`` (i = 0..n, body 0 = frame 0) and ``joint[i]`` (joint i+1, i = 0..n-1)."""

    body: list[ca.SX]
    joint: list[ca.SX]


def chain_frames_sym(chain: Chain, q: ca.SX) -> ChainFrames:
    """Body and joint frames of ``chain`` at ``q`` (n x 1 SX), in frame 0."""
    body = [ca.SX.eye(4)]
    joint = []
    for i in range(chain.n):
        J = ca.simplify(_mul(body[-1], chain.placements[i]))
        joint.append(J)
        body.append(ca.simplify(J @ joint_motion(chain.axes[i], q[i], chain.revolute[i])))
    return ChainFrames(body=body, joint=joint)


def point_jacobian_sym(chain: Chain, frames: ChainFrames, p: ca.SX, upto: int | None = None) -> ca.SX:
    """(6, n) geometric Jacobian ``[v; w]`` of a point ``p`` (3 x 1, frame 0) fixed to body ``upto`` (default n).

    Column i uses joint i's axis ``a = R_0J u_i`` and origin ``o``: revolute ``[a x (p - o); a]``,
    prismatic ``[a; 0]``; joints beyond ``upto`` give zero columns. Frame-0 axes.
    """
    upto = chain.n if upto is None else upto
    cols = []
    for i in range(chain.n):
        if i >= upto:
            cols.append(ca.SX.zeros(6, 1))
            continue
        J = frames.joint[i]
        a = J[0:3, 0:3] @ ca.DM(chain.axes[i])
        if chain.revolute[i]:
            cols.append(ca.vertcat(ca.cross(a, p - J[0:3, 3]), a))
        else:
            cols.append(ca.vertcat(a, ca.SX.zeros(3, 1)))
    return ca.horzcat(*cols)


def fkine_all_sym(desc: RobotDescription, q: ca.SX) -> list[ca.SX]:
    """``[T_W0, T_W1, ..., T_Wn]``: world poses of frame 0 and of every reported link frame."""
    chain = build_chain(desc)
    frames = chain_frames_sym(chain, q)
    base = ca.DM(chain.base)
    return [base] + [base @ _mul(frames.body[i + 1], chain.reported[i]) for i in range(chain.n)]


@dataclass(frozen=True)
class KinematicsFunctions:
    """Named CasADi Functions of one robot: ``fkine``, ``fkine_all``, ``jacob0``, ``jacobe``.

    ``fkine_all`` returns the frames stacked vertically, a (4(n+1), 4) matrix.
    """

    fkine: ca.Function
    fkine_all: ca.Function
    jacob0: ca.Function
    jacobe: ca.Function


def build_kinematics(desc: RobotDescription) -> KinematicsFunctions:
    """Build the kinematic CasADi Functions of a robot (input ``q``, n x 1; outputs in the world frame)."""
    chain = build_chain(desc)
    q = ca.SX.sym("q", desc.n)
    frames = chain_frames_sym(chain, q)
    T_0E = _mul(_mul(frames.body[-1], chain.tip), chain.tool)
    J_0 = point_jacobian_sym(chain, frames, T_0E[0:3, 3])
    R_W0 = ca.DM(chain.base[:3, :3])
    T_WE = ca.DM(chain.base) @ T_0E
    J_W = ca.diagcat(R_W0, R_W0) @ J_0
    R = T_WE[0:3, 0:3]
    all_frames = fkine_all_sym(desc, q)
    return KinematicsFunctions(
        fkine=ca.Function("fkine", [q], [T_WE], ["q"], ["T_WE"]),
        fkine_all=ca.Function("fkine_all", [q], [ca.vertcat(*all_frames)], ["q"], ["T_Wi"]),
        jacob0=ca.Function("jacob0", [q], [J_W], ["q"], ["J_W"]),
        jacobe=ca.Function("jacobe", [q], [ca.diagcat(R.T, R.T) @ J_W], ["q"], ["J_E"]),
    )
