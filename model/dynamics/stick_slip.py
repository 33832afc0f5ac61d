"""The stick-slip friction law as CasADi expressions: modes, accelerations, event indicators, mode update.

Each joint has a friction mode ``m``: ``+1`` sliding forward (Coulomb torque
``Tc+ = |G| Tc+_m``, joint side), ``-1`` sliding backward (``Tc- = |G| Tc-_m``),
``0`` stuck (``qd = 0``, ``qdd = 0``, friction = the holding torque, from the
dynamics). With ``r = G u - h(q, qd)`` (``h``: Coriolis, gravity and viscous
torques), the stuck mask ``s`` and the Coulomb torques ``f_c`` of the sliding
joints, the free joints' accelerations solve the masked system::

    M w = (1 - s) (r - f_c),   M = diag(1 - s) B diag(1 - s) + diag(s)

(``M`` is positive definite with ``B``: one unpivoted LDL^T, as ``accel``), and
``qdd = (1 - s) w``; a stuck joint's holding torque is ``f = r - B qdd`` in its
row. The modes are frozen between events, so a Model Exchange integrator sees a
smooth right-hand side. Event indicators, positive while the mode holds:

* sliding: ``m qd + V_EPS`` (the velocity reaches zero, overshooting by at most ``V_EPS``);
* stuck: ``min(Tc+ - f, f - Tc-) + F_EPS (Tc+ - Tc-)`` (the holding torque reaches a limit);
* no Coulomb friction on the joint (``Tc+ - Tc- = 0``): ``1`` (it never sticks).

One pass of the mode update: every sliding joint with ``m qd <= V_EPS`` that
decelerates (``m qdd < -A_EPS (1 + max|qdd|)``) sticks, its velocity set to 0;
if none does, the stuck joint whose holding torque exceeds its limit the most
breaks loose towards that torque (the first of equal largest). The passes are
repeated until nothing changes (``mw_plant_settle`` of ``plant_step.c``). The
start modes are the signs of the velocities (a joint at rest starts stuck, then
the update releases it if it cannot be held; a joint without Coulomb friction
never starts stuck).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca

from .linalg import ldl_pivots_sx, ldl_solve_sx

__all__ = ["V_EPS", "F_EPS", "A_EPS", "ModeLaw", "sliding_accel_sx", "sliding_indicators_sx", "stick_slip_sx"]

#: Velocity overshoot allowed before a sliding joint's event, rad/s or m/s.
V_EPS = 1e-6
#: Relative margin of the holding torque beyond a limit before a stuck joint's event.
F_EPS = 1e-9
#: Relative deceleration below which a sliding joint at rest counts as turning back (sticks).
A_EPS = 1e-9


@dataclass(frozen=True)
class ModeLaw:
    """The law at one symbolic point ``(q, qd, u, p, m)``: every field an SX column.

    Attributes
    ----------
    qd_held, qdd
        (n,) the position derivative (``qd``, 0 for a stuck joint) and the accelerations.
    friction
        (n,) joint-side Coulomb torque of a sliding joint, holding torque of a stuck one, N m or N.
    z
        (n,) event indicators.
    m_next, qd_next
        (n,) modes and velocities after one pass of the update.
    m_start
        (n,) the modes to begin from.
    active
        (2,) ``[active, quiet]``: active is 1 if a mode can change (a joint has Coulomb friction, or one is
        stuck), else 0; quiet is 1 if one pass of the update would change nothing now (nothing stuck, no
        sliding joint with Coulomb friction within ``V_EPS`` of rest), so the settle loop may skip it.
    pivots
        (n,) the LDL^T pivots of ``M`` (a pivot that is not positive: B singular at that joint).
    """

    qd_held: ca.SX
    qdd: ca.SX
    friction: ca.SX
    z: ca.SX
    m_next: ca.SX
    qd_next: ca.SX
    m_start: ca.SX
    active: ca.SX
    pivots: ca.SX


def _any(flags: list[Any]) -> Any:
    out = flags[0]
    for flag in flags[1:]:
        out = ca.logic_or(out, flag)
    return out


def sliding_accel_sx(B: ca.SX, r: ca.SX, tc_pos: ca.SX, tc_neg: ca.SX, m: ca.SX) -> ca.SX:
    """(n, 1) the accelerations of the law when no joint is stuck (every ``m_i`` is +-1): ``B^-1 (r - f_c)``.

    The same operations as :func:`stick_slip_sx`'s ``qdd`` with the stuck mask all zero (its selections
    then return their operands unchanged), so the two agree bit for bit wherever nothing is stuck; the
    fixed-step rule uses this one there, which saves the masking.
    """
    n = m.numel()
    f_c = _coulomb(tc_pos, tc_neg, m)
    return ldl_solve_sx(B, ca.vertcat(*[r[i] - f_c[i] for i in range(n)]))


def sliding_indicators_sx(tc_pos: ca.SX, tc_neg: ca.SX, qd: ca.SX, m: ca.SX) -> ca.SX:
    """(n, 1) the event indicators of the law when no joint is stuck: ``m qd + V_EPS``, 1 without Coulomb friction.

    :func:`stick_slip_sx`'s ``z`` with the stuck mask all zero, bit for bit (its selections return the
    sliding operand unchanged), without the holding torques a stuck joint's indicator needs.
    """
    return ca.vertcat(*[ca.if_else(tc_pos[i] - tc_neg[i] > 0, m[i] * qd[i] + V_EPS, 1) for i in range(m.numel())])


def _coulomb(tc_pos: ca.SX, tc_neg: ca.SX, m: ca.SX) -> list[ca.SX]:
    """The Coulomb torque of each joint's mode: ``Tc+`` sliding forward, ``Tc-`` backward, 0 stuck."""
    return [ca.if_else(m[i] > 0, tc_pos[i], ca.if_else(m[i] < 0, tc_neg[i], 0)) for i in range(m.numel())]


