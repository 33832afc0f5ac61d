"""The joint-space inertia matrix by the composite-rigid-body algorithm, as straight-line SX.

The frames and symbols are those of :mod:`model.dynamics.newton_euler` (body frame i of
:mod:`model.chain`, ``A_i = (R_i, p_i)`` the pose of body i in body i-1, joint axis ``a_i`` in
body i). A rigid body about the origin of frame i is ``(m, h, I)``: its mass, first moment ``h = m c``
and inertia about the origin ``I = I_c - m [c]x [c]x``. Seen from frame i-1 (origin moved by
``p``, axes turned by ``R``)::

    h' = R h + m p,   I' = R I R^T - [R h]x [p]x - [p]x [R h]x - m [p]x [p]x

Backward, the composite body ``K_i`` (body i and everything outboard, the payload on body n) is
``K_i = body_i + K_{i+1}`` moved into frame i. Column j: joint j moving at unit rate moves ``K_j``
with momentum ``(L, H)`` about the origin of frame j, ``L = a_j x h``, ``H = I a_j`` (revolute) or
``L = m a_j``, ``H = h x a_j`` (prismatic); ``B_jj`` is ``a_j . H`` (``a_j . L``) plus the reflected
rotor ``G_j^2 Jm_j``, and for i < j the momentum moves inward, ``L <- R_{i+1} L``,
``H <- R_{i+1} H + p_{i+1} x L``, and ``B_ij = B_ji = a_i . H`` (``a_i . L``). O(n^2) operations,
against the O(n^2) of the n Newton-Euler passes of :func:`model.dynamics.symbolic._inertia_columns_ne`
with a larger constant; which of the two a build compiles is chosen by their operation counts.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ..chain import build_chain
from ..description import RobotDescription
from ..kinematics import joint_motion
from .parameters import SymbolicParameters, inertia_matrix_sx

__all__ = ["crba_sx", "crba_world_sx", "world_bodies"]


def _skew(v: Any) -> ca.SX:
    return ca.vertcat(ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0))


def _symmetric(entry: Any) -> ca.SX:
    """The symmetric 3x3 matrix of ``entry(a, b)`` for a <= b: each off-diagonal value formed once, so that
    sums of such matrices stay one expression per pair (CSE cannot see that two orderings are equal)."""
    rows = [[None] * 3 for _ in range(3)]
    for a in range(3):
        for b in range(a, 3):
            rows[a][b] = rows[b][a] = entry(a, b)
    return ca.vertcat(*[ca.horzcat(*r) for r in rows])


def _about_origin(m: Any, c: Any, I_c: Any) -> tuple[Any, ca.SX, ca.SX]:
    """``(m, h, I)`` of a body of mass m, COM c and inertia I_c about its COM (same axes), about the origin:
    ``I = I_c + m (|c|^2 1 - c c^T)`` (= ``I_c - m [c]x [c]x``), formed symmetric."""
    c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    return m, m * c, _symmetric(lambda a, b: I_c[a, b] + m * ((c2 if a == b else 0) - c[a] * c[b]))


def _rotated(R: Any, I: Any) -> ca.SX:
    """``R I R^T`` of a symmetric I, formed symmetric."""
    M = R @ I
    return _symmetric(lambda a, b: M[a, 0] * R[b, 0] + M[a, 1] * R[b, 1] + M[a, 2] * R[b, 2])


def crba_sx(desc: RobotDescription, q: ca.SX, params: SymbolicParameters) -> ca.SX:
    """(n, n) joint-space inertia B(q) of the reflected motor model (rotors as ``G^2 Jm``), kg m^2 / kg.

    Link inertial data are constants; the payload (``params``, tip frame) rides on body n.
    """
    n = desc.n
    chain = build_chain(desc)
    G = np.array([lk.gear_ratio for lk in desc.links])
    Jm = np.array([lk.motor_inertia for lk in desc.links])
    axes = [ca.DM(a) for a in chain.axes]
    A = [ca.DM(chain.placements[i]) @ joint_motion(chain.axes[i], q[i], chain.revolute[i]) for i in range(n)]
    R_tip, t_tip = ca.DM(chain.tip[:3, :3]), ca.DM(chain.tip[:3, 3])

    bodies = [_about_origin(chain.mass[i], ca.DM(chain.com[i]), ca.DM(chain.inertia[i])) for i in range(n)]
    c_p = R_tip @ params.payload_com + t_tip
    I_p = R_tip @ inertia_matrix_sx(params.payload_inertia) @ R_tip.T
    m_p, h_p, Io_p = _about_origin(params.payload_mass, c_p, I_p)
    m, h, I = bodies[n - 1]
    composite: list[Any] = [None] * n
    composite[n - 1] = (m + m_p, h + h_p, I + Io_p)
    for i in range(n - 1, 0, -1):  # move K_i into frame i-1 and add body i-1
        m, h, I = composite[i]
        R, p = A[i][0:3, 0:3], A[i][0:3, 3]
        hr = R @ h
        P, Hr = _skew(p), _skew(hr)
        h_moved = hr + m * p
        I_moved = _rotated(R, I) - _symmetric(lambda a, b: (Hr @ P)[a, b] + (Hr @ P)[b, a]) - m * (P @ P)
        mb, hb, Ib = bodies[i - 1]
        composite[i - 1] = (mb + m, hb + h_moved, Ib + I_moved)

    B = [[None] * n for _ in range(n)]
    for j in range(n):
        m, h, I = composite[j]
        a = axes[j]
        if chain.revolute[j]:
            L, H = ca.cross(a, h), I @ a
        else:
            L, H = m * a, ca.cross(h, a)
        B[j][j] = (a.T @ (H if chain.revolute[j] else L)) + G[j] * G[j] * Jm[j]
        for i in range(j - 1, -1, -1):
            R, p = A[i + 1][0:3, 0:3], A[i + 1][0:3, 3]
            L = R @ L
            H = R @ H + ca.cross(p, L)
            B[i][j] = B[j][i] = axes[i].T @ (H if chain.revolute[i] else L)
    return ca.vertcat(*[ca.horzcat(*row) for row in B])


def world_bodies(desc: RobotDescription, q: ca.SX, params: SymbolicParameters) -> tuple[list, list, list]:
    """Per body, in frame-0 axes about the frame-0 origin: motion subspace ``S_i = (u_i; o_i x u_i)``
    (revolute) or ``(0; u_i)`` (prismatic), and spatial inertia ``(m, h, I_o)`` (payload on body n);
    also the poses ``T_0i``."""
    n = desc.n
    chain = build_chain(desc)
    T = ca.SX.eye(4)
    S, bodies, poses = [], [], []
    R_tip, t_tip = ca.DM(chain.tip[:3, :3]), ca.DM(chain.tip[:3, 3])
    for i in range(n):
        T = T @ (ca.DM(chain.placements[i]) @ joint_motion(chain.axes[i], q[i], chain.revolute[i]))
        R, o = T[0:3, 0:3], T[0:3, 3]
        u = R @ ca.DM(chain.axes[i])
        S.append(ca.vertcat(u, ca.cross(o, u)) if chain.revolute[i] else ca.vertcat(ca.SX.zeros(3, 1), u))
        parts = [(chain.mass[i], ca.DM(chain.com[i]), ca.DM(chain.inertia[i]))]
        if i == n - 1:
            parts.append((params.payload_mass, R_tip @ params.payload_com + t_tip,
                          R_tip @ inertia_matrix_sx(params.payload_inertia) @ R_tip.T))
        m_sum, h_sum, I_sum = 0, ca.SX.zeros(3, 1), ca.SX.zeros(3, 3)
        for m, c, I_c in parts:
            mb, hb, Ib = _about_origin(m, o + R @ c, _rotated(R, I_c))
            m_sum, h_sum, I_sum = m_sum + mb, h_sum + hb, I_sum + Ib
        bodies.append((m_sum, h_sum, I_sum))
        poses.append(T)
    return S, bodies, poses


def crba_world_sx(desc: RobotDescription, q: ca.SX, params: SymbolicParameters) -> ca.SX:
    """(n, n) B(q) of the reflected motor model by the composite-rigid-body algorithm in frame-0 coordinates.

    As :func:`crba_sx`, with every quantity in frame 0 about its origin: composites are plain sums and
    ``B_ij = S_i . (K_j S_j)``, so moving a momentum inward costs nothing (the O(n^2) part is dot products).
    """
    n = desc.n
    G = np.array([lk.gear_ratio for lk in desc.links])
    Jm = np.array([lk.motor_inertia for lk in desc.links])
    S, bodies, _ = world_bodies(desc, q, params)
    B = [[None] * n for _ in range(n)]
    m, h, I = 0, ca.SX.zeros(3, 1), ca.SX.zeros(3, 3)
    for j in reversed(range(n)):
        mb, hb, Ib = bodies[j]
        m, h, I = m + mb, h + hb, I + Ib
        w, v = S[j][0:3], S[j][3:6]
        F = ca.vertcat(I @ w + ca.cross(h, v), m * v - ca.cross(h, w))
        for i in range(j + 1):
            B[i][j] = B[j][i] = S[i].T @ F + (G[j] * G[j] * Jm[j] if i == j else 0)
    return ca.vertcat(*[ca.horzcat(*row) for row in B])
