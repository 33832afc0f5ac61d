"""The Python closed loop: sampled controller, ZOH torque, RK4 plant (compiled dynamics).

The timing, references, start state and sub-steps are those of
:class:`~closed_loop.schedule.Schedule`; the plant ``qdd = accel(q, qd, G tau_m)``
runs with the plant Robot's parameters in one explicit workspace.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from control_design.controllers import Controller
from control_design.errors import DesignSpecError, SimulationDivergedError
from control_design.reference import Reference
from model.codegen import CompilerNotFoundError
from model.dynamics import Workspace
from model.robot import Robot
from model.trajectory import Trajectory

from .result import TrackingResult
from .schedule import Schedule

__all__ = ["simulate_tracking"]


def simulate_tracking(plant: Robot, controller: Controller, trajectory: Trajectory, *, t_final: float | None = None,
                      q0: Any = None, qd0: Any = None, substeps: int | None = None,
                      progress: Callable[[float, float, float], None] | None = None) -> TrackingResult:
    """Run ``controller`` on the nonlinear ``plant`` along ``trajectory``.

    Parameters
    ----------
    plant
        The simulated robot (its dynamics parameters, e.g. a payload, are used).
    controller
        Sampled controller; its rate sets the control period ``dt``.
    trajectory
        Reference; its path is evaluated at every control instant.
    t_final
        End time, s (default: the end of the trajectory); must be >= one period.
    q0, qd0
        Initial state (default: the reference at the start).
    substeps
        RK4 steps per control period (default :func:`~closed_loop.schedule.default_substeps`).
    progress
        Called as ``progress(fraction, t, t_final)`` every period (e.g. :class:`~closed_loop.progress.ProgressLine`).

    Returns
    -------
    TrackingResult

    Raises
    ------
    control_design.errors.DesignSpecError
        Joint counts that differ, bad times or start state.
    control_design.errors.SimulationDivergedError
        The state became non-finite.
    """
    n = plant.n
    if controller.n != n or trajectory.n != n:
        raise DesignSpecError(f"controller/trajectory: expected {n} joints like plant {plant.name!r}, "
                              f"got {controller.n} and {trajectory.n}")
    sched = Schedule.build(plant, trajectory, controller.dt, rate_hz=controller.rate_hz, t_final=t_final, q0=q0,
                           qd0=qd0, substeps=substeps)
    steps, t, substeps = sched.steps, sched.t, sched.substeps
    Qr, QDr, QDDr = sched.q_ref, sched.qd_ref, sched.qdd_ref
    q, qd = sched.q0.copy(), sched.qd0.copy()
    h = sched.dt / substeps
    G = plant.gear_ratio
    p = plant.parameters
    try:
        ws: Workspace | None = plant.dynamics.workspace()
    except CompilerNotFoundError:  # the dynamics evaluate with CasADi (warned once); no buffers to hold
        ws = None
    dyn_accel = plant.dynamics.accel  # compiled C

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
    return sched.result(plant, controller.kind, Q, QD, TAU, controller.tau_m_max, wall)
