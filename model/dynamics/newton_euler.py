"""Recursive Newton-Euler inverse dynamics on the chain, written independently of the Lagrange model.

Every vector of body i is expressed in body frame i of the chain
(:mod:`model.chain`). With ``A_i = P_i M_i(q_i)`` the pose of body i in body
i-1, ``R = R(A_i)``, ``r_i = R^T p(A_i)`` (origin of body i seen from the
origin of body i-1, body-i axes) and ``a_i`` the joint axis (the same in the
joint frame and in body i), ``w' = R^T w_{i-1}``, ``wd' = R^T wd_{i-1}``:

forward, i = 1..n (``w_0 = wd_0 = 0``, ``vd_0 = -g_0``: gravity as a base acceleration,
``g_0 = R_W0^T g`` the world gravity in frame-0 axes)::

    vd_i = R^T vd_{i-1} + wd' x r_i + w' x (w' x r_i)
    revolute:   w_i = w' + a_i qd_i,   wd_i = wd' + a_i qdd_i + w' x a_i qd_i
    prismatic:  w_i = w',   wd_i = wd',   vd_i += a_i qdd_i + 2 w' x a_i qd_i

backward, i = n..1: ``f_i``, ``n_i`` are the force and the moment about the
body-i origin (on joint axis i) that body i-1 exerts on everything outboard of joint i::

    F_i = m_i (wd_i x c_i + w_i x (w_i x c_i) + vd_i),   N_i = I_i wd_i + w_i x (I_i w_i)
    f_i = R_{i+1} f_{i+1} + F_i
    n_i = R_{i+1} n_{i+1} + r'_{i+1} x R_{i+1} f_{i+1} + c_i x F_i + N_i
    tau_i = n_i . a_i  (revolute)   or   f_i . a_i  (prismatic)

with ``R_{i+1} = R(A_{i+1})`` and ``r'_{i+1} = p(A_{i+1})`` (body-i axes). The
payload, stated in the tip frame, adds its wrench to body n. Rotor i+1
(``"full"`` motor model) is carried by body i at the joint-(i+1) frame origin
``t = p(P_{i+1})`` and spins about ``u = R(P_{i+1}) a_{i+1}``: it adds the force
``F_r = m_r (vd_i + wd_i x t + w_i x (w_i x t))`` and the moment
``t x F_r + dh/dt`` with ``dh/dt = Jm (u.wd_i + G qdd_{i+1}) u + Jm (u.w_i + G qd_{i+1}) (w_i x u)``
to body i, and its spin equation adds ``G_i Jm_i (u_i.wd_{i-1} + G_i qdd_i)`` to
``tau_i``. The ``"reflected"`` model adds only ``G_i^2 Jm_i qdd_i``. Friction
``F(qd)`` is added last.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ..chain import Chain, build_chain
from ..description import RobotDescription
from ..kinematics import joint_motion
from .lagrange import gravity_in_frame0
from .motors import friction_sx
from .parameters import SymbolicParameters, inertia_matrix_sx

__all__ = ["forward_pass", "rne_sx"]


def _body_wrench(m: Any, c_i: Any, I_i: Any, w_i: Any, wd_i: Any, vd_i: Any) -> tuple[ca.SX, ca.SX]:
    """Inertial force and moment about the COM of a body fixed to frame i (frame-i axes)."""
    F = m * (ca.cross(wd_i, c_i) + ca.cross(w_i, ca.cross(w_i, c_i)) + vd_i)
    N = I_i @ wd_i + ca.cross(w_i, I_i @ w_i)
    return F, N


def forward_pass(chain: Chain, q: Any, qd: Any, qdd: Any, vd0: Any) -> tuple[list, list, list, list]:
    """The forward recursion of Newton-Euler: per body i, ``(A_i, w_i, wd_i, vd_i)`` (body-i axes).

    ``A_i`` is the (4, 4) pose of body i in body i-1, ``w_i``, ``wd_i`` its angular velocity and acceleration and
    ``vd_i`` the linear acceleration of its origin; ``vd0`` is that of frame 0 (``-g_0``: gravity as a base
    acceleration). The formulas are those of the module docstring.
    """
    axes = [ca.DM(a) for a in chain.axes]
    w = ca.SX.zeros(3, 1)
    wd = ca.SX.zeros(3, 1)
    vd = vd0
    A_list, w_list, wd_list, vd_list = [], [], [], []
    for i in range(chain.n):
        A = ca.DM(chain.placements[i]) @ joint_motion(chain.axes[i], q[i], chain.revolute[i])
        Rt = A[0:3, 0:3].T
        r = Rt @ A[0:3, 3]
        a = axes[i]
        wp, wdp = Rt @ w, Rt @ wd
        vd = Rt @ vd + ca.cross(wdp, r) + ca.cross(wp, ca.cross(wp, r))
        if chain.revolute[i]:
            w = wp + a * qd[i]
            wd = wdp + a * qdd[i] + ca.cross(wp, a * qd[i])
        else:
            w, wd = wp, wdp
            vd = vd + a * qdd[i] + 2 * ca.cross(wp, a * qd[i])
        A_list.append(A)
        w_list.append(w)
        wd_list.append(wd)
        vd_list.append(vd)
    return A_list, w_list, wd_list, vd_list


def rne_sx(
    desc: RobotDescription,
    motor_model: str,
    q: ca.SX,
    qd: ca.SX,
    qdd: ca.SX,
    params: SymbolicParameters,
    *,
    with_friction: bool = True,
    link_mass_scale: Any = None,
) -> ca.SX:
    """(n, 1) joint torques ``tau = B qdd + C qd + g + F`` by recursive Newton-Euler.

    Parameters
    ----------
    desc
        Robot description (any convention); body inertial data become constants.
    motor_model
        ``"reflected"`` or ``"full"`` (see :mod:`model.dynamics.motors`).
    q, qd, qdd
        (n, 1) joint positions, velocities, accelerations (rad, m and derivatives).
    params
        Symbolic payload (tip frame), friction and gravity (world frame).
    with_friction
        Add F(qd); False gives the rigid-body-plus-rotor torque only.
    link_mass_scale
        None (the description's links), or a (symbolic) factor on every link's mass and inertia
        (centres of mass, rotors and payload unchanged): the plant of a sweep over link masses.
    """
    n = desc.n
    chain = build_chain(desc)
    G = np.array([lk.gear_ratio for lk in desc.links])
    Jm = np.array([lk.motor_inertia for lk in desc.links])
    full = motor_model == "full"
    axes = [ca.DM(a) for a in chain.axes]

    A_list, w_list, wd_list, vd_list = forward_pass(chain, q, qd, qdd, -gravity_in_frame0(chain.base, params.gravity))
    wd_prev = [ca.SX.zeros(3, 1), *wd_list[:-1]]  # wd of body i-1 (frame i-1 axes), for the spin equation of rotor i

    R_tip, t_tip = ca.DM(chain.tip[:3, :3]), ca.DM(chain.tip[:3, 3])
    tau = [None] * n
    f = ca.SX.zeros(3, 1)
    nm = ca.SX.zeros(3, 1)
    for i in reversed(range(n)):
        w, wd, vd = w_list[i], wd_list[i], vd_list[i]
        c_i = ca.DM(chain.com[i])
        m_i, I_i = chain.mass[i], ca.DM(chain.inertia[i])
        if link_mass_scale is not None:
            m_i, I_i = m_i * link_mass_scale, I_i * link_mass_scale
        F, N = _body_wrench(m_i, c_i, I_i, w, wd, vd)
        if i + 1 < n:
            A_next = A_list[i + 1]
            f_out = A_next[0:3, 0:3] @ f
            n_new = A_next[0:3, 0:3] @ nm + ca.cross(A_next[0:3, 3], f_out) + ca.cross(c_i, F) + N
        else:
            f_out = ca.SX.zeros(3, 1)
            n_new = ca.cross(c_i, F) + N
        f_new = f_out + F
        if i == n - 1:
            c_p = R_tip @ params.payload_com + t_tip
            I_p = R_tip @ inertia_matrix_sx(params.payload_inertia) @ R_tip.T
            F_p, N_p = _body_wrench(params.payload_mass, c_p, I_p, w, wd, vd)
            f_new += F_p
            n_new += ca.cross(c_p, F_p) + N_p
        if full and i + 1 < n:  # rotor of joint i+1 (0-based) rides on body i, at the joint-(i+1) frame
            P = chain.placements[i + 1]
            t, u = ca.DM(P[:3, 3]), ca.DM(P[:3, :3] @ chain.axes[i + 1])
            F_r = desc.links[i + 1].rotor_mass * (vd + ca.cross(wd, t) + ca.cross(w, ca.cross(w, t)))
            spin = Jm[i + 1] * (u.T @ w + G[i + 1] * qd[i + 1])
            hdot = Jm[i + 1] * (u.T @ wd + G[i + 1] * qdd[i + 1]) * u + spin * ca.cross(w, u)
            f_new += F_r
            n_new += ca.cross(t, F_r) + hdot
        f, nm = f_new, n_new
        tau_i = (nm.T @ axes[i]) if chain.revolute[i] else (f.T @ axes[i])
        if full:
            u_i = ca.DM(chain.placements[i][:3, :3] @ chain.axes[i])
            tau_i += G[i] * Jm[i] * (u_i.T @ wd_prev[i] + G[i] * qdd[i])
        else:
            tau_i += G[i] * G[i] * Jm[i] * qdd[i]
        tau[i] = tau_i
    tau_sx = ca.vertcat(*tau)
    if with_friction:
        tau_sx += friction_sx(G, qd, params.viscous_friction, params.coulomb_friction_pos, params.coulomb_friction_neg)
    return tau_sx
