"""The P-PI cascade on the elastic joint model: transfer functions, margins, the resonance (python-control).

One joint, the rest of the arm frozen at ``q`` (the link inertia ``Jl = B_ii(q)`` of the arm without this
joint's rotor). Motor side, link inertia reflected ``Jl' = Jl / G^2``, gear spring ``c`` and damper ``d``::

    qd_m / tau_m = (Jl' s^2 + d s + c) / (s (Jm Jl' s^2 + (Jm + Jl') (d s + c)))

(the two-mass system: anti-resonance ``w_a = sqrt(c / Jl')``, resonance ``w_r = sqrt(c (1/Jm + 1/Jl'))``); a
rigid gear is ``1 / ((Jm + Jl') s)``. The current loop ``w^2 / (s^2 + 2 D w s + w^2)`` (back-EMF left out: a
small extra damping), the speed PI ``ks (1 + 1 / (ti s))`` on ``qd_m`` times the torque constant ``k``, and the
position P ``kp`` around the closed speed loop. :func:`cascade_loops` gives every joint's loops on the elastic
model and, for comparison, on the rigid one (the loops a rigid-model design would have assumed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control
import numpy as np

from model.drive_train import rigid_arm_description
from model.robot import Robot

__all__ = ["ElasticCheck", "JointCascade", "bode_figure", "cascade_loops", "check_on_elastic", "link_angle_tf",
           "motor_speed_tf"]


def motor_speed_tf(Jm: float, Jl: float, G: float, c: float | None, d: float = 0.0) -> control.TransferFunction:
    """``qd_m / tau_m`` of one joint, rad/(N m s): the elastic two-mass system, or rigid with ``c`` None."""
    Jl_m = Jl / (G * G)
    if c is None:
        return control.tf([1.0], [Jm + Jl_m, 0.0])
    return control.tf([Jl_m, d, c], [Jm * Jl_m, (Jm + Jl_m) * d, (Jm + Jl_m) * c, 0.0])


@dataclass(frozen=True)
class JointCascade:
    """One joint's cascade: open loops and margins on the elastic and the rigid joint model.

    Attributes
    ----------
    name
        Joint name.
    speed_loop, position_loop
        Open loops on the elastic model: ``ks k (1 + 1/(ti s)) I(s) P(s)`` and ``kp T_v(s) / s``.
    speed_loop_rigid, position_loop_rigid
        The same on the rigid model (gear stiffness infinite).
    resonance, antiresonance
        ``w_r`` and ``w_a`` of the elastic gear, rad/s (nan for a rigid gear).
    margins, margins_rigid
        ``{"speed": (gm, pm_deg, wcg, wcp), "position": (...)}``: python-control's ``margin`` (gain margin as a
        factor, inf when the phase never crosses -180 deg; crossover frequencies rad/s).
    """

    name: str
    speed_loop: control.TransferFunction
    position_loop: control.TransferFunction
    speed_loop_rigid: control.TransferFunction
    position_loop_rigid: control.TransferFunction
    resonance: float
    antiresonance: float
    margins: dict[str, tuple[float, float, float, float]]
    margins_rigid: dict[str, tuple[float, float, float, float]]


def _loops(P: control.TransferFunction, k: float, ks: float, ti: float, kp: float,
           current: control.TransferFunction) -> tuple[control.TransferFunction, control.TransferFunction]:
    pi = control.tf([ks * ti, ks], [ti, 0.0])
    Lv = control.minreal(k * pi * current * P, verbose=False)
    Tv = control.feedback(Lv, 1)
    Lp = control.minreal(kp * Tv * control.tf([1.0], [1.0, 0.0]), verbose=False)
    return Lv, Lp


def _margins(L: control.TransferFunction) -> tuple[float, float, float, float]:
    gm, pm, wcg, wcp = control.margin(L)
    return float(gm), float(pm), float(wcg), float(wcp)


def cascade_loops(robot: Robot, q: Any = None, gains: dict[str, Any] | None = None) -> list[JointCascade]:
    """Every joint's :class:`JointCascade` at configuration ``q`` (default the rest), gains of the ``[cascade]``
    table (or ``gains`` with ``kp``, ``ks``, ``ti``: n values each)."""
    desc = robot.description
    n = desc.n
    q = desc.q_rest if q is None else np.asarray(q, dtype=float)
    table = dict(gains if gains is not None else desc.extra["cascade"])
    arm = Robot(rigid_arm_description(desc))
    B = arm.inertia(q)
    out = []
    for i, lk in enumerate(desc.links):
        G = lk.gear_ratio
        Jl = float(B[i, i]) - (0.0 if lk.is_elastic else G * G * lk.motor_inertia)  # the link alone
        k = 1.0 if lk.torque_constant is None else lk.torque_constant
        if lk.has_current_loop:
            w, D = lk.current_bandwidth, lk.current_damping
            current = control.tf([w * w], [1.0, 2 * D * w, w * w])
        else:
            current = control.tf([1.0], [1.0])
        kp, ks, ti = (float(np.broadcast_to(table[key], (n,))[i]) for key in ("kp", "ks", "ti"))
        P = motor_speed_tf(lk.motor_inertia, Jl, G, lk.gear_stiffness, lk.gear_damping)
        P_rigid = motor_speed_tf(lk.motor_inertia, Jl, G, None)
        Lv, Lp = _loops(P, k, ks, ti, kp, current)
        Lv_r, Lp_r = _loops(P_rigid, k, ks, ti, kp, current)
        if lk.is_elastic:
            Jl_m = Jl / (G * G)
            wr = math.sqrt(lk.gear_stiffness * (1 / lk.motor_inertia + 1 / Jl_m))
            wa = math.sqrt(lk.gear_stiffness / Jl_m)
        else:
            wr = wa = math.nan
        out.append(JointCascade(
            name=lk.name or f"joint{i + 1}", speed_loop=Lv, position_loop=Lp, speed_loop_rigid=Lv_r,
            position_loop_rigid=Lp_r, resonance=wr, antiresonance=wa,
            margins={"speed": _margins(Lv), "position": _margins(Lp)},
            margins_rigid={"speed": _margins(Lv_r), "position": _margins(Lp_r)}))
    return out


def bode_figure(loops: list[JointCascade]) -> Any:
    """A matplotlib Figure: |L_v| and phase of each elastic joint's speed loop, elastic and rigid, the resonance marked."""
    from matplotlib.figure import Figure

    chosen = [c for c in loops if not math.isnan(c.resonance)] or loops
    fig = Figure(figsize=(8.0, 6.0))
    ax_mag, ax_ph = fig.add_subplot(2, 1, 1), fig.add_subplot(2, 1, 2, sharex=None)
    w = np.logspace(0, 4.5, 2000)
    for k, c in enumerate(chosen):
        color = f"C{k}"
        for L, style, label in ((c.speed_loop, "-", "elastic"), (c.speed_loop_rigid, ":", "rigid model")):
            resp = L(1j * w)
            ax_mag.loglog(w, np.abs(resp), style, color=color, label=f"{c.name} {label}")
            ax_ph.semilogx(w, np.degrees(np.unwrap(np.angle(resp))), style, color=color)
        if not math.isnan(c.resonance):
            ax_mag.axvline(c.resonance, color=color, lw=0.6, ls="--")
            ax_ph.axvline(c.resonance, color=color, lw=0.6, ls="--")
    ax_mag.axhline(1.0, color="k", lw=0.5)
    ax_ph.axhline(-180.0, color="k", lw=0.5)
    ax_mag.set_ylabel("|L_v| (speed loop)")
    ax_ph.set_ylabel("phase, deg")
    ax_ph.set_xlabel("frequency, rad/s (dashed: gear resonance w_r)")
    ax_mag.legend(fontsize=7, ncol=2)
    ax_mag.set_title("P-PI cascade: speed loop on the elastic joint model vs the rigid one")
    fig.tight_layout()
    return fig


