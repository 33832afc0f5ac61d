"""The test oracle of the stick-slip plant: an arm with stick-slip Coulomb friction in NumPy, event-located.

No product code uses it. The law is the plant's, stated in :mod:`model.dynamics.stick_slip`: per joint a mode
(sliding forward, sliding backward, stuck), the accelerations of the free
joints and the holding torques of the stuck ones from one masked solve, event
indicators positive while the modes hold, and the same mode update, repeated
until nothing changes. Here it is written again with NumPy, and the events are
located by :func:`scipy.integrate.solve_ivp` (DOP853), one hold interval of the
piecewise-constant torque at a time: an independent integration of the same
law (written again here, from the docstring, with NumPy and a general
solve instead of the plant's masked LDL^T), against which the plant's
fixed-step rule (RK4 with bisection on the indicators, in every engine) and the
importers' integrators (CVode with root finding) are compared.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from model.dynamics.stick_slip import A_EPS, F_EPS, V_EPS
from model.errors import NumericalError

__all__ = ["StickSlipResult", "coulomb_limits", "mode_dynamics", "indicators", "update_modes", "settle_modes",
           "start_modes", "simulate_stick_slip"]


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
    """Joint-side Coulomb torques ``(Tc+, Tc-)`` (n,) each, N m or N: ``|G|`` times the motor-side values
    of the robot's parameters (:attr:`model.Robot.parameters`)."""
    G = np.abs(np.asarray(robot.gear_ratio, dtype=float))
    p = robot.parameters
    return G * p.field("coulomb_friction_pos"), G * p.field("coulomb_friction_neg")


