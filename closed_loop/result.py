"""The one result type of every closed loop: :class:`TrackingResult`, and its :class:`TrackingMetrics`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["SATURATION_MARGIN", "TrackingMetrics", "TrackingResult"]

#: A torque at (1 - 1e-12) of its limit or beyond counts as saturated (the clipped value, rounding forgiven).
SATURATION_MARGIN = 1 - 1e-12


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
    saturated_longest, saturated_longest_start
        (n,) longest unbroken stretch of control periods at the limit, s, and the time it starts, s
        (NaN when the motor never saturates).
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
    saturated_longest: np.ndarray
    saturated_longest_start: np.ndarray
    rate_hz: float
    wall_time: float

    @property
    def saturated(self) -> np.ndarray:
        """(n,) indices of the motors that reached their limit at least once."""
        return np.flatnonzero(self.saturated_fraction > 0)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (arrays as lists, one entry per joint)."""
        return {
            "controller": self.controller, "robot": self.robot, "joints": list(self.joints), "units": list(self.units),
            "rms_error": self.rms_error.tolist(), "max_error": self.max_error.tolist(),
            "peak_motor_torque": self.peak_motor_torque.tolist(), "peak_motor_velocity": self.peak_motor_velocity.tolist(),
            "saturated_fraction": self.saturated_fraction.tolist(),
            "saturated_longest_s": self.saturated_longest.tolist(),
            "saturated_longest_start_s": [None if v != v else v for v in self.saturated_longest_start.tolist()],
            "rate_hz": self.rate_hz, "wall_time": self.wall_time,
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
    rotor_qd
        (N+1, n) rotor speeds, rad/s, where a joint has an elastic gear (its own state); None: ``G qd``.
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
    rotor_qd: np.ndarray | None = None

    @property
    def error(self) -> np.ndarray:
        """(N+1, n) tracking error ``q_ref - q``, rad or m."""
        return self.q_ref - self.q

    @property
    def qd_m(self) -> np.ndarray:
        """(N+1, n) motor velocity, rad/s: ``G qd``, or the rotor's own speed behind an elastic gear."""
        return self.qd * self.G if self.rotor_qd is None else self.rotor_qd

    def metrics(self) -> TrackingMetrics:
        """RMS / max error, peak motor torque and velocity, saturation per joint."""
        e = self.error
        if self.tau_m_max is None:
            at_limit = np.zeros(self.tau_m.shape, dtype=bool)
        else:
            at_limit = np.abs(self.tau_m) >= self.tau_m_max * SATURATION_MARGIN
        runs = [_longest_run(at_limit[:, j]) for j in range(at_limit.shape[1])]
        dt = 1.0 / self.rate_hz
        return TrackingMetrics(
            controller=self.controller, robot=self.robot, joints=self.joints, units=self.units,
            rms_error=np.sqrt(np.mean(e * e, axis=0)), max_error=np.max(np.abs(e), axis=0),
            peak_motor_torque=np.max(np.abs(self.tau_m), axis=0), peak_motor_velocity=np.max(np.abs(self.qd_m), axis=0),
            saturated_fraction=np.mean(at_limit, axis=0),
            saturated_longest=np.array([length * dt for length, _ in runs]),
            saturated_longest_start=np.array([self.t[k] if length else np.nan for length, k in runs]),
            rate_hz=self.rate_hz, wall_time=self.wall_time,
        )


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """Length and first index of the longest run of True in the 1-D ``mask``; (0, 0) if none."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    if starts.size == 0:
        return 0, 0
    k = int(np.argmax(ends - starts))
    return int(ends[k] - starts[k]), int(starts[k])
