"""The standard dynamic parameters of an arm: the vector the joint torques are linear in.

``tau = Y(q, qd, qdd) pi`` (:mod:`model.identification.regressor`) with, for each link i = 1..n, ten
inertial parameters in **link frame i** (the frame the robot file states the link's centre of mass and
inertia in: DH frame i at the far end of link i for standard DH, frame i at joint i for modified DH,
the URDF link frame for a URDF), then four joint parameters::

    m_i                               mass, kg
    mc_xi, mc_yi, mc_zi               first moment m c (c: centre of mass in link frame i), kg m
    I_xxi, I_xyi, I_yyi, I_xzi, I_yzi, I_zzi
                                      inertia about the ORIGIN of link frame i, link-frame axes, kg m^2
                                      (Pinocchio's order of ``Inertia.toDynamicParameters``)
    Ia_i                              reflected rotor inertia G^2 Jm, kg m^2 (kg for a prismatic joint)
    fv_i                              viscous friction, joint side: G^2 B, N m s/rad (N s/m)
    fc_i                              symmetric Coulomb friction, joint side, N m (N)
    off_i                             torque offset, N m (N)

ordered link by link: ``pi = [m_1 .. I_zz1, Ia_1, fv_1, fc_1, off_1, m_2, ...]`` (14 per joint).
Inertia about the origin is ``I_o = I_c + m (|c|^2 1 - c c^T)`` with ``I_c`` the file's inertia about
the centre of mass.

Friction. The model's friction (:mod:`model.dynamics.motors`) is ``G^2 B qd + |G| Tc(sign qd)`` with
``Tc+`` for ``qd > 0`` and ``Tc-`` (<= 0) for ``qd < 0``. While the joint moves this equals
``fv qd + fc sign(qd) + o`` with ``fv = G^2 B``, ``fc = |G| (Tc+ - Tc-) / 2`` and
``o = |G| (Tc+ + Tc-) / 2``: the asymmetry of the Coulomb friction is a constant torque while moving,
the same column as a torque sensor's bias. ``off_i`` is that constant; the two cannot be told apart
from motion data. A robot file written from identified values
(:func:`model.identification.robot_file.identified_description`) gets the symmetric part as
``Tc+ = fc / |G|``, ``Tc- = -fc / |G|`` and leaves the offset out (it is reported, not modelled).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import numpy.typing as npt

from ..description import RobotDescription

__all__ = [
    "INERTIAL_FIELDS",
    "JOINT_FIELDS",
    "PER_JOINT",
    "ParameterKind",
    "parameter_names",
    "parameter_kinds",
    "standard_parameters",
    "inertial_block",
    "frame_transform",
    "pseudo_inertia",
    "inertial_from_pseudo",
    "link_inertia_about_com",
]

Array = npt.NDArray[np.float64]

#: The ten inertial parameters of one link, in vector order (Pinocchio's ``toDynamicParameters`` order).
INERTIAL_FIELDS: tuple[str, ...] = ("m", "mc_x", "mc_y", "mc_z", "I_xx", "I_xy", "I_yy", "I_xz", "I_yz", "I_zz")
#: The four joint parameters after them: reflected rotor inertia, viscous, Coulomb, offset.
JOINT_FIELDS: tuple[str, ...] = ("Ia", "fv", "fc", "off")
#: Parameters per joint (10 inertial + 4 joint).
PER_JOINT = len(INERTIAL_FIELDS) + len(JOINT_FIELDS)


class ParameterKind:
    """The groups of parameters, for selecting columns (e.g. the inertial base parameters only)."""

    INERTIAL = "inertial"
    ROTOR = "rotor"
    FRICTION = "friction"
    OFFSET = "offset"
    ALL = (INERTIAL, ROTOR, FRICTION, OFFSET)


def _field_name(field: str, link: int) -> str:
    """``m_2``, ``mc_x2``, ``I_zz2``, ``Ia_2``: the field with its 1-based link number."""
    return f"{field}_{link}" if "_" not in field else f"{field}{link}"


def parameter_names(n: int) -> tuple[str, ...]:
    """The 14 n names of ``pi``, in vector order (``m_1``, ``mc_x1``, ..., ``I_zz1``, ``Ia_1``, ``fv_1``, ``fc_1``,
    ``off_1``, ``m_2``, ...)."""
    return tuple(_field_name(f, i + 1) for i in range(n) for f in (*INERTIAL_FIELDS, *JOINT_FIELDS))


def parameter_kinds(n: int) -> tuple[str, ...]:
    """The :class:`ParameterKind` of each entry of ``pi``."""
    one = (ParameterKind.INERTIAL,) * len(INERTIAL_FIELDS) + (
        ParameterKind.ROTOR, ParameterKind.FRICTION, ParameterKind.FRICTION, ParameterKind.OFFSET)
    return one * n


def _skew(v: Array) -> Array:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _inertia_six(I: Array) -> Array:
    """(6,) ``[xx, xy, yy, xz, yz, zz]`` of a symmetric (3, 3) matrix."""
    return np.array([I[0, 0], I[0, 1], I[1, 1], I[0, 2], I[1, 2], I[2, 2]])


def _inertia_matrix(six: Sequence[float]) -> Array:
    xx, xy, yy, xz, yz, zz = six
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def inertial_block(mass: float, com: Sequence[float], inertia_com: npt.ArrayLike) -> Array:
    """(10,) inertial parameters of a body: mass (kg), centre of mass ``com`` (3,) m and inertia about it
    ``inertia_com`` (3, 3) kg m^2, all in one frame; the inertia is moved to that frame's origin."""
    c = np.asarray(com, dtype=float)
    I_o = np.asarray(inertia_com, dtype=float) + mass * (c @ c * np.eye(3) - np.outer(c, c))
    return np.concatenate([[mass], mass * c, _inertia_six(I_o)])


