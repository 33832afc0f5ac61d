"""Reference integrator of an arm with stick-slip Coulomb friction (Python, event-located).

The friction law is that of a bearing with Coulomb friction (Modelica's
``BearingFriction`` without a separate static level): each joint is in one of
three modes,

* sliding forward (``+1``): the joint-side Coulomb torque ``Tc+ = |G| Tc+_m`` acts;
* sliding backward (``-1``): ``Tc- = |G| Tc-_m`` (<= 0) acts;
* stuck (``0``): ``qd = 0`` and ``qdd = 0`` for that joint, and the friction torque
  is whatever holds it, computed from the dynamics; it holds while
  ``Tc- <= f <= Tc+``.

With ``s`` the stuck mask, the accelerations of the free joints and the
holding torques of the stuck ones come from one linear solve,
``(B diag(1 - s) + diag(s)) v = tau - h(q, qd) - f_c``, with ``h`` the
bias and viscous torques and ``f_c`` the Coulomb torques of the sliding
joints: ``qdd = (1 - s) v`` and ``f = s v``.

Mode switches are events, located by :func:`scipy.integrate.solve_ivp`: a
sliding joint whose velocity reaches zero while decelerating sticks (its
velocity is set to exactly 0); a stuck joint whose holding torque reaches a
limit breaks loose in the direction of that torque. Joints without Coulomb
friction never stick. Modes are made consistent at every event (a joint
stuck by an event may at once break loose again, one joint at a time, the
largest excess first).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["StickSlipResult", "coulomb_limits", "mode_dynamics", "consistent_modes", "simulate_stick_slip"]


@dataclass(frozen=True)
class StickSlipResult:
    """Samples of a stick-slip run: ``t`` (N,), states ``X`` (N, 2n), friction torques ``F`` (N, n, joint side,
    N m or N; Coulomb plus viscous, holding torque while stuck), modes (N, n) and the event times."""

    t: np.ndarray
    X: np.ndarray
    F: np.ndarray
    modes: np.ndarray
    events: tuple[float, ...]


def coulomb_limits(robot: Any) -> tuple[np.ndarray, np.ndarray]:
    """Joint-side Coulomb torques ``(Tc+, Tc-)`` (n,) each, N m or N: ``|G|`` times the motor-side values."""
    G = np.abs(np.asarray(robot.gear_ratio, dtype=float))
    pos = np.array([lk.coulomb_friction[0] for lk in robot.description.links], dtype=float)
    neg = np.array([lk.coulomb_friction[1] for lk in robot.description.links], dtype=float)
    return G * pos, G * neg


def mode_dynamics(B: np.ndarray, r: np.ndarray, tc_pos: np.ndarray, tc_neg: np.ndarray,
                  modes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations ``qdd`` (0 for stuck joints) and friction ``f`` (Coulomb of sliding joints, holding
    torque of stuck ones) under ``modes``; ``r = tau - h(q, qd)`` without Coulomb friction."""
    s = (modes == 0).astype(float)
    f_c = np.where(modes > 0, tc_pos, np.where(modes < 0, tc_neg, 0.0))
    A = B * (1.0 - s)[None, :] + np.diag(s)
    v = np.linalg.solve(A, r - f_c)
    return (1.0 - s) * v, np.where(s > 0, v, f_c)


