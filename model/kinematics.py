"""Forward kinematics and geometric Jacobians, built symbolically with CasADi.

Frames: frame 0 is the base, frame i is at the far end of link i (standard DH),
frame n is the end effector (no tool transform). Jacobians have rows
``[v; w]``: linear velocity of the frame-n origin, then angular velocity;
``jacob0`` expresses both in the base frame, ``jacobe`` in frame n.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from .description import RobotDescription

__all__ = ["dh_transform", "fkine_all_sym", "jacob0_sym", "KinematicsFunctions", "build_kinematics"]


def dh_transform(a, alpha, d, theta) -> ca.SX:
    """``Rz(theta) Tz(d) Tx(a) Rx(alpha)`` as a 4x4 CasADi matrix (arguments may be symbolic)."""
    ct, st = ca.cos(theta), ca.sin(theta)
    ca_, sa = ca.cos(alpha), ca.sin(alpha)
    return ca.vertcat(
        ca.horzcat(ct, -st * ca_, st * sa, a * ct),
        ca.horzcat(st, ct * ca_, -ct * sa, a * st),
        ca.horzcat(0, sa, ca_, d),
        ca.horzcat(0, 0, 0, 1),
    )


def fkine_all_sym(desc: RobotDescription, q: ca.SX) -> list[ca.SX]:
    """``[T_00, T_01, ..., T_0n]``: pose of every link frame in the base frame."""
    frames = [ca.SX.eye(4)]
    for i, link in enumerate(desc.links):
        if link.is_revolute:
            A = dh_transform(link.a, link.alpha, link.d, q[i] + link.theta)
        else:
            A = dh_transform(link.a, link.alpha, q[i] + link.d, link.theta)
        frames.append(ca.simplify(frames[-1] @ A))
    return frames


def jacob0_sym(desc: RobotDescription, frames: list[ca.SX], upto: int | None = None) -> ca.SX:
    """Geometric Jacobian (6 x n) of the origin of frame ``upto`` (default n), base-frame axes.

    Column i (joint i, 1-based) uses the axis z_{i-1} and origin p_{i-1} of frame i-1:
    revolute ``[z x (p_e - p); z]``, prismatic ``[z; 0]``; columns beyond ``upto`` are zero.
    """
    n = desc.n
    upto = n if upto is None else upto
    p_e = frames[upto][0:3, 3]
    cols = []
    for i, link in enumerate(desc.links):
        if i >= upto:
            cols.append(ca.SX.zeros(6, 1))
            continue
        z = frames[i][0:3, 2]
        p = frames[i][0:3, 3]
        if link.is_revolute:
            cols.append(ca.vertcat(ca.cross(z, p_e - p), z))
        else:
            cols.append(ca.vertcat(z, ca.SX.zeros(3, 1)))
    return ca.horzcat(*cols)


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
    """Build the kinematic CasADi Functions of a robot (input ``q``, n x 1)."""
    q = ca.SX.sym("q", desc.n)
    frames = fkine_all_sym(desc, q)
    T = frames[-1]
    J0 = jacob0_sym(desc, frames)
    R = T[0:3, 0:3]
    Rt6 = ca.diagcat(R.T, R.T)
    return KinematicsFunctions(
        fkine=ca.Function("fkine", [q], [T], ["q"], ["T_0E"]),
        fkine_all=ca.Function("fkine_all", [q], [ca.vertcat(*frames)], ["q"], ["T_0i"]),
        jacob0=ca.Function("jacob0", [q], [J0], ["q"], ["J_0"]),
        jacobe=ca.Function("jacobe", [q], [Rt6 @ J0], ["q"], ["J_E"]),
    )
