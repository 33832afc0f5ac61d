"""Lagrange formulation: B(q) from the link Jacobians, C(q, qd) from Christoffel symbols, g(q) = dU/dq.

Kinetic energy ``T = 1/2 qd^T B(q) qd`` with::

    B(q) = sum_i  m_i J_v,Ci^T J_v,Ci + J_w,i^T R_0i I_i R_0i^T J_w,i      (links, payload on link n)
           + rotor terms (see :mod:`model.dynamics.motors`)

Body i is body i of the chain (:mod:`model.chain`): ``R_0i``, ``p_0i`` its
frame in frame 0, ``c_i``, ``I_i`` its centre of mass and inertia in that
frame. ``J_v,Ci`` is the linear Jacobian of the centre of mass
``p_0Ci = p_0i + R_0i c_i``, ``J_w,i`` the angular Jacobian of body i, both in
frame-0 axes; gravity (world frame) enters as ``g_0 = R_W0^T g``. The payload
is a body fixed to the tip frame (DH frame n), its com and inertia in that frame. The
Christoffel symbols of the first kind
``c_ijk = 1/2 (db_ij/dq_k + db_ik/dq_j - db_jk/dq_i)`` summed with ``qd_k``
give ``C = 1/2 (Bdot + D - D^T)`` where ``D = d(B qd)/dq``; this is the C for
which ``Bdot - 2C`` is skew-symmetric. Potential energy
``U = -sum m g^T p_0C`` and ``g(q) = (dU/dq)^T``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from ..chain import build_chain
from ..description import RobotDescription
from ..kinematics import chain_frames_sym, point_jacobian_sym
from .motors import rotor_energy_terms
from .parameters import SymbolicParameters, inertia_matrix_sx

__all__ = ["LagrangeModel", "lagrange_model", "christoffel_coriolis", "gravity_in_frame0"]


@dataclass(frozen=True)
class LagrangeModel:
    """Symbolic Lagrange quantities of one robot (CasADi SX, in terms of ``q``, ``qd`` and ``p``).

    Attributes
    ----------
    B
        (n, n) joint-space inertia matrix, kg m^2 (revolute) / kg (prismatic).
    C
        (n, n) Coriolis/centrifugal matrix from Christoffel symbols.
    g
        (n, 1) gravity torques, N m / N.
    T, U
        Kinetic and potential energy, J (rotors included, as the motor model says).
    """

    B: ca.SX
    C: ca.SX
    g: ca.SX
    T: ca.SX
    U: ca.SX


def christoffel_coriolis(B: ca.SX, q: ca.SX, qd: ca.SX) -> ca.SX:
    """``C_ij = sum_k c_ijk qd_k`` with the Christoffel symbols of the first kind of ``B(q)``."""
    Bdot = ca.jtimes(B, q, qd)
    D = ca.jacobian(B @ qd, q)
    return 0.5 * (Bdot + D - D.T)


def _skew(r: ca.SX) -> ca.SX:
    return ca.vertcat(
        ca.horzcat(0, -r[2], r[1]),
        ca.horzcat(r[2], 0, -r[0]),
        ca.horzcat(-r[1], r[0], 0),
    )


def _body_terms(m: Any, c_i: Any, I_i: Any, T_0i: ca.SX, J_v: ca.SX, J_w: ca.SX, gravity: Any) -> tuple[ca.SX, ca.SX]:
    """Inertia-matrix and potential-energy terms of a rigid body fixed to frame i."""
    R_0i = T_0i[0:3, 0:3]
    r_0 = R_0i @ c_i  # COM offset from the frame-i origin, base axes
    J_vc = J_v - _skew(r_0) @ J_w
    I_0 = R_0i @ I_i @ R_0i.T
    B = m * (J_vc.T @ J_vc) + J_w.T @ I_0 @ J_w
    U = -m * (gravity.T @ (T_0i[0:3, 3] + r_0))
    return B, U


def gravity_in_frame0(base: np.ndarray, gravity: Any) -> Any:
    """Gravity (3 x 1, world frame, m/s^2) in frame-0 axes: ``R_W0^T g``; unchanged without a base rotation."""
    R = np.asarray(base, dtype=float)[:3, :3]
    return gravity if np.array_equal(R, np.eye(3)) else ca.DM(R.T) @ gravity


def lagrange_model(desc: RobotDescription, motor_model: str, q: ca.SX, qd: ca.SX, params: SymbolicParameters) -> LagrangeModel:
    """Build B, C, g and the energies of ``desc`` symbolically.

    Parameters
    ----------
    desc
        Robot description (link inertial data become constants).
    motor_model
        ``"reflected"`` or ``"full"``.
    q, qd
        (n, 1) SX joint positions and velocities.
    params
        Symbolic payload and gravity (friction is not part of the Lagrangian).
    """
    n = desc.n
    chain = build_chain(desc)
    frames = chain_frames_sym(chain, q)
    J_v = [ca.SX.zeros(3, n)]
    J_w = [ca.SX.zeros(3, n)]
    for k in range(1, n + 1):
        J_k = point_jacobian_sym(chain, frames, frames.body[k][0:3, 3], upto=k)
        J_v.append(J_k[0:3, :])
        J_w.append(J_k[3:6, :])
    gravity = gravity_in_frame0(chain.base, params.gravity)
    B = ca.SX.zeros(n, n)
    U = ca.SX(0)
    for k in range(1, n + 1):
        m, c, I = chain.mass[k - 1], chain.com[k - 1], chain.inertia[k - 1]
        if m == 0 and not np.any(I):
            continue
        B_k, U_k = _body_terms(m, ca.DM(c), ca.DM(I), frames.body[k], J_v[k], J_w[k], gravity)
        B += B_k
        U += U_k
    T_tip = frames.body[n] @ ca.DM(chain.tip)
    J_tip = point_jacobian_sym(chain, frames, T_tip[0:3, 3], upto=n)
    B_p, U_p = _body_terms(
        params.payload_mass, params.payload_com, inertia_matrix_sx(params.payload_inertia),
        T_tip, J_tip[0:3, :], J_w[n], gravity,
    )
    B_m, U_m = rotor_energy_terms(desc, motor_model, chain, frames, J_w, gravity)
    B = B + B_p + B_m
    U = U + U_p + U_m
    C = christoffel_coriolis(B, q, qd)
    g = ca.gradient(U, q)
    T = 0.5 * (qd.T @ B @ qd)
    return LagrangeModel(B=B, C=C, g=g, T=T, U=U)
