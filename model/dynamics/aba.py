"""Forward dynamics by the articulated-body algorithm in frame 0, as straight-line SX.

Spatial quantities as in :mod:`model.dynamics.coriolis_recursive`, every one in frame 0 about its
origin (``S_i``, body inertias ``I_i`` from :func:`model.dynamics.crba.world_bodies`), so no
coordinate transforms appear (Featherstone's articulated-body algorithm in the frame-0 form):

* forward: ``v_i = v_{i-1} + S_i qd_i``, ``c_i = v_i x (S_i qd_i)``, ``IA_i = I_i``, ``pA_i = v_i x* (I_i v_i)``;
* backward: ``U_i = IA_i S_i``, ``D_i = S_i . U_i + G_i^2 Jm_i`` (the reflected rotor), ``u_i = tau_i - S_i . pA_i``,
  and for the parent ``IA_{i-1} += IA_i - U_i U_i^T / D_i``, ``pA_{i-1} += pA_i + (IA_i - U_i U_i^T / D_i) c_i + U_i u_i / D_i``;
* forward: ``a_0 = (0; -g_0)`` (gravity as a base acceleration), ``a'_i = a_{i-1} + c_i``,
  ``qdd_i = (u_i - U_i . a'_i) / D_i``, ``a_i = a'_i + S_i qdd_i``.

``tau`` is the joint torque less friction, so ``accel = B^-1 (tau - rne(q, qd, 0))`` as the LDL^T form
of :mod:`model.dynamics.symbolic`, in O(n) operations; which of the two a build compiles is chosen by
their operation counts.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from ..chain import build_chain
from ..description import RobotDescription
from .coriolis_recursive import _crf, _crm, _spatial
from .crba import world_bodies
from .lagrange import gravity_in_frame0
from .parameters import SymbolicParameters

__all__ = ["aba_world_sx"]


def aba_world_sx(desc: RobotDescription, q: ca.SX, qd: ca.SX, tau: Any, params: SymbolicParameters) -> ca.SX:
    """(n, 1) joint accelerations of the rigid bodies, payload and reflected rotors under joint torques ``tau``
    (friction already taken out), rad/s^2 or m/s^2."""
    n = desc.n
    chain = build_chain(desc)
    G = np.array([lk.gear_ratio for lk in desc.links])
    Jm = np.array([lk.motor_inertia for lk in desc.links])
    S, bodies, _ = world_bodies(desc, q, params)
    v = ca.SX.zeros(6, 1)
    c, IA, pA = [], [], []
    for i in range(n):
        Sqd = S[i] * qd[i]
        v = v + Sqd
        c.append(_crm(v) @ Sqd)
        I = _spatial(*bodies[i])
        IA.append(I)
        pA.append(_crf(v) @ (I @ v))
    U, D, u = [None] * n, [None] * n, [None] * n
    for i in reversed(range(n)):
        U[i] = IA[i] @ S[i]
        D[i] = S[i].T @ U[i] + G[i] * G[i] * Jm[i]
        u[i] = tau[i] - S[i].T @ pA[i]
        if i > 0:
            Ia = IA[i] - (U[i] @ U[i].T) / D[i]
            IA[i - 1] = IA[i - 1] + Ia
            pA[i - 1] = pA[i - 1] + pA[i] + Ia @ c[i] + U[i] * (u[i] / D[i])
    a = ca.vertcat(ca.SX.zeros(3, 1), -gravity_in_frame0(chain.base, params.gravity))
    qdd = []
    for i in range(n):
        a = a + c[i]
        qdd_i = (u[i] - U[i].T @ a) / D[i]
        a = a + S[i] * qdd_i
        qdd.append(qdd_i)
    return ca.vertcat(*qdd)