@dataclass(frozen=True)
class ElasticCheck:
    """A joint loop designed on the rigid model, checked on the elastic joint model.

    Attributes
    ----------
    name
        Joint name.
    stable_rigid, stable_elastic
        Whether the closed loop's poles are all in the left half plane on each model (continuous loop, the
        sampling's half-period delay as a first-order Pade term).
    margins_rigid, margins_elastic
        python-control's ``margin`` of the open loop on each model: (gain margin, phase margin deg, wcg, wcp).
    """

    name: str
    stable_rigid: bool
    stable_elastic: bool
    margins_rigid: tuple[float, float, float, float]
    margins_elastic: tuple[float, float, float, float]


def link_angle_tf(Jm: float, Jl: float, G: float, c: float | None, d: float = 0.0) -> control.TransferFunction:
    """``G q / tau_m`` of one joint (the motor-side image of the link angle), rad/(N m): elastic or rigid."""
    Jl_m = Jl / (G * G)
    if c is None:
        return control.tf([1.0], [Jm + Jl_m, 0.0, 0.0])
    return control.tf([d, c], [Jm * Jl_m, (Jm + Jl_m) * d, (Jm + Jl_m) * c, 0.0, 0.0])


def check_on_elastic(robot: Robot, design: Any, q: Any = None) -> list[ElasticCheck]:
    """Each decentralised loop of ``design`` (gains on ``G q``, :class:`control_design.loops.JointLoop`) closed
    around the elastic joint model of ``robot`` and around the rigid one (current loop included, arm frozen at
    ``q``): a rigid-model design verified on the elastic plant. Joints with a rigid gear give equal answers."""
    desc = robot.description
    q = desc.q_rest if q is None else np.asarray(q, dtype=float)
    B = Robot(rigid_arm_description(desc)).inertia(q)
    out = []
    for i, (lk, loop) in enumerate(zip(desc.links, design.loops)):
        g = loop.gains
        dt = loop.dt or 0.0
        C = control.tf([g.Kd, g.Kp, g.Ki], [1.0, 0.0]) if g.Ki else control.tf([g.Kd, g.Kp], [1.0])
        if dt > 0:  # zero-order hold: half a period of delay
            num, den = control.pade(dt / 2, 1)
            C = C * control.tf(num, den)
        if lk.has_current_loop:
            w, D = lk.current_bandwidth, lk.current_damping
            C = C * control.tf([w * w], [1.0, 2 * D * w, w * w])
        Jl = float(B[i, i]) - (0.0 if lk.is_elastic else lk.gear_ratio ** 2 * lk.motor_inertia)
        res = []
        for c in (None, lk.gear_stiffness):
            L = C * link_angle_tf(lk.motor_inertia, Jl, lk.gear_ratio, c, lk.gear_damping)
            poles = control.poles(control.feedback(L, 1))
            res.append((bool(np.all(np.real(poles) < 0)), _margins(L)))
        out.append(ElasticCheck(lk.name or f"joint{i + 1}", res[0][0], res[1][0], res[0][1], res[1][1]))
    return out
