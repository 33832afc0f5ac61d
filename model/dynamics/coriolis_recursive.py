"""The Coriolis matrix C(q, qd) (Christoffel) by a recursive O(n^2) algorithm, as straight-line SX.

Spatial vectors in body frame i (frames and ``A_i = (R_i, p_i)`` as in :mod:`model.dynamics.crba`):
a motion ``(w; v)`` (``v`` the velocity of the frame's origin), a force ``(n; f)`` (``n`` about the
origin); a body's spatial inertia about the origin ``I = [[I_o, [h]x], [[h]x^T, m 1]]``. Motions move
from body i-1 to body i by ``X_i = [[R^T, 0], [-R^T [p]x, R^T]]``, forces back by ``X_i^T``.

The algorithm is the Coriolis-matrix recursion of Echeandia and Wensing (2021, "Numerical methods to
compute the Coriolis matrix and Christoffel symbols for rigid-body systems", algorithm 2), written here
from its equations: forward ``v_i = X_i v_{i-1} + S_i qd_i``, ``Sd_i = v_i x S_i``, body terms
``B_i = 1/2 (v_i x* I_i + (I_i v_i) xbar* - I_i (v_i x))``; backward, with the composites ``K_i``, ``BK_i``
(moved inward by ``X^T . X``): ``f1 = K_i Sd_i + BK_i S_i``, ``f2 = K_i S_i``, ``f3 = BK_i^T S_i``,
``C_ii = S_i^T f1`` and, moving the three forces inward to each ancestor j, ``C_ji = S_j^T f1`` and
``C_ij = Sd_j^T f2 + S_j^T f3``. Rotors of the reflected model (``G^2 Jm``, constant) add nothing to C.
:func:`coriolis_world_sx` runs the same recursion with every quantity in frame 0 about its origin
(all ``X`` the identity: composites are sums and the O(n^2) part is dot products), which has fewer
operations on long chains; :mod:`model.dynamics.symbolic` compiles whichever form is smallest.
"""

from __future__ import annotations

from typing import Any

import casadi as ca

from ..chain import build_chain
from ..description import RobotDescription
from ..kinematics import joint_motion
from .crba import _about_origin, _skew, world_bodies
from .parameters import SymbolicParameters, inertia_matrix_sx

__all__ = ["coriolis_recursive_sx", "coriolis_world_sx"]


def _crm(v: Any) -> ca.SX:
    """6x6 motion cross product ``v x``."""
    W, V = _skew(v[0:3]), _skew(v[3:6])
    Z = ca.SX.zeros(3, 3)
    return ca.vertcat(ca.horzcat(W, Z), ca.horzcat(V, W))


def _crf(v: Any) -> ca.SX:
    """6x6 force cross product ``v x* = -(v x)^T``."""
    return -_crm(v).T


def _icrf(f: Any) -> ca.SX:
    """6x6 matrix of ``v -> v x* f``."""
    N, F = _skew(f[0:3]), _skew(f[3:6])
    Z = ca.SX.zeros(3, 3)
    return -ca.vertcat(ca.horzcat(N, F), ca.horzcat(F, Z))


def _spatial(m: Any, h: Any, I_o: Any) -> ca.SX:
    H = _skew(h)
    return ca.vertcat(ca.horzcat(I_o, H), ca.horzcat(H.T, m * ca.SX.eye(3)))


def _X(A: Any) -> ca.SX:
    R, p = A[0:3, 0:3], A[0:3, 3]
    Rt = R.T
    Z = ca.SX.zeros(3, 3)
    return ca.vertcat(ca.horzcat(Rt, Z), ca.horzcat(-Rt @ _skew(p), Rt))


def coriolis_recursive_sx(desc: RobotDescription, q: ca.SX, qd: ca.SX, params: SymbolicParameters) -> ca.SX:
    """(n, n) Christoffel Coriolis matrix of the rigid bodies (and payload), reflected rotors, N m s / rad."""
    n = desc.n
    chain = build_chain(desc)
    X = [_X(ca.DM(chain.placements[i]) @ joint_motion(chain.axes[i], q[i], chain.revolute[i])) for i in range(n)]
    S = [ca.vertcat(ca.DM(a), ca.DM.zeros(3)) if rev else ca.vertcat(ca.DM.zeros(3), ca.DM(a))
         for a, rev in zip(chain.axes, chain.revolute)]
    inertias = [_spatial(*_about_origin(chain.mass[i], ca.DM(chain.com[i]), ca.DM(chain.inertia[i]))) for i in range(n)]
    R_tip, t_tip = ca.DM(chain.tip[:3, :3]), ca.DM(chain.tip[:3, 3])
    c_p = R_tip @ params.payload_com + t_tip
    I_p = R_tip @ inertia_matrix_sx(params.payload_inertia) @ R_tip.T
    inertias[n - 1] = inertias[n - 1] + _spatial(*_about_origin(params.payload_mass, c_p, I_p))

    v = ca.SX.zeros(6, 1)
    Sd, K, BK = [], [], []
    for i in range(n):
        v = X[i] @ v + S[i] * qd[i]
        Sd.append(_crm(v) @ S[i])
        Ii = inertias[i]
        K.append(Ii)
        BK.append(0.5 * (_crf(v) @ Ii + _icrf(Ii @ v) - Ii @ _crm(v)))
    C = [[None] * n for _ in range(n)]
    for i in reversed(range(n)):
        f1 = K[i] @ Sd[i] + BK[i] @ S[i]
        f2 = K[i] @ S[i]
        f3 = BK[i].T @ S[i]
        C[i][i] = S[i].T @ f1
        for j in range(i - 1, -1, -1):
            Xt = X[j + 1].T
            f1, f2, f3 = Xt @ f1, Xt @ f2, Xt @ f3
            C[j][i] = S[j].T @ f1
            C[i][j] = Sd[j].T @ f2 + S[j].T @ f3
        if i > 0:
            K[i - 1] = K[i - 1] + X[i].T @ K[i] @ X[i]
            BK[i - 1] = BK[i - 1] + X[i].T @ BK[i] @ X[i]
    return ca.vertcat(*[ca.horzcat(*row) for row in C])


def coriolis_world_sx(desc: RobotDescription, q: ca.SX, qd: ca.SX, params: SymbolicParameters) -> ca.SX:
    """(n, n) Christoffel C(q, qd) by the same recursion in frame-0 coordinates (every ``X`` the identity:
    composites are sums, forces need no moving inward)."""
    n = desc.n
    S, bodies, _ = world_bodies(desc, q, params)
    v = ca.SX.zeros(6, 1)
    Sd, Ib, Bb = [], [], []
    for i in range(n):
        v = v + S[i] * qd[i]
        Sd.append(_crm(v) @ S[i])
        I = _spatial(*bodies[i])
        Ib.append(I)
        Bb.append(0.5 * (_crf(v) @ I + _icrf(I @ v) - I @ _crm(v)))
    C = [[None] * n for _ in range(n)]
    K, BK = ca.SX.zeros(6, 6), ca.SX.zeros(6, 6)
    for i in reversed(range(n)):
        K, BK = K + Ib[i], BK + Bb[i]
        f1 = K @ Sd[i] + BK @ S[i]
        f2 = K @ S[i]
        f3 = BK.T @ S[i]
        C[i][i] = S[i].T @ f1
        for j in range(i):
            C[j][i] = S[j].T @ f1
            C[i][j] = Sd[j].T @ f2 + S[j].T @ f3
    return ca.vertcat(*[ca.horzcat(*row) for row in C])
