"""Closed-loop tracking on the full nonlinear model: sampled controller, ZOH torque, RK4 plant.

At ``t_k = t0 + k dt`` (integer k, never a running sum) the controller reads
the plant state and the reference and returns motor torques; they are held
(zero-order hold) while the plant ``qdd = accel(q, qd, G tau_m)`` (compiled
dynamics) is integrated over ``[t_k, t_k+1]`` by classic fixed-step RK4 in
``substeps`` equal steps. With the torque held the plant alone has no stiff
mode (its fastest eigenvalue is the viscous friction rate
``G^2 B_m / B_ii``); the sub-step is chosen so that ``h <= 1 ms`` and ``h`` times
that rate is <= 0.5, well inside RK4's stability region (|h lambda| < 2.78).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from typing import Any, Callable, TextIO

import numpy as np

from model.robot import Robot, as_joint_vector
from model.trajectory import Trajectory

from .controllers import Controller
from .errors import DesignSpecError, SimulationDivergedError
from .reference import Reference

__all__ = [
    "MAX_SUBSTEP",
    "TrackingResult",
    "TrackingMetrics",
    "ProgressLine",
    "default_substeps",
    "simulate_tracking",
]

#: Longest RK4 sub-step, s.
MAX_SUBSTEP = 1e-3
_STIFF_MARGIN = 0.5  # |h lambda| bound for the plant's fastest (friction) eigenvalue


@dataclass(frozen=True)
class TrackingMetrics:
    """Per-joint tracking numbers of one run (joint side unless ``_m``).

    Attributes
    ----------
    controller, robot
        Controller kind and robot name.
    joints, units
        Joint names and units of q.
    rms_error, max_error
        (n,) RMS and max |q_d - q| over the control samples, rad or m.
    peak_motor_torque
        (n,) max |tau_m|, N m.
    peak_motor_velocity
        (n,) max |G qd|, rad/s at the motor.
    saturated_fraction
        (n,) fraction of control periods with the torque at its limit.
    rate_hz, wall_time
        Control rate (Hz) and simulation wall time (s).
    """

    controller: str
    robot: str
    joints: tuple[str, ...]
    units: tuple[str, ...]
    rms_error: np.ndarray
    max_error: np.ndarray
    peak_motor_torque: np.ndarray
    peak_motor_velocity: np.ndarray
    saturated_fraction: np.ndarray
    rate_hz: float
    wall_time: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (arrays as lists, one entry per joint)."""
        return {
            "controller": self.controller, "robot": self.robot, "joints": list(self.joints), "units": list(self.units),
            "rms_error": self.rms_error.tolist(), "max_error": self.max_error.tolist(),
            "peak_motor_torque": self.peak_motor_torque.tolist(), "peak_motor_velocity": self.peak_motor_velocity.tolist(),
            "saturated_fraction": self.saturated_fraction.tolist(), "rate_hz": self.rate_hz, "wall_time": self.wall_time,
        }


@dataclass(frozen=True)
class TrackingResult:
    """A closed-loop run sampled at the control instants.

    Attributes
    ----------
    controller, robot, joints, units
        Controller kind, robot name, joint names, units of q.
    t
        (N+1,) control instants ``t0 + k dt``, s.
    q, qd
        (N+1, n) plant state at those instants.
    q_ref, qd_ref, qdd_ref
        (N+1, n) reference.
    tau_m
        (N+1, n) motor torque applied from each instant on, N m.
    G
        (n,) reduction ratios.
    tau_m_max
        (n,) torque limits of the controller, N m, or None.
    rate_hz, substeps, wall_time
        Control rate (Hz), RK4 sub-steps per period, wall time (s).
    """

    controller: str
    robot: str
    joints: tuple[str, ...]
    units: tuple[str, ...]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray
    qdd_ref: np.ndarray
    tau_m: np.ndarray
    G: np.ndarray
    tau_m_max: np.ndarray | None
    rate_hz: float
    substeps: int
    wall_time: float

    @property
    def error(self) -> np.ndarray:
        """(N+1, n) tracking error ``q_ref - q``, rad or m."""
        return self.q_ref - self.q

    @property
    def qd_m(self) -> np.ndarray:
        """(N+1, n) motor velocity ``G qd``, rad/s."""
        return self.qd * self.G

    def metrics(self) -> TrackingMetrics:
        """RMS / max error, peak motor torque and velocity, saturation per joint."""
        e = self.error
        if self.tau_m_max is None:
            sat = np.zeros(self.G.size)
        else:
            sat = np.mean(np.abs(self.tau_m) >= self.tau_m_max * (1 - 1e-12), axis=0)
        return TrackingMetrics(
            controller=self.controller, robot=self.robot, joints=self.joints, units=self.units,
            rms_error=np.sqrt(np.mean(e * e, axis=0)), max_error=np.max(np.abs(e), axis=0),
            peak_motor_torque=np.max(np.abs(self.tau_m), axis=0), peak_motor_velocity=np.max(np.abs(self.qd_m), axis=0),
            saturated_fraction=sat, rate_hz=self.rate_hz, wall_time=self.wall_time,
        )


class ProgressLine:
    """Prints ``label: 40 % (t = 6.0 / 15.0 s)`` to a stream every ``every`` of the run."""

    def __init__(self, label: str = "simulate", stream: TextIO | None = None, every: float = 0.1) -> None:
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.every = every
        self._next = 0.0

    def __call__(self, fraction: float, t: float, t_final: float) -> None:
        if fraction + 1e-12 >= self._next:
            print(f"{self.label}: {100 * fraction:3.0f} % (t = {t:.2f} / {t_final:.2f} s)", file=self.stream, flush=True)
            self._next += self.every