def stick_slip_sx(B: ca.SX, r: ca.SX, tc_pos: ca.SX, tc_neg: ca.SX, qd: ca.SX, m: ca.SX,
                  hold_pos: ca.SX | None = None, hold_neg: ca.SX | None = None) -> ModeLaw:
    """The stick-slip law (module docstring) from its symbolic pieces.

    Parameters
    ----------
    B
        (n, n) joint-space inertia; only its diagonal and lower triangle are read.
    r
        (n, 1) ``G u - h(q, qd)``: the joint torque left for acceleration and Coulomb friction, N m or N.
    tc_pos, tc_neg
        (n, 1) joint-side Coulomb torques ``Tc+ >= 0`` and ``Tc- <= 0``.
    qd, m
        (n, 1) joint velocities and friction modes.
    hold_pos, hold_neg
        (n, 1) the break-away limits of a stuck joint (``peak Tc+`` and ``peak Tc-``, peak >= 1); default
        ``tc_pos``, ``tc_neg`` (the same expressions: the law is then the one without a peak, bit for bit).
    """
    n = m.numel()
    hp = tc_pos if hold_pos is None else hold_pos
    hn = tc_neg if hold_neg is None else hold_neg
    stuck = [m[i] == 0 for i in range(n)]
    f_c = _coulomb(tc_pos, tc_neg, m)
    M = ca.SX(n, n)
    for i in range(n):
        for j in range(i + 1):
            M[i, j] = ca.if_else(stuck[i], 1, B[i, i]) if i == j else \
                ca.if_else(ca.logic_or(stuck[i], stuck[j]), 0, B[i, j])
    rhs = ca.vertcat(*[ca.if_else(stuck[i], 0, r[i] - f_c[i]) for i in range(n)])
    w = ldl_solve_sx(M, rhs)
    qdd = ca.vertcat(*[ca.if_else(stuck[i], 0, w[i]) for i in range(n)])
    B_full = ca.tril(B) + ca.tril(B, False).T
    held = r - B_full @ qdd
    f = ca.vertcat(*[ca.if_else(stuck[i], held[i], f_c[i]) for i in range(n)])
    qd_held = ca.vertcat(*[ca.if_else(stuck[i], 0, qd[i]) for i in range(n)])

    has_c = [tc_pos[i] - tc_neg[i] > 0 for i in range(n)]
    z = []
    for i in range(n):
        sliding = m[i] * qd[i] + V_EPS
        hold = ca.fmin(hp[i] - f[i], f[i] - hn[i]) + F_EPS * (hp[i] - hn[i])
        z.append(ca.if_else(has_c[i], ca.if_else(stuck[i], hold, sliding), 1))

    a_tol = A_EPS * (1 + ca.mmax(ca.fabs(qdd)))
    stick = [ca.logic_and(has_c[i], ca.logic_and(m[i] != 0, ca.logic_and(m[i] * qd[i] <= V_EPS,
                                                                          m[i] * qdd[i] < -a_tol)))
             for i in range(n)]
    any_stick = _any(stick)
    excess = [ca.if_else(stuck[i], ca.fmax(f[i] - hp[i], hn[i] - f[i]), -1e300) for i in range(n)]
    m_next, qd_next = [], []
    for i in range(n):
        largest = excess[i] > 0
        for j in range(n):
            if j < i:
                largest = ca.logic_and(largest, excess[i] > excess[j])
            elif j > i:
                largest = ca.logic_and(largest, excess[i] >= excess[j])
        release = ca.if_else(f[i] > hp[i], 1, -1)
        mi = ca.if_else(any_stick, ca.if_else(stick[i], 0, m[i]), ca.if_else(largest, release, m[i]))
        m_next.append(mi)
        qd_next.append(ca.if_else(mi == 0, 0, qd[i]))

    m_start = ca.vertcat(*[ca.if_else(has_c[i], ca.sign(qd[i]), ca.if_else(qd[i] < 0, -1, 1)) for i in range(n)])
    # quiet: nothing stuck, and no sliding joint with Coulomb friction within V_EPS of rest, so that one pass of the
    # update (sticking needs m qd <= V_EPS, breaking loose a stuck joint) changes nothing
    near_rest = [ca.logic_and(has_c[i], m[i] * qd[i] <= V_EPS) for i in range(n)]
    quiet = ca.logic_not(_any([*stuck, *near_rest]))
    active = ca.vertcat(ca.if_else(_any([*has_c, *stuck]), 1, 0), ca.if_else(quiet, 1, 0))
    return ModeLaw(qd_held=qd_held, qdd=qdd, friction=f, z=ca.vertcat(*z), m_next=ca.vertcat(*m_next),
                   qd_next=ca.vertcat(*qd_next), m_start=m_start, active=active, pivots=ldl_pivots_sx(M))