def link_inertia_about_com(block: npt.ArrayLike, min_mass: float = 0.0) -> tuple[float, Array, Array]:
    """``(mass, com (3,), inertia about the com (3, 3))`` of a 10-vector; a block of mass at most ``min_mass``
    is taken as massless: mass and com 0, its inertia the one about the origin."""
    b = np.asarray(block, dtype=float)
    m, h, I_o = float(b[0]), b[1:4], _inertia_matrix(b[4:10])
    if m <= min_mass:
        return 0.0, np.zeros(3), I_o
    c = h / m
    return m, c, I_o - m * (c @ c * np.eye(3) - np.outer(c, c))


def standard_parameters(desc: RobotDescription) -> Array:
    """(14 n,) ``pi`` of a description (reflected motor model): link data in link frame i as the file states
    them, ``Ia = G^2 Jm``, ``fv = G^2 B``, ``fc = |G| (Tc+ - Tc-) / 2``, ``off = |G| (Tc+ + Tc-) / 2``."""
    out = []
    for lk in desc.links:
        G = lk.gear_ratio
        tc_pos, tc_neg = lk.coulomb_friction
        out.append(inertial_block(lk.mass, lk.com, lk.inertia_matrix))
        out.append([G * G * lk.motor_inertia, G * G * lk.viscous_friction, abs(G) * (tc_pos - tc_neg) / 2,
                    abs(G) * (tc_pos + tc_neg) / 2])
    return np.concatenate(out)


def frame_transform(T_ab: npt.ArrayLike) -> Array:
    """(10, 10) map of a body's inertial parameters from frame b to frame a, ``pi_a = X pi_b``.

    ``T_ab`` is the (4, 4) pose of frame b in frame a (rotation R, origin p): a point at r in b is at
    ``R r + p`` in a, so ``m`` is kept, ``h_a = R h_b + m p`` and
    ``I_a = R I_b R^T + 2 (R h_b . p) 1 - (R h_b) p^T - p (R h_b)^T + m (|p|^2 1 - p p^T)`` (inertias
    about each frame's origin).
    """
    T = np.asarray(T_ab, dtype=float)
    R, p = T[:3, :3], T[:3, 3]
    X = np.zeros((10, 10))
    X[0, 0] = 1.0
    X[1:4, 0] = p
    X[1:4, 1:4] = R
    # I_a's six entries as linear functions of (m, h, six(I_b)), built column by column.
    for k in range(10):
        e = np.zeros(10)
        e[k] = 1.0
        m, h, I_b = e[0], e[1:4], _inertia_matrix(e[4:10])
        Rh = R @ h
        I_a = R @ I_b @ R.T + 2 * (Rh @ p) * np.eye(3) - np.outer(Rh, p) - np.outer(p, Rh) + m * (p @ p * np.eye(3) - np.outer(p, p))
        X[4:10, k] = _inertia_six(I_a)
    return X


def pseudo_inertia(block: npt.ArrayLike) -> Array:
    """(4, 4) pseudo-inertia ``J = [[S, h], [h^T, m]]``, ``S = tr(I_o)/2 1 - I_o``, of a 10-vector.

    ``J`` is positive semi-definite exactly when the parameters are those of a rigid body (mass >= 0,
    inertia about the centre of mass positive semi-definite and obeying the triangle inequality):
    the condition of a physically consistent fit.
    """
    b = np.asarray(block, dtype=float)
    I_o = _inertia_matrix(b[4:10])
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(I_o) * np.eye(3) - I_o
    J[:3, 3] = J[3, :3] = b[1:4]
    J[3, 3] = b[0]
    return J


def inertial_from_pseudo(J: npt.ArrayLike) -> Array:
    """(10,) inertial parameters of a pseudo-inertia (the inverse of :func:`pseudo_inertia`)."""
    J = np.asarray(J, dtype=float)
    S = 0.5 * (J[:3, :3] + J[:3, :3].T)
    I_o = np.trace(S) * np.eye(3) - S
    return np.concatenate([[J[3, 3]], 0.5 * (J[:3, 3] + J[3, :3]), _inertia_six(I_o)])