def default_substeps(plant: Robot, dt: float, q0: np.ndarray) -> int:
    """RK4 sub-steps per control period: ``h <= MAX_SUBSTEP`` and ``h * lambda_friction <= 0.5``.

    ``lambda_friction`` is the largest eigenvalue of ``B(q0)^-1 diag(G^2 B_m)``, the plant's
    fastest open-loop decay rate (1/s), with the plant's friction parameters.
    """
    G = plant.gear_ratio
    B_m = plant.parameters.viscous_friction
    Binv_F = np.linalg.solve(plant.inertia(q0), np.diag(G * G * B_m))
    lam = float(np.max(np.abs(np.linalg.eigvals(Binv_F))))
    return max(1, math.ceil(dt / MAX_SUBSTEP - 1e-9), math.ceil(dt * lam / _STIFF_MARGIN - 1e-9))


def simulate_tracking(plant: Robot, controller: Controller, trajectory: Trajectory, *, t_final: float | None = None,
                      q0: Any = None, qd0: Any = None, substeps: int | None = None,
                      progress: Callable[[float, float, float], None] | None = None) -> TrackingResult:
    """Run ``controller`` on the nonlinear ``plant`` along ``trajectory``.

    Parameters
    ----------
    plant
        The simulated robot (its dynamics parameters, e.g. a payload, are used as set).
    controller
        Sampled controller; its rate sets the control period ``dt``.
    trajectory
        Reference; its path is evaluated at every control instant.
    t_final
        End time, s (default: the end of the trajectory); must be >= one period.
    q0, qd0
        Initial state (default: the reference at the start).
    substeps
        RK4 steps per control period (default :func:`default_substeps`).
    progress
        Called as ``progress(fraction, t, t_final)`` every period (e.g. :class:`ProgressLine`).

    Returns
    -------
    TrackingResult
    """
    n = plant.n
    if controller.n != n or trajectory.n != n:
        raise DesignSpecError(f"controller/trajectory: expected {n} joints like plant {plant.name!r}, "
                              f"got {controller.n} and {trajectory.n}")
    path = trajectory.path
    t0 = path.t_start
    t_end = path.t_end if t_final is None else float(t_final)
    dt = controller.dt
    steps = int(round((t_end - t0) / dt))
    if steps < 1:
        raise DesignSpecError(f"t_final: expected at least one control period ({dt:g} s) after t0 = {t0:g} s, got {t_end!r}")
    t = t0 + np.arange(steps + 1) * dt
    Qr, QDr, QDDr = path.batch(t)
    q = np.array(Qr[0]) if q0 is None else as_joint_vector(q0, n, "q0")
    qd = np.array(QDr[0]) if qd0 is None else as_joint_vector(qd0, n, "qd0")
    if substeps is None:
        substeps = default_substeps(plant, dt, q)
    if substeps < 1:
        raise DesignSpecError(f"substeps: expected >= 1, got {substeps!r}")
    h = dt / substeps
    G = plant.gear_ratio
    p, ws = plant.parameters, plant.dynamics.workspace()
    dyn_accel = plant.dynamics.accel  # compiled C; Robot.accel adds only a shape check

    def accel(q: np.ndarray, qd: np.ndarray, tau: np.ndarray) -> np.ndarray:
        return dyn_accel(q, qd, tau, p, ws=ws)

    Q = np.empty((steps + 1, n))
    QD = np.empty((steps + 1, n))
    TAU = np.empty((steps + 1, n))
    controller.reset()
    start = time.perf_counter()
    for k in range(steps + 1):
        Q[k], QD[k] = q, qd
        tau_m = controller.update(float(t[k]), q.copy(), qd.copy(), Reference(Qr[k], QDr[k], QDDr[k]))
        TAU[k] = tau_m
        if k == steps:
            break
        tau = G * tau_m
        for _ in range(substeps):
            a1 = accel(q, qd, tau)
            q2, v2 = q + 0.5 * h * qd, qd + 0.5 * h * a1
            a2 = accel(q2, v2, tau)
            q3, v3 = q + 0.5 * h * v2, qd + 0.5 * h * a2
            a3 = accel(q3, v3, tau)
            q4, v4 = q + h * v3, qd + h * a3
            a4 = accel(q4, v4, tau)
            q = q + (h / 6.0) * (qd + 2.0 * v2 + 2.0 * v3 + v4)
            qd = qd + (h / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
            raise SimulationDivergedError(f"simulation: the closed loop diverged at t = {t[k + 1]:g} s (controller {controller.kind!r})")
        if progress is not None:
            progress((k + 1) / steps, float(t[k + 1]), float(t[-1]))
    wall = time.perf_counter() - start
    links = plant.description.links
    return TrackingResult(
        controller=controller.kind, robot=plant.name,
        joints=tuple(lk.name or f"joint{i + 1}" for i, lk in enumerate(links)),
        units=tuple("rad" if lk.is_revolute else "m" for lk in links),
        t=t, q=Q, qd=QD, q_ref=np.array(Qr), qd_ref=np.array(QDr), qdd_ref=np.array(QDDr), tau_m=TAU,
        G=np.array(G), tau_m_max=None if controller.tau_m_max is None else controller.tau_m_max.copy(),
        rate_hz=controller.rate_hz, substeps=substeps, wall_time=wall,
    )
