"""The one kinematic representation of a serial arm: fixed placements and joint motions.

Standard DH, modified DH and URDF all map to the same chain, as in Pinocchio.
Joint ``i`` (1-based) has a fixed placement ``P_i`` (the pose of the joint
frame in the previous body frame; body 0 is frame 0, the robot base), then
moves about (revolute) or along (prismatic) a unit axis ``u_i`` given in the
joint frame::

    T_{0,i} = T_{0,i-1} P_i M_i(q_i),   M_i = Rot(u_i, q_i) or Trans(u_i q_i)

Body ``i`` is rigid with the moved joint frame (the *body frame*); its mass,
centre of mass and inertia about the centre of mass are stated in it. The
world pose of the tool is ``T_WE = base T_{0,n} tip tool``, and each body has
a fixed *reported* frame ``F_i`` (the frame a user's table numbers as frame i):
``T_{0,i}^rep = T_{0,i} F_i``.

Standard DH (``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``): with
``C_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)`` built from the constant values
(offset ``theta`` for a revolute joint, ``d`` for a prismatic one),
``A_i = Rz(q_i) C_i`` (revolute: Rz(q + theta) = Rz(q) Rz(theta)) and
``A_i = Tz(q_i) C_i`` (prismatic: Rz(theta) and Tz commute). So joint i moves
about or along z of DH frame i-1, body i is frame i-1 moved by the joint, and
the constant part ``C_i`` is what follows it:
``P_1 = I``, ``P_i = C_{i-1}``, ``F_i = C_i``, ``tip = C_n``. The centre of
mass and inertia of link i, given in DH frame i, move to body i by ``C_i``:
``c_body = C_i c``, ``I_body = R(C_i) I R(C_i)^T``.

Modified DH (Craig, ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``,
link i holding ``a_{i-1}, alpha_{i-1}`` as the Robotics Toolbox's
``RevoluteMDH``): ``A_i = [Rx(alpha) Tx(a) Rz(theta) Tz(d)] Rz(q_i)`` (or
``Tz(q_i)``), so ``P_i = Rx(alpha) Tx(a) Rz(theta) Tz(d)``, the body frame is
frame i itself (``F_i = I``, ``tip = I``) and com and inertia are used as given.

URDF: ``P_i`` is the joint's ``origin``, ``u_i`` its ``axis``, ``F_i = I`` and
``tip`` the merged fixed joints after the last moving one.

``flip`` negates the axis (the joint coordinate enters as ``-q``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .description import RobotDescription, RobotDescriptionError, pose_matrix

__all__ = ["Chain", "build_chain", "dh_standard", "dh_modified", "joint_axes"]


def _rx(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])


def _rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1.0, 0], [0, 0, 0, 1]])


def _trans(x: float, y: float, z: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def dh_standard(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """(4, 4) ``Rz(theta) Tz(d) Tx(a) Rx(alpha)`` (m, rad)."""
    return _rz(theta) @ _trans(0, 0, d) @ _trans(a, 0, 0) @ _rx(alpha)


def dh_modified(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """(4, 4) ``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` (m, rad)."""
    return _rx(alpha) @ _trans(a, 0, 0) @ _rz(theta) @ _trans(0, 0, d)


@dataclass(frozen=True)
class Chain:
    """A serial chain of n joints and n bodies (constant numpy data).

    Attributes
    ----------
    placements
        n (4, 4) joint-frame poses in the previous body frame (``P_1`` in frame 0).
    axes
        (n, 3) unit joint axes in the joint frames (flip applied).
    revolute
        n flags, True for a revolute joint.
    mass
        (n,) body masses, kg.
    com
        (n, 3) centres of mass in the body frames, m.
    inertia
        (n, 3, 3) inertias about the centres of mass, body-frame axes, kg m^2.
    reported
        n (4, 4) poses of the reported link frame i in body frame i.
    base, tip, tool
        (4, 4) frame 0 in the world; the tip (flange) frame in body n; the tool frame in the tip frame.
    """

    placements: tuple[np.ndarray, ...]
    axes: np.ndarray
    revolute: tuple[bool, ...]
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    reported: tuple[np.ndarray, ...]
    base: np.ndarray
    tip: np.ndarray
    tool: np.ndarray

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.placements)


def _urdf_link(desc: RobotDescription, i: int) -> tuple[np.ndarray, np.ndarray]:
    link = desc.links[i]
    where = f"{desc.path or '<dict>'}, link {i + 1}"
    if link.origin is None or len(link.origin) != 16 or not np.all(np.isfinite(link.origin)):
        raise RobotDescriptionError(f"{where}: field 'origin' = {link.origin!r}: expected 16 finite floats (row-major 4x4)")
    axis = np.array(link.axis, dtype=float)
    norm = float(np.linalg.norm(axis))
    if axis.shape != (3,) or not np.isfinite(norm) or abs(norm - 1.0) > 1e-9:
        raise RobotDescriptionError(f"{where}: field 'axis' = {link.axis!r}: expected a unit vector of 3 floats")
    return pose_matrix(link.origin), axis / norm


def _clean(T: np.ndarray) -> np.ndarray:
    """Entries below 1e-15 (round-off of cos(pi/2) and the like) set to exactly 0: leaner symbolic expressions."""
    T = np.array(T, dtype=float)
    T[np.abs(T) < 1e-15] = 0.0
    return T


def build_chain(desc: RobotDescription) -> Chain:
    """The :class:`Chain` of a description, for any convention (see the module docstring).

    Raises
    ------
    RobotDescriptionError
        Unknown convention, or a URDF link without a valid origin or axis.
    """
    n = desc.n
    z = np.array([0.0, 0.0, 1.0])
    placements, axes, reported, coms, inertias = [], [], [], [], []
    if desc.convention == "standard":
        C = [dh_standard(lk.a, lk.alpha, lk.d, lk.theta) for lk in desc.links]
        placements = [np.eye(4)] + C[:-1]
        axes = [z] * n
        reported = C
        tip = C[-1]
        for lk, Ci in zip(desc.links, C):
            R = Ci[:3, :3]
            coms.append(R @ np.array(lk.com) + Ci[:3, 3])
            inertias.append(R @ lk.inertia_matrix @ R.T)
    elif desc.convention == "modified":
        placements = [dh_modified(lk.a, lk.alpha, lk.d, lk.theta) for lk in desc.links]
        axes = [z] * n
        reported = [np.eye(4)] * n
        tip = np.eye(4)
        coms = [np.array(lk.com, dtype=float) for lk in desc.links]
        inertias = [lk.inertia_matrix for lk in desc.links]
    elif desc.convention == "urdf":
        for i in range(n):
            P, u = _urdf_link(desc, i)
            placements.append(P)
            axes.append(u)
        reported = [np.eye(4)] * n
        tip = pose_matrix(desc.tip)
        coms = [np.array(lk.com, dtype=float) for lk in desc.links]
        inertias = [lk.inertia_matrix for lk in desc.links]
    else:
        raise RobotDescriptionError(
            f"{desc.path or '<dict>'}: field 'convention' = {desc.convention!r}: expected 'standard', 'modified' or 'urdf'"
        )
    signs = np.array([-1.0 if lk.flip else 1.0 for lk in desc.links])
    return Chain(
        placements=tuple(_clean(P) for P in placements),
        axes=np.array(axes, dtype=float) * signs[:, None],
        revolute=tuple(lk.is_revolute for lk in desc.links),
        mass=np.array([lk.mass for lk in desc.links], dtype=float),
        com=np.array(coms, dtype=float).reshape(n, 3),
        inertia=np.array(inertias, dtype=float).reshape(n, 3, 3),
        reported=tuple(_clean(F) for F in reported),
        base=desc.T_base,
        tip=_clean(tip),
        tool=desc.T_tool,
    )


def joint_axes(chain: Chain, T_links: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """World origin (m) and unit axis of every joint, from the reported link frames ``T_links`` (n+1, 4, 4).

    ``T_links`` is ``fkine_all(q)`` (frame 0, then the reported frame of each link). Joint i
    sits in body i-1 at ``P_i``: its frame is ``T_W,body(i-1) P_i`` with
    ``T_W,body(i-1) = T_links[i-1] F_(i-1)^-1`` (body 0 is frame 0).
    """
    out = []
    for i in range(chain.n):
        body = T_links[0] if i == 0 else T_links[i] @ np.linalg.inv(chain.reported[i - 1])
        J = body @ chain.placements[i]
        out.append((J[:3, 3].copy(), J[:3, :3] @ chain.axes[i]))
    return out