def consistent_modes(B: np.ndarray, r: np.ndarray, tc_pos: np.ndarray, tc_neg: np.ndarray,
                     modes: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Modes after an event: stuck joints whose holding torque exceeds a limit break loose, one at a time.

    A joint at rest (``qd = 0``) set sliding whose acceleration points the other way is stuck
    instead; joints without Coulomb friction are never stuck.
    """
    modes = modes.copy()
    free_of_coulomb = (tc_pos == 0) & (tc_neg == 0)
    modes[free_of_coulomb & (modes == 0)] = 1
    for _ in range(2 * modes.size + 1):
        qdd, f = mode_dynamics(B, r, tc_pos, tc_neg, modes)
        excess = np.where(modes == 0, np.maximum(f - tc_pos, tc_neg - f), -np.inf)
        # decelerating from rest, beyond rounding: a joint just set sliding that would move the other way
        wrong_way = ((modes != 0) & (qd == 0) & (modes * qdd < -1e-9 * (1.0 + np.max(np.abs(qdd))))
                     & ~free_of_coulomb)
        if np.any(wrong_way):
            modes[np.flatnonzero(wrong_way)[0]] = 0
            continue
        if np.max(excess, initial=-np.inf) > 0:
            i = int(np.argmax(excess))
            modes[i] = 1 if f[i] > tc_pos[i] else -1
            continue
        return modes
    raise RuntimeError(f"consistent_modes: no consistent friction modes found (last {modes.tolist()})")


def simulate_stick_slip(robot: Any, profile: Any, x0: np.ndarray | None = None, *, rtol: float = 1e-10,
                        atol: float = 1e-12, samples_per_hold: int = 10) -> StickSlipResult:
    """Integrate the arm under the piecewise-constant motor torques of ``profile`` with stick-slip friction.

    Parameters
    ----------
    robot
        A :class:`model.Robot`; its Coulomb friction follows the law of this module, the rest of its
        dynamics (viscous friction included) is ``robot.dynamics``.
    profile
        A :class:`fmu.validate.TorqueProfile` (``t_switch``, ``tau_m`` motor side, ``t_end``).
    x0
        Initial state ``[q; qd]``; default rest, at rest.
    rtol, atol
        Tolerances of the DOP853 integration between events.
    samples_per_hold
        Output samples per hold interval of the profile (the switching times are always sampled).
    """
    from scipy.integrate import solve_ivp

    from model import Robot

    n = robot.n
    tc_pos, tc_neg = coulomb_limits(robot)
    smooth = Robot(robot.description, motor_model=robot.motor_model)
    smooth.dynamics.set_parameters(robot.dynamics.p)
    smooth.dynamics.set_friction(coulomb_pos=np.zeros(n), coulomb_neg=np.zeros(n))
    G = np.asarray(robot.gear_ratio, dtype=float)
    x = np.concatenate([robot.q_rest, np.zeros(n)]) if x0 is None else np.asarray(x0, dtype=float).copy()

    def parts(xv: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, qd = xv[:n], xv[n:]
        return smooth.inertia(q), tau - smooth.rne(q, qd, np.zeros(n))

    def viscous(qd: np.ndarray) -> np.ndarray:
        return smooth.friction(qd)

    modes = np.where(x[n:] > 0, 1, np.where(x[n:] < 0, -1, 0))
    B, r = parts(x, G * profile.tau_m[0])
    modes = consistent_modes(B, r, tc_pos, tc_neg, modes, x[n:])
    ts, Xs, Fs, Ms, events = [], [], [], [], []
    bounds = np.append(profile.t_switch, profile.t_end)

    def record(t: float, xv: np.ndarray, tau: np.ndarray, m: np.ndarray) -> None:
        B_, r_ = parts(xv, tau)
        _, f = mode_dynamics(B_, r_, tc_pos, tc_neg, m)
        ts.append(t)
        Xs.append(xv.copy())
        Fs.append(f + viscous(xv[n:]))
        Ms.append(m.copy())

    for k in range(profile.t_switch.size):
        tau = G * profile.tau_m[k]
        t0, t1 = float(bounds[k]), float(bounds[k + 1])
        B, r = parts(x, tau)
        modes = consistent_modes(B, r, tc_pos, tc_neg, modes, np.where(modes == 0, 0.0, x[n:]))
        t_eval = np.linspace(t0, t1, samples_per_hold + 1)
        while True:
            m = modes.copy()

            def rhs(_t: float, xv: np.ndarray, m: np.ndarray = m) -> np.ndarray:
                B_, r_ = parts(xv, tau)
                qdd, _ = mode_dynamics(B_, r_, tc_pos, tc_neg, m)
                qd = np.where(m == 0, 0.0, xv[n:])
                return np.concatenate([qd, qdd])

            def indicator(i: int):
                def z(_t: float, xv: np.ndarray, m: np.ndarray = m) -> float:
                    if tc_pos[i] == 0 and tc_neg[i] == 0:
                        return 1.0
                    if m[i] != 0:
                        return float(xv[n + i])
                    B_, r_ = parts(xv, tau)
                    _, f = mode_dynamics(B_, r_, tc_pos, tc_neg, m)
                    return float(min(tc_pos[i] - f[i], f[i] - tc_neg[i]))
                z.terminal = True
                z.direction = -1.0 if m[i] >= 0 else 1.0
                return z

            sol = solve_ivp(rhs, (t0, t1), x, method="DOP853", rtol=rtol, atol=atol,
                            t_eval=t_eval[(t_eval >= t0) & (t_eval <= t1)], events=[indicator(i) for i in range(n)])
            if sol.status < 0:
                raise RuntimeError(f"simulate_stick_slip: solve_ivp failed on [{t0}, {t1}]: {sol.message}")
            for tk, xk in zip(sol.t, sol.y.T):
                if not ts or tk > ts[-1]:
                    record(float(tk), xk, tau, m)
            if sol.status == 0:
                x = sol.y[:, -1]
                break
            te = float(sol.t_events[[len(e) > 0 for e in sol.t_events].index(True)][0])
            x = sol.y_events[[len(e) > 0 for e in sol.t_events].index(True)][0].copy()
            fired = [i for i, e in enumerate(sol.t_events) if len(e) > 0]
            for i in fired:
                if m[i] != 0:
                    modes[i] = 0                       # velocity reached zero: stick
                    x[n + i] = 0.0
                else:
                    B_, r_ = parts(x, tau)
                    _, f = mode_dynamics(B_, r_, tc_pos, tc_neg, m)
                    modes[i] = 1 if f[i] > 0.5 * (tc_pos[i] + tc_neg[i]) else -1   # break loose
            B, r = parts(x, tau)
            modes = consistent_modes(B, r, tc_pos, tc_neg, modes, np.where(modes == 0, 0.0, x[n:]))
            events.append(te)
            if len(events) > 4 * n and events[-4 * n] == te:
                raise RuntimeError(f"simulate_stick_slip: {4 * n} events at t = {te} without progress")
            t0 = te
            t_eval = t_eval[t_eval > te]
            if te >= t1:
                break
    return StickSlipResult(np.array(ts), np.array(Xs), np.array(Fs), np.array(Ms), tuple(events))
