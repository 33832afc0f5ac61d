"""Motor and gearbox terms: friction, and the rotor's share of the kinetic and potential energy.

Two motor models (``MOTOR_MODELS``):

``"reflected"``
    The Robotics Toolbox convention: rotor i only adds ``G_i^2 Jm_i`` to the
    diagonal of B(q); its mass is assumed lumped into the link data.
``"full"``
    Rotor i is a body carried by body i-1 of the chain (:mod:`model.chain`;
    the base for i = 1), centred on joint axis i at the origin of the joint-i
    frame (DH frame i-1 for standard DH), mass ``rotor_mass_i``, inertia
    ``Jm_i`` about its spin axis ``a_i`` (the joint axis) and no transverse
    inertia. Its angular velocity is ``w_{i-1} + G_i qd_i a_i``, which gives the
    off-diagonal ``G_i Jm_i a_i^T J_w,i-1`` terms of B(q).

Friction (both models) is motor-side data reflected to the joint:
``F_i(qd) = G_i^2 B_i qd_i + |G_i| Tc_i(sign qd_i)`` with ``Tc+`` for
``qd > 0``, ``Tc-`` for ``qd < 0`` and 0 at ``qd = 0``; F is the torque the
joint must supply to overcome friction (positive with ``qd``). That is the
law of a sliding joint; a joint at rest sticks or breaks loose by the friction
modes of :mod:`model.dynamics.stick_slip`, which the plant (:mod:`model.plant`)
integrates.
"""

from __future__ import annotations

from typing import Any, Sequence

import casadi as ca
import numpy as np

from ..chain import Chain
from ..description import RobotDescription
from ..kinematics import point_jacobian_sym
from ..errors import InputError

__all__ = ["MOTOR_MODELS", "check_motor_model", "coulomb_limits_sx", "friction_sx", "rotor_energy_terms",
           "viscous_friction_sx"]

MOTOR_MODELS: tuple[str, ...] = ("reflected", "full")


def check_motor_model(motor_model: str) -> str:
    """Return ``motor_model`` if it is one of :data:`MOTOR_MODELS`; ValueError naming it otherwise."""
    if motor_model not in MOTOR_MODELS:
        raise InputError(f"expected one of {MOTOR_MODELS}, got {motor_model!r}", parameter="motor_model")
    return motor_model


def viscous_friction_sx(gear_ratio: np.ndarray, qd: Any, viscous: Any) -> list[Any]:
    """The n joint viscous friction torques ``G_i^2 B_i qd_i``, N m or N (motor-side ``viscous``, N m s/rad)."""
    return [g * g * viscous[i] * qd[i] for i, g in enumerate(np.asarray(gear_ratio, dtype=float))]


def coulomb_limits_sx(gear_ratio: np.ndarray, coulomb_pos: Any, coulomb_neg: Any) -> tuple[ca.SX, ca.SX]:
    """(n, 1) joint-side Coulomb torques ``(|G| Tc+, |G| Tc-)``, N m or N, of the motor-side coefficients."""
    G = ca.DM(np.abs(np.asarray(gear_ratio, dtype=float)))
    return G * coulomb_pos, G * coulomb_neg


def friction_sx(gear_ratio: np.ndarray, qd: Any, viscous: Any, coulomb_pos: Any, coulomb_neg: Any) -> ca.SX:
    """(n, 1) joint friction torque F(qd), N m or N: viscous plus the Coulomb torque of the sign of ``qd``.

    This is the sliding law (0 at ``qd_i = 0``); whether a joint at rest sticks is decided by the
    friction modes of :mod:`model.dynamics.stick_slip`.

    Parameters
    ----------
    gear_ratio
        (n,) reduction ratios G (motor angle = G q).
    qd
        (n, 1) joint velocities, rad/s or m/s.
    viscous, coulomb_pos, coulomb_neg
        (n, 1) motor-side viscous (N m s/rad) and Coulomb (N m) coefficients.

    Branch-free: the Coulomb torque is ``Tc+ (qd > 0) + Tc- (qd < 0)`` with the comparisons as 0/1
    factors, which C evaluates without a jump (no misprediction where a joint reverses); for finite
    coefficients it rounds to the same bits as the choice ``Tc+ if qd > 0 else Tc- if qd < 0 else 0``
    (``x * 1 = x``, ``x * 0 = +-0`` and ``y + +-0 = y``; at ``qd = 0`` or NaN both give +0).
    """
    terms = []
    for i, (g, visc) in enumerate(zip(np.asarray(gear_ratio, dtype=float), viscous_friction_sx(gear_ratio, qd, viscous))):
        coulomb = coulomb_pos[i] * (qd[i] > 0) + coulomb_neg[i] * (qd[i] < 0)
        terms.append(visc + abs(g) * coulomb)
    return ca.vertcat(*terms)


def rotor_energy_terms(
    desc: RobotDescription,
    motor_model: str,
    chain: Chain,
    frames: Any,
    J_w: Sequence[ca.SX],
    gravity: Any,
) -> tuple[ca.SX, ca.SX]:
    """Rotor contributions ``(B_m, U_m)`` to the inertia matrix and the potential energy.

    Parameters
    ----------
    chain, frames
        The chain of ``desc`` and its symbolic frames (:func:`model.kinematics.chain_frames_sym`), frame 0.
    J_w
        For k = 0..n, the (3, n) angular Jacobian of body k (k = 0: the base, zeros), frame-0 axes.
    gravity
        (3, 1) gravitational acceleration in frame-0 axes, m/s^2.

    Returns
    -------
    B_m
        (n, n) rotor inertia matrix contribution, kg m^2.
    U_m
        Rotor potential energy, J (zero in the reflected model).
    """
    n = desc.n
    G = np.array([lk.gear_ratio for lk in desc.links])
    Jm = np.array([lk.motor_inertia for lk in desc.links])
    if motor_model == "reflected":
        return ca.SX(ca.DM(np.diag(G * G * Jm))), ca.SX(0)
    B_m = ca.SX.zeros(n, n)
    U_m = ca.SX(0)
    for i, link in enumerate(desc.links):  # rotor of joint i (0-based) rides on body i, at the joint-i frame
        J = frames.joint[i]
        a_0 = J[0:3, 0:3] @ ca.DM(chain.axes[i])
        spin_row = a_0.T @ J_w[i]  # (1, n): a . w_{body i} per joint rate
        e_i = ca.DM.zeros(1, n)
        e_i[i] = G[i]
        a_row = spin_row + e_i  # rotor spin rate about its axis, per joint rate
        B_m += Jm[i] * (a_row.T @ a_row)
        if link.rotor_mass:
            p_0 = J[0:3, 3]
            J_v = point_jacobian_sym(chain, frames, p_0, upto=i)[0:3, :]
            B_m += link.rotor_mass * (J_v.T @ J_v)
            U_m -= link.rotor_mass * (gravity.T @ p_0)
    return B_m, U_m