def mode_dynamics(B: np.ndarray, r: np.ndarray, tc_pos: np.ndarray, tc_neg: np.ndarray,
                  modes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Accelerations ``qdd`` (0 for stuck joints) and friction ``f`` (Coulomb of sliding joints, holding
    torque of stuck ones) under ``modes``; ``r = G u - h(q, qd)`` without Coulomb friction."""
    s = (modes == 0).astype(float)
    f_c = np.where(modes > 0, tc_pos, np.where(modes < 0, tc_neg, 0.0))
    A = B * (1.0 - s)[None, :] + np.diag(s)
    v = np.linalg.solve(A, r - f_c)
    return (1.0 - s) * v, np.where(s > 0, v, f_c)


def indicators(qd: np.ndarray, f: np.ndarray, tc_pos: np.ndarray, tc_neg: np.ndarray,
               modes: np.ndarray) -> np.ndarray:
    """Event indicators, positive while the modes hold (see :mod:`model.dynamics.stick_slip`)."""
    sliding = modes * qd + V_EPS
    stuck = np.minimum(tc_pos - f, f - tc_neg) + F_EPS * (tc_pos - tc_neg)
    return np.where(tc_pos - tc_neg > 0, np.where(modes != 0, sliding, stuck), 1.0)


def update_modes(B: np.ndarray, r: np.ndarray, tc_pos: np.ndarray, tc_neg: np.ndarray, modes: np.ndarray,
                 qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One pass of the mode update: ``(modes, qd)`` next (see :mod:`model.dynamics.stick_slip`)."""
    qdd, f = mode_dynamics(B, r, tc_pos, tc_neg, modes)
    has_c = tc_pos - tc_neg > 0
    a_tol = A_EPS * (1.0 + np.max(np.abs(qdd)))
    stick = has_c & (modes != 0) & (modes * qd <= V_EPS) & (modes * qdd < -a_tol)
    nxt = modes.copy()
    if np.any(stick):
        nxt[stick] = 0
    else:
        excess = np.where(modes == 0, np.maximum(f - tc_pos, tc_neg - f), -1e300)
        i = int(np.argmax(excess))            # the first of equal largest excesses, as the FMU
        if excess[i] > 0:
            nxt[i] = 1 if f[i] > tc_pos[i] else -1
    return nxt, np.where(nxt == 0, 0.0, qd)


def settle_modes(B_r: Any, tc_pos: np.ndarray, tc_neg: np.ndarray, modes: np.ndarray,
                 x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Repeat :func:`update_modes` until nothing changes (at most ``2 n + 2`` passes, as the FMU).

    ``B_r(x)`` returns ``(B, r)`` at state ``x``.
    """
    n = modes.size
    for _ in range(2 * n + 2):
        B, r = B_r(x)
        nxt, qd = update_modes(B, r, tc_pos, tc_neg, modes, x[n:])
        if np.array_equal(nxt, modes) and np.array_equal(qd, x[n:]):
            return modes, x
        modes, x = nxt, np.concatenate([x[:n], qd])
    raise NumericalError(f"settle_modes: the friction modes did not settle (last {modes.tolist()})")


def start_modes(qd: np.ndarray, tc_pos: np.ndarray, tc_neg: np.ndarray) -> np.ndarray:
    """The modes to begin from: the sign of the velocity (joints without Coulomb friction: never 0)."""
    return np.where(tc_pos - tc_neg > 0, np.sign(qd), np.where(qd < 0, -1.0, 1.0))


def simulate_stick_slip(robot: Any, profile: Any, x0: np.ndarray | None = None, *, rtol: float = 1e-10,
                        atol: float = 1e-12, samples_per_hold: int = 10) -> StickSlipResult:
    """Integrate the arm under the piecewise-constant motor torques of ``profile`` with stick-slip friction.

    Parameters
    ----------
    robot
        A :class:`model.Robot`; its Coulomb friction follows the law of this module, the rest of its
        dynamics (viscous friction included) is ``robot.dynamics``.
    profile
        Piecewise-constant motor torques: ``t_switch`` (K,), ``tau_m`` (K, n) motor side, ``t_end``
        (e.g. a :class:`fmu.validate.TorqueProfile`).
    x0
        Initial state ``[q; qd]``; default rest, at rest.
    rtol, atol
        Tolerances of the DOP853 integration between events.
    samples_per_hold
        Output samples per hold interval of the profile (the switching times are always sampled).
    """
    from scipy.integrate import solve_ivp

    n = robot.n
    tc_pos, tc_neg = coulomb_limits(robot)
    smooth = robot.with_parameters(robot.parameters.with_friction(coulomb_pos=np.zeros(n), coulomb_neg=np.zeros(n)))
    G = np.asarray(robot.gear_ratio, dtype=float)
    x = np.concatenate([robot.q_rest, np.zeros(n)]) if x0 is None else np.asarray(x0, dtype=float).copy()

    def parts(xv: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, qd = xv[:n], xv[n:]
        return smooth.inertia(q), tau - smooth.rne(q, qd, np.zeros(n))

    def viscous(qd: np.ndarray) -> np.ndarray:
        return smooth.friction(qd)

    def B_r(xv: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return parts(xv, tau)

    modes = start_modes(x[n:], tc_pos, tc_neg)
    ts: list[float] = []
    Xs, Fs, Ms, events = [], [], [], []
    bounds = np.append(profile.t_switch, profile.t_end)

    def record(t: float, xv: np.ndarray, tau: np.ndarray, m: np.ndarray) -> None:
        B_, r_ = parts(xv, tau)
        _, f = mode_dynamics(B_, r_, tc_pos, tc_neg, m)
        ts.append(t)
        Xs.append(xv.copy())
        Fs.append(np.where(m == 0, f, f + viscous(xv[n:])))
        Ms.append(m.copy())

    for k in range(profile.t_switch.size):
        tau = G * profile.tau_m[k]
        t0, t1 = float(bounds[k]), float(bounds[k + 1])
        modes, x = settle_modes(lambda xv, tau=tau: B_r(xv, tau), tc_pos, tc_neg, modes, x)
        t_eval = np.linspace(t0, t1, samples_per_hold + 1)
        while True:
            m = modes.copy()

            def rhs(_t: float, xv: np.ndarray, m: np.ndarray = m) -> np.ndarray:
                B_, r_ = parts(xv, tau)
                qdd, _ = mode_dynamics(B_, r_, tc_pos, tc_neg, m)
                return np.concatenate([np.where(m == 0, 0.0, xv[n:]), qdd])

            def indicator(i: int):
                def z(_t: float, xv: np.ndarray, m: np.ndarray = m) -> float:
                    B_, r_ = parts(xv, tau)
                    _, f = mode_dynamics(B_, r_, tc_pos, tc_neg, m)
                    return float(indicators(xv[n:], f, tc_pos, tc_neg, m)[i])
                z.terminal = True
                z.direction = -1.0
                return z

            sol = solve_ivp(rhs, (t0, t1), x, method="DOP853", rtol=rtol, atol=atol,
                            t_eval=t_eval[(t_eval >= t0) & (t_eval <= t1)], events=[indicator(i) for i in range(n)])
            if sol.status < 0:
                raise NumericalError(f"simulate_stick_slip: solve_ivp failed on [{t0}, {t1}]: {sol.message}")
            # a terminal event before the first t_eval point leaves sol.y an empty list: no samples
            for tk, xk in zip(sol.t, np.reshape(sol.y, (2 * n, -1)).T):
                if not ts or tk > ts[-1]:
                    record(float(tk), xk, tau, m)
            if sol.status == 0:
                x = sol.y[:, -1]
                break
            first = [len(e) > 0 for e in sol.t_events].index(True)
            te = float(sol.t_events[first][0])
            x = sol.y_events[first][0].copy()
            modes, x = settle_modes(lambda xv, tau=tau: B_r(xv, tau), tc_pos, tc_neg, modes, x)
            events.append(te)
            if len(events) > 4 * n and events[-4 * n] == te:
                raise NumericalError(f"simulate_stick_slip: {4 * n} events at t = {te} without progress")
            t0 = te
            t_eval = t_eval[t_eval > te]
            if te >= t1:
                break
    return StickSlipResult(np.array(ts), np.array(Xs), np.array(Fs), np.array(Ms), tuple(events))
