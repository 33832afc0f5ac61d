"""The Python closed loop: sampled controller in Python, ZOH torque, the plant's fixed-step rule in C.

The timing, references, start state and sub-steps are those of
:class:`~closed_loop.schedule.Schedule`. The plant is the one plant of
:mod:`model.plant` (its dynamics parameters, stick-slip friction modes
included), advanced over each control period by the rule every engine runs
(``model/dynamics/c/plant_step.c``: RK4 sub-steps, friction events located by
bisection, the modes settled at each period's start), called through ctypes
(:mod:`model.compiled_plant`). The run starts as an FMU leaves
initialisation: the start modes settled with zero torque.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, Callable

import numpy as np

from control_design.controllers import Controller
from control_design.errors import DesignSpecError, SimulationDivergedError
from control_design.reference import Reference
from model.compiled_plant import compiled_plant
from model.drive_train import drive_layout, drive_substeps, equilibrium_state
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
    model.errors.SingularDynamicsError
        B(q) is singular at a state the run reached (naming the joint and ``q``).
    model.codegen.CompilerNotFoundError
        No C compiler: the plant's rule is compiled C.
    """
    n = plant.n
    if controller.n != n or trajectory.n != n:
        raise DesignSpecError(f"controller/trajectory: expected {n} joints like plant {plant.name!r}, "
                              f"got {controller.n} and {trajectory.n}")
    if substeps is None:
        substeps = drive_substeps(plant.description, controller.dt)
    sched = Schedule.build(plant, trajectory, controller.dt, rate_hz=controller.rate_hz, t_final=t_final, q0=q0,
                           qd0=qd0, substeps=substeps)
    steps, t, substeps = sched.steps, sched.t, sched.substeps
    Qr, QDr, QDDr = sched.q_ref, sched.qd_ref, sched.qdd_ref
    run = compiled_plant(plant).run(plant.parameters.vector)
    lay = drive_layout(plant.description)
    G = np.asarray(plant.gear_ratio, dtype=float)
    x0 = np.concatenate([sched.q0, sched.qd0])
    if lay.nx > 2 * n:  # drive trains: start in static equilibrium (gears deflected, loops at rest), as Modelica's r3
        x0 = equilibrium_state(plant.description, sched.q0, plant.gravload(sched.q0))
        x0[n:2 * n] = sched.qd0
    run.start(x0)
    x = run.x
    Q = np.empty((steps + 1, n))
    QD = np.empty((steps + 1, n))
    TAU = np.empty((steps + 1, n))
    QDM = np.empty((steps + 1, n)) if lay.ne else None
    controller.reset()
    motor = getattr(controller, "measures_motor", False)
    if motor:  # a motor-side controller starts holding the arm where it is
        qm, qdm = lay.motor_state(x, G)
        controller.hold_from(qm, qdm, Reference(Qr[0], QDr[0], QDDr[0]), plant.gravload(sched.q0) / G)
    start = time.perf_counter()
    try:
        for k in range(steps + 1):
            Q[k], QD[k] = x[:n], x[n:2 * n]
            ref = Reference(Qr[k], QDr[k], QDDr[k])
            if QDM is not None:
                QDM[k] = lay.motor_state(x, G)[1]
            if motor:
                qm, qdm = lay.motor_state(x, G)
                tau_m = controller.update_motor(float(t[k]), Q[k].copy(), QD[k].copy(), qm, qdm, ref)
            else:
                tau_m = controller.update(float(t[k]), Q[k].copy(), QD[k].copy(), ref)
            TAU[k] = tau_m
            if k == steps:
                break
            if not run.advance(tau_m, sched.dt, substeps):
                raise SimulationDivergedError(f"simulation: the closed loop diverged at t = {t[k + 1]:g} s "
                                              f"(controller {controller.kind!r})")
            if progress is not None:
                progress((k + 1) / steps, float(t[k + 1]), float(t[-1]))
    finally:
        run.close()
    wall = time.perf_counter() - start
    result = sched.result(plant, controller.kind, Q, QD, TAU, controller.tau_m_max, wall)
    return result if QDM is None else dataclasses.replace(result, rotor_qd=QDM)
