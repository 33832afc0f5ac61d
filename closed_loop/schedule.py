"""The one schedule of every closed loop: control instants, references, start state and RK4 sub-steps.

At ``t_k = t0 + k h`` (integer k, never a running sum; ``h = 1 / rate_hz``) a
loop reads the plant state and the reference ``trajectory.path`` at ``t_k``;
the controller's motor torques are held over ``[t_k, t_k+1]`` (zero-order
hold) while the plant is integrated by classic fixed-step RK4 in ``substeps``
equal sub-steps. With the torque held the plant alone has no stiff mode (its
fastest eigenvalue is the viscous friction rate ``G^2 B_m / B_ii``); the
sub-step is chosen so that ``h <= 1 ms`` and ``h`` times that rate is <= 0.5,
well inside RK4's stability region (|h lambda| < 2.78). The Python loop
(:func:`closed_loop.simulate.simulate_tracking`), the FMPy master and the
libcosim master (:mod:`closed_loop.master`) all build their run from one
:class:`Schedule` and return its :class:`~closed_loop.result.TrackingResult`,
so their results compare sample by sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from control_design.errors import DesignSpecError
from model.arrays import as_joint_vector
from model.dynamics.singular import singular_dynamics_error, singular_joint
from model.limits import MAX_SAMPLES
from model.robot import Robot
from model.trajectory import Trajectory

from .result import TrackingResult

__all__ = ["MAX_SUBSTEP", "Schedule", "default_substeps"]

#: Longest RK4 sub-step, s.
MAX_SUBSTEP = 1e-3
_STIFF_MARGIN = 0.5  # |h lambda| bound for the plant's fastest (friction) eigenvalue


def default_substeps(plant: Robot, dt: float, q0: np.ndarray, rate_factor: float = 1.0) -> int:
    """RK4 sub-steps per control period: ``h <= MAX_SUBSTEP`` and ``h * lambda_friction <= 0.5``.

    ``lambda_friction`` is the largest eigenvalue of ``B(q0)^-1 diag(G^2 B_m)``, the plant's
    fastest open-loop decay rate (1/s), with the plant's friction parameters, times ``rate_factor``
    (a bound for a plant whose inertia is not ``plant``'s: ``1 / s`` for link masses scaled by ``s < 1``).
    A singular ``B(q0)`` is a :class:`~model.errors.SingularDynamicsError` naming the joint.
    """
    G = plant.gear_ratio
    B_m = plant.parameters.viscous_friction
    B = plant.inertia(q0)
    singular = singular_joint(B)
    if singular is not None:
        raise singular_dynamics_error(plant.description, singular[0], q0, "at the start of the closed loop")
    Binv_F = np.linalg.solve(B, np.diag(G * G * B_m))
    lam = float(np.max(np.abs(np.linalg.eigvals(Binv_F)))) * rate_factor
    return max(1, math.ceil(dt / MAX_SUBSTEP - 1e-9), math.ceil(dt * lam / _STIFF_MARGIN - 1e-9))


@dataclass(frozen=True)
class Schedule:
    """One closed-loop run's timing, references and start.

    Attributes
    ----------
    dt, rate_hz
        Control period (s) and rate (Hz).
    steps
        Number of periods N.
    t
        (N+1,) control instants ``t0 + k dt``, s.
    q_ref, qd_ref, qdd_ref
        (N+1, n) the trajectory's path at those instants.
    q0, qd0
        (n,) start state.
    substeps
        RK4 sub-steps per period.
    """

    dt: float
    rate_hz: float
    steps: int
    t: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray
    qdd_ref: np.ndarray
    q0: np.ndarray
    qd0: np.ndarray
    substeps: int

    @classmethod
    def build(cls, plant: Robot, trajectory: Trajectory, dt: float, *, rate_hz: float | None = None,
              t_final: float | None = None, q0: Any = None, qd0: Any = None,
              substeps: int | None = None) -> "Schedule":
        """The schedule of ``trajectory`` (from its start to ``t_final``, default its end) at period ``dt`` (s).

        ``rate_hz`` defaults to ``1 / dt``; ``q0``, ``qd0`` to the reference at the start; ``substeps``
        to :func:`default_substeps`.

        Raises
        ------
        control_design.errors.DesignSpecError
            A joint count that differs from the plant's, no whole period before ``t_final``,
            ``substeps`` < 1, a bad start state.
        """
        n = plant.n
        if trajectory.n != n:
            raise DesignSpecError(f"expected {n} joints like plant {plant.name!r}, got {trajectory.n}",
                                  parameter="trajectory")
        path = trajectory.path
        t0 = path.t_start
        t_end = path.t_end if t_final is None else float(t_final)
        periods = (t_end - t0) / dt
        if periods + 1 > MAX_SAMPLES:
            raise DesignSpecError(f"{t_end - t0:g} s at {1.0 / dt:g} Hz: {periods + 1:.4g} control instants, "
                                  f"more than the sample limit of {MAX_SAMPLES}", parameter="t_final")
        steps = int(round(periods))
        if steps < 1:
            raise DesignSpecError(f"expected at least one control period ({dt:g} s) after t0 = {t0:g} s, "
                                  f"got {t_end!r}", parameter="t_final")
        t = t0 + np.arange(steps + 1) * dt
        Qr, QDr, QDDr = (np.asarray(a) for a in path.batch(t))
        try:
            q_start = np.array(Qr[0]) if q0 is None else as_joint_vector(q0, n, "q0")
            qd_start = np.array(QDr[0]) if qd0 is None else as_joint_vector(qd0, n, "qd0")
        except ValueError as exc:
            raise DesignSpecError(str(exc)) from None
        sub = default_substeps(plant, dt, q_start) if substeps is None else int(substeps)
        if sub < 1:
            raise DesignSpecError(f"expected >= 1, got {substeps!r}", parameter="substeps")
        if steps * sub + 1 > MAX_SAMPLES:  # the RK4 grid is a time grid too: bounded before the run starts
            why = "" if substeps is not None else " (as fast as the plant's viscous friction needs: default_substeps)"
            raise DesignSpecError(f"{steps} control periods of {sub} RK4 sub-steps each{why}: {steps * sub + 1:.4g} "
                                  f"integration instants, more than the sample limit of {MAX_SAMPLES}",
                                  parameter="substeps")
        return cls(dt=dt, rate_hz=1.0 / dt if rate_hz is None else float(rate_hz), steps=steps, t=t,
                   q_ref=Qr, qd_ref=QDr, qdd_ref=QDDr, q0=q_start, qd0=qd_start, substeps=sub)

    def result(self, plant: Robot, kind: str, Q: np.ndarray, QD: np.ndarray, TAU: np.ndarray,
               tau_m_max: np.ndarray | None, wall: float) -> TrackingResult:
        """The :class:`~closed_loop.result.TrackingResult` of a run on this schedule."""
        links = plant.description.links
        return TrackingResult(
            controller=kind, robot=plant.name,
            joints=tuple(lk.name or f"joint{i + 1}" for i, lk in enumerate(links)),
            units=tuple("rad" if lk.is_revolute else "m" for lk in links),
            t=self.t, q=Q, qd=QD, q_ref=self.q_ref.copy(), qd_ref=self.qd_ref.copy(), qdd_ref=self.qdd_ref.copy(),
            tau_m=TAU, G=np.array(plant.gear_ratio),
            tau_m_max=None if tau_m_max is None else np.array(tau_m_max, dtype=float),
            rate_hz=self.rate_hz, substeps=self.substeps, wall_time=wall,
        )
