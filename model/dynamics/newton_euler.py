"""Recursive Newton-Euler inverse dynamics, written independently of the Lagrange model.

Every vector of link i is expressed in frame i (standard DH, frame i at the
far end of link i). With ``R = R_{i-1,i} = Rz(theta_i) Rx(alpha_i)``,
``p_i = [a_i, d_i sin(alpha_i), d_i cos(alpha_i)]`` (origin of frame i seen
from the origin of frame i-1, frame-i axes) and ``z = [0, 0, 1]``:

forward, i = 1..n (``w_0 = wd_0 = 0``, ``vd_0 = -gravity``, gravity as a base acceleration)::

    revolute:   w_i  = R^T (w_{i-1} + z qd_i)
                wd_i = R^T (wd_{i-1} + z qdd_i + w_{i-1} x z qd_i)
                vd_i = wd_i x p_i + w_i x (w_i x p_i) + R^T vd_{i-1}
    prismatic:  w_i  = R^T w_{i-1},   wd_i = R^T wd_{i-1}
                vd_i = R^T (vd_{i-1} + z qdd_i) + wd_i x p_i + 2 w_i x (R^T z qd_i) + w_i x (w_i x p_i)

backward, i = n..1: ``f_i``, ``n_i`` are the force and the moment about the
origin of frame i-1 that link i-1 exerts on everything outboard of joint i::

    F_i = m_i (wd_i x c_i + w_i x (w_i x c_i) + vd_i),   N_i = I_i wd_i + w_i x (I_i w_i)
    f_i = R_{i,i+1} f_{i+1} + F_i
    n_i = R_{i,i+1} n_{i+1} + p_i x R_{i,i+1} f_{i+1} + (p_i + c_i) x F_i + N_i
    tau_i = n_i . (R^T z)  (revolute)   or   f_i . (R^T z)  (prismatic)

The payload adds its wrench to link n. Rotor i+1 (``"full"`` motor model) is
carried by link i at the origin of frame i and spins about ``z``: it adds the
force ``m_r vd_i`` and the moment ``dh/dt = Jm (z.wd_i + G qdd_{i+1}) z +
Jm (z.w_i + G qd_{i+1}) (w_i x z)`` to link i, and its spin equation adds
``G_i Jm_i (z.wd_{i-1} + G_i qdd_i)`` to ``tau_i``. The ``"reflected"`` model
adds only ``G_i^2 Jm_i qdd_i``. Friction ``F(qd)`` is added last.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ..description import RobotDescription
from .motors import friction_sx
from .parameters import SymbolicParameters, inertia_matrix_sx

__all__ = ["rne_sx"]


def _link_rotation(alpha: float, theta: Any) -> ca.SX:
    """``R_{i-1,i} = Rz(theta) Rx(alpha)``."""
    ct, st = ca.cos(theta), ca.sin(theta)
    c_al, s_al = float(np.cos(alpha)), float(np.sin(alpha))
    return ca.vertcat(
        ca.horzcat(ct, -st * c_al, st * s_al),
        ca.horzcat(st, ct * c_al, -ct * s_al),
        ca.horzcat(0, s_al, c_al),
    )


def _body_wrench(m: Any, c_i: Any, I_i: Any, w_i: Any, wd_i: Any, vd_i: Any) -> tuple[ca.SX, ca.SX]:
    """Inertial force and moment about the COM of a body fixed to frame i (frame-i axes)."""
    F = m * (ca.cross(wd_i, c_i) + ca.cross(w_i, ca.cross(w_i, c_i)) + vd_i)
    N = I_i @ wd_i + ca.cross(w_i, I_i @ w_i)
    return F, N


def rne_sx(
    desc: RobotDescription,
    motor_model: str,
    q: ca.SX,
    qd: ca.SX,
    qdd: ca.SX,
    params: SymbolicParameters,
    *,
    with_friction: bool = True,
) -> ca.SX:
    """(n, 1) joint torques ``tau = B qdd + C qd + g + F`` by recursive Newton-Euler.

    Parameters
    ----------
    desc
        Robot description; link inertial data become constants.
    motor_model
        ``"reflected"`` or ``"full"`` (see :mod:`model.dynamics.motors`).
    q, qd, qdd
        (n, 1) joint positions, velocities, accelerations (rad, m and derivatives).
    params
        Symbolic payload, friction and gravity.
    with_friction
        Add F(qd); False gives the rigid-body-plus-rotor torque only.
    """
    n = desc.n
    z = ca.DM([0.0, 0.0, 1.0])
    G = np.array([lk.gear_ratio for lk in desc.links])
    Jm = np.array([lk.motor_inertia for lk in desc.links])
    full = motor_model == "full"

    w = ca.SX.zeros(3, 1)
    wd = ca.SX.zeros(3, 1)
    vd = -params.gravity
    R_list, p_list, w_list, wd_list, vd_list = [], [], [], [], []
    spin_acc = []  # z_{i-1} . wd_{i-1}, frame i-1 (0 for the base)
    for i, link in enumerate(desc.links):
        spin_acc.append(wd[2])
        theta = q[i] + link.theta if link.is_revolute else link.theta
        d = link.d if link.is_revolute else q[i] + link.d
        R = _link_rotation(link.alpha, theta)
        Rt = R.T
        p_i = ca.vertcat(link.a, d * np.sin(link.alpha), d * np.cos(link.alpha))
        if link.is_revolute:
            w_new = Rt @ (w + z * qd[i])
            wd_new = Rt @ (wd + z * qdd[i] + ca.cross(w, z * qd[i]))
            vd_new = ca.cross(wd_new, p_i) + ca.cross(w_new, ca.cross(w_new, p_i)) + Rt @ vd
        else:
            w_new = Rt @ w
            wd_new = Rt @ wd
            vd_new = (
                Rt @ (vd + z * qdd[i]) + ca.cross(wd_new, p_i)
                + 2 * ca.cross(w_new, Rt @ z * qd[i]) + ca.cross(w_new, ca.cross(w_new, p_i))
            )
        w, wd, vd = w_new, wd_new, vd_new
        R_list.append(R)
        p_list.append(p_i)
        w_list.append(w)
        wd_list.append(wd)
        vd_list.append(vd)

    tau = [None] * n
    f = ca.SX.zeros(3, 1)
    nm = ca.SX.zeros(3, 1)
    R_next = ca.SX.eye(3)
    for i in reversed(range(n)):
        link = desc.links[i]
        w, wd, vd, p_i = w_list[i], wd_list[i], vd_list[i], p_list[i]
        c_i = ca.DM(link.com)
        F, N = _body_wrench(link.mass, c_i, ca.DM(link.inertia_matrix), w, wd, vd)
        f_out = R_next @ f
        n_new = R_next @ nm + ca.cross(p_i, f_out) + ca.cross(p_i + c_i, F) + N
        f_new = f_out + F
        if i == n - 1:
            c_p = params.payload_com
            F_p, N_p = _body_wrench(params.payload_mass, c_p, inertia_matrix_sx(params.payload_inertia), w, wd, vd)
            f_new += F_p
            n_new += ca.cross(p_i + c_p, F_p) + N_p
        if full and i + 1 < n:  # rotor i+2 (1-based) rides on link i+1 at the origin of frame i+1
            nxt = desc.links[i + 1]
            F_r = nxt.rotor_mass * vd
            spin = Jm[i + 1] * (w[2] + G[i + 1] * qd[i + 1])
            hdot = Jm[i + 1] * (wd[2] + G[i + 1] * qdd[i + 1]) * z + spin * ca.cross(w, z)
            f_new += F_r
            n_new += ca.cross(p_i, F_r) + hdot
        f, nm = f_new, n_new
        axis = R_list[i].T @ z
        tau_i = (nm.T @ axis) if link.is_revolute else (f.T @ axis)
        if full:
            tau_i += G[i] * Jm[i] * (spin_acc[i] + G[i] * qdd[i])
        else:
            tau_i += G[i] * G[i] * Jm[i] * qdd[i]
        tau[i] = tau_i
        R_next = R_list[i]
    tau_sx = ca.vertcat(*tau)
    if with_friction:
        tau_sx += friction_sx(G, qd, params.viscous_friction, params.coulomb_friction_pos, params.coulomb_friction_neg)
    return tau_sx
