"""The stick-slip friction law of the FMU as CasADi Functions (modes, event indicators, mode update).

Each joint has a friction mode ``m``: ``+1`` sliding forward (Coulomb torque
``Tc+ = |G| Tc+_m``), ``-1`` sliding backward (``Tc- = |G| Tc-_m``), ``0``
stuck (``qd = 0``, ``qdd = 0``, friction = the holding torque, from the
dynamics). With the stuck mask ``s``, one solve gives the accelerations of the
free joints and the holding torques of the stuck ones::

    (B diag(1 - s) + diag(s)) v = G u - h(q, qd) - f_c,   qdd = (1 - s) v,   f = s v

(``h``: Coriolis, gravity and viscous torques; ``f_c``: Coulomb torques of the
sliding joints). The signs are frozen between events, so Model Exchange
integrators see a smooth right-hand side. Event indicators (positive while
the mode holds):

* sliding: ``m qd + V_EPS`` (the velocity reaches zero, overshooting by at most ``V_EPS``);
* stuck: ``min(Tc+ - f, f - Tc-) + F_EPS (Tc+ - Tc-)`` (the holding torque reaches a limit);
* no Coulomb friction on the joint: ``1`` (it never sticks).

One pass of the mode update: every sliding joint with ``m qd <= V_EPS`` that
decelerates (``m qdd < -A_EPS (1 + max|qdd|)``) sticks, its velocity set to 0;
if none does, the stuck joint whose holding torque exceeds its limit the most
breaks loose towards that torque. The FMU repeats passes until nothing changes.
:mod:`fmu.reference` integrates the same law in Python.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

__all__ = ["V_EPS", "F_EPS", "A_EPS", "FrictionModes", "friction_modes", "no_modes"]

#: Velocity overshoot allowed before a sliding joint's event, rad/s or m/s.
V_EPS = 1e-6
#: Relative margin of the holding torque beyond a limit before a stuck joint's event.
F_EPS = 1e-9
#: Relative deceleration below which a sliding joint at rest counts as turning back (sticks).
A_EPS = 1e-9


@dataclass(frozen=True)
class FrictionModes:
    """``ode(x, u, p, m) -> xdot``, ``events(x, u, p, m) -> z``, ``update(x, u, p, m) -> (m, x)``,
    ``start(x, u, p) -> m`` and the number of modes ``nz``."""

    nz: int
    ode: ca.Function
    events: ca.Function
    update: ca.Function
    start: ca.Function


def no_modes(ode: ca.Function) -> FrictionModes:
    """The Functions of a model without modes: ``ode`` with an empty ``m`` input, no events."""
    nx, nu, np_ = (ode.numel_in(i) for i in range(3))
    x, u, p, m = ca.SX.sym("x", nx), ca.SX.sym("u", nu), ca.SX.sym("p", np_), ca.SX.sym("m", 0)
    empty = ca.SX(0, 1)
    return FrictionModes(
        0,
        ca.Function("ode", [x, u, p, m], [ode(x, u, p)], ["x", "u", "p", "m"], ["xdot"]),
        ca.Function("events", [x, u, p, m], [empty], ["x", "u", "p", "m"], ["z"]),
        ca.Function("update", [x, u, p, m], [empty, x], ["x", "u", "p", "m"], ["m_next", "x_next"]),
        ca.Function("start", [x, u, p], [empty], ["x", "u", "p"], ["m"]),
    )


def _solve(B: ca.SX, r: ca.SX, tc_pos: ca.SX, tc_neg: ca.SX, m: ca.SX) -> tuple[ca.SX, ca.SX]:
    n = m.numel()
    s = ca.vertcat(*[ca.if_else(m[i] == 0, 1, 0) for i in range(n)])
    f_c = ca.vertcat(*[ca.if_else(m[i] > 0, tc_pos[i], ca.if_else(m[i] < 0, tc_neg[i], 0)) for i in range(n)])
    A = B @ ca.diag(1 - s) + ca.diag(s)
    v = ca.solve(A, r - f_c)
    return (1 - s) * v, ca.vertcat(*[ca.if_else(s[i] > 0, v[i], f_c[i]) for i in range(n)])


def friction_modes(robot: Any, param_names: tuple[str, ...]) -> FrictionModes:
    """The stick-slip Functions of ``robot`` (see the module docstring); ``param_names`` is the plant's p layout."""
    n = robot.n
    G = np.asarray(robot.gear_ratio, dtype=float)
    names = list(param_names)
    pos = [names.index(f"coulomb_friction_pos[{i + 1}]") for i in range(n)]
    neg = [names.index(f"coulomb_friction_neg[{i + 1}]") for i in range(n)]
    x, u, p, m = ca.SX.sym("x", 2 * n), ca.SX.sym("u", n), ca.SX.sym("p", len(names)), ca.SX.sym("m", n)
    q, qd = x[:n], x[n:]
    p_smooth = ca.vertcat(*[0 if k in pos or k in neg else p[k] for k in range(len(names))])
    fns = robot.dynamics.functions
    B = fns.inertia(q, p)
    h = fns.rne(q, qd, ca.SX.zeros(n), p_smooth)
    r = ca.DM(G) * u - h
    tc_pos = ca.DM(np.abs(G)) * p[pos]
    tc_neg = ca.DM(np.abs(G)) * p[neg]
    has_c = [tc_pos[i] - tc_neg[i] > 0 for i in range(n)]

    qdd, f = _solve(B, r, tc_pos, tc_neg, m)
    qd_held = ca.vertcat(*[ca.if_else(m[i] == 0, 0, qd[i]) for i in range(n)])
    xdot = ca.vertcat(qd_held, qdd)

    z = []
    for i in range(n):
        sliding = m[i] * qd[i] + V_EPS
        stuck = ca.fmin(tc_pos[i] - f[i], f[i] - tc_neg[i]) + F_EPS * (tc_pos[i] - tc_neg[i])
        z.append(ca.if_else(has_c[i], ca.if_else(m[i] != 0, sliding, stuck), 1))
    z = ca.vertcat(*z)

    a_tol = A_EPS * (1 + ca.mmax(ca.fabs(qdd)))
    stick = [ca.logic_and(has_c[i], ca.logic_and(m[i] != 0, ca.logic_and(m[i] * qd[i] <= V_EPS,
                                                                          m[i] * qdd[i] < -a_tol)))
             for i in range(n)]
    any_stick = stick[0]
    for i in range(1, n):
        any_stick = ca.logic_or(any_stick, stick[i])
    excess = [ca.if_else(m[i] == 0, ca.fmax(f[i] - tc_pos[i], tc_neg[i] - f[i]), -1e300) for i in range(n)]
    m_next, qd_next = [], []
    for i in range(n):
        largest = excess[i] > 0
        for j in range(n):
            if j < i:
                largest = ca.logic_and(largest, excess[i] > excess[j])
            elif j > i:
                largest = ca.logic_and(largest, excess[i] >= excess[j])
        release = ca.if_else(f[i] > tc_pos[i], 1, -1)
        mi = ca.if_else(any_stick, ca.if_else(stick[i], 0, m[i]), ca.if_else(largest, release, m[i]))
        m_next.append(mi)
        qd_next.append(ca.if_else(mi == 0, 0, qd[i]))
    m_next = ca.vertcat(*m_next)
    x_next = ca.vertcat(q, *qd_next)

    m_start = ca.vertcat(*[ca.if_else(has_c[i], ca.sign(qd[i]), ca.if_else(qd[i] < 0, -1, 1)) for i in range(n)])
    args, names_in = [x, u, p, m], ["x", "u", "p", "m"]
    return FrictionModes(
        n,
        ca.Function("ode", args, [xdot], names_in, ["xdot"]),
        ca.Function("events", args, [z], names_in, ["z"]),
        ca.Function("update", args, [m_next, x_next], names_in, ["m_next", "x_next"]),
        ca.Function("start", [x, u, p], [m_start], ["x", "u", "p"], ["m"]),
    )
