"""Closed-loop co-simulation masters: a controller driving the plant FMU at the control rate.

The timing is the one :class:`~closed_loop.schedule.Schedule` of every loop, that of
:func:`closed_loop.simulate.simulate_tracking`, so the results compare sample by sample: at ``t_k = t0 + k h`` (integer k, never a
running sum; ``h = 1 / rate_hz``) the controller reads the plant state and the
reference ``trajectory.path`` at ``t_k``; its motor torques are held over
``[t_k, t_k+1]`` (zero-order hold) while the plant FMU takes one
``fmi2DoStep(t_k, h)`` (``fmi3DoStep``), integrated inside the FMU by RK4 in ``substeps`` equal
sub-steps (its ``internal_step`` is set to ``h / substeps``, the same sub-step
as the Python loop's).

* :func:`run_closed_loop` - the FMUs through :class:`fmu.instance.Instance` (FMI 2.0 or 3.0; its
  buffered reader, writer and stepper in the loop; Gauss-Seidel order:
  plant outputs -> controller -> plant inputs within the same instant). The
  controller is a Python :class:`~control_design.controllers.Controller` or a
  controller FMU (:mod:`closed_loop.controller_fmu`), whose torques go to the plant
  from buffer to buffer (no Python floats).
* :func:`run_libcosim_closed_loop` - the same two FMUs in libcosim, connected by
  libcosim variable connections (plant ``q``, ``qd`` -> controller; controller
  ``tau_m`` -> plant). libcosim's fixed-step algorithm steps every slave in
  parallel and transfers the connected values after the step (Jacobi), so a
  direct-feedthrough controller reaches the plant one period later: that loop is
  the Python loop with a one-period computational delay
  (:class:`~closed_loop.delay.OnePeriodDelay`), which is what it is compared with. The reference is
  fed by Python through libcosim's override manipulator from the same
  ``trajectory.path`` samples as the Python loop (bit-identical references; the
  controller FMU stays a time-free law usable with any trajectory or waypoint file).
* :func:`closed_loop_through_fmu` - what the demo calls: exports the FMUs it
  needs into a folder, then runs :func:`run_closed_loop`.
"""

from __future__ import annotations

import math
import os
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from control_design.controllers import Controller
from control_design.design import RobotDesign
from control_design.errors import SimulationDivergedError
from control_design.laws import NO_LIMIT
from control_design.reference import Reference
from fmu.build import build_fmu, export_fmu
from fmu.cosim import CosimError, add_slave, last_error
from fmu.instance import FmuCallError, Instance
from fmu.opened import open_fmu
from fmu.robot_resource import RobotNotReloadableError, reload_fmu_robot
from model.errors import InputError
from model.robot import Robot
from model.trajectory import Trajectory

from .controller_fmu import controller_fmu_kind, controller_spec
from .result import TrackingResult
from .schedule import Schedule

__all__ = [
    "run_closed_loop",
    "run_closed_loop_me",
    "run_libcosim_closed_loop",
    "closed_loop_through_fmu",
]

Progress = Callable[[float, float, float], None]
Say = Callable[[str], None]

_NS_PER_S = 1_000_000_000


# --------------------------------------------------------------------- helpers

def _plant_robot(plant_fmu: Path, plant: Robot | None) -> Robot:
    if plant is not None:
        return plant
    try:
        robot = reload_fmu_robot(plant_fmu)
    except RobotNotReloadableError as exc:
        raise InputError(f"{plant_fmu.name}: {exc}; pass the plant Robot as plant=", parameter="plant") from exc
    if robot is None:
        raise InputError(f"{plant_fmu.name} records no robot in its VendorAnnotations; pass the plant Robot",
                         parameter="plant")
    return robot


def _existing(path: str | os.PathLike[str], what: str) -> Path:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"expected an FMU file, got {str(p)!r}", parameter=what)
    return p


def _limits(values: np.ndarray) -> np.ndarray | None:
    return None if np.all(values >= NO_LIMIT) else values


def _cs_instance(stack: ExitStack, path: Path, parameter: str, name: str) -> Instance:
    """A Co-Simulation :class:`~fmu.instance.Instance` of the FMU at ``path``, closed with ``stack``."""
    opened = stack.enter_context(open_fmu(path, parameter=parameter))
    if "cs" not in opened.interfaces:
        raise InputError(f"{path.name} has no Co-Simulation interface", parameter=parameter)
    return stack.enter_context(opened.instance("cs", name))


def _plant_start_values(plant: Robot, sched: Schedule) -> dict[str, float]:
    n = plant.n
    values = {f"q[{i + 1}]": float(sched.q0[i]) for i in range(n)}
    values.update({f"qd[{i + 1}]": float(sched.qd0[i]) for i in range(n)})
    values.update(plant.parameters.as_dict())
    values["internal_step"] = sched.dt / sched.substeps
    return values


# ------------------------------------------------------------- FMPy master

def run_closed_loop(plant_fmu: str | os.PathLike[str], controller: Controller | str | os.PathLike[str],
                    trajectory: Trajectory, *, plant: Robot | None = None, rate_hz: float | None = None,
                    t_final: float | None = None, q0: Any = None, qd0: Any = None, substeps: int | None = None,
                    controller_parameters: Mapping[str, float] | None = None,
                    progress: Progress | None = None) -> TrackingResult:
    """Run a controller on the plant FMU (FMI 2.0 or 3.0 Co-Simulation) along ``trajectory``.

    Parameters
    ----------
    plant_fmu
        The plant FMU (:func:`fmu.export_fmu`).
    controller
        A Python :class:`~control_design.controllers.Controller` (its ``update`` is called once
        per period) or the path of a controller FMU (:func:`closed_loop.export_controller_fmu`).
    trajectory
        Reference; its path is evaluated at every control instant.
    plant
        The simulated robot: its dynamics parameters (payload, friction, gravity) are set in the
        FMU, its joint names and gear ratios label the result (default: the robot recorded in
        the FMU, with its default parameters).
    rate_hz
        Control rate, Hz (default: the Python controller's, or the controller FMU's default step).
    t_final
        End time, s (default: the end of the trajectory).
    q0, qd0
        Initial state (default: the reference at the start).
    substeps
        RK4 sub-steps of the plant FMU per period (default
        :func:`~closed_loop.schedule.default_substeps`, as the Python loop).
    controller_parameters
        Parameter values set in a controller FMU before it starts (e.g. ``{"Kp[1]": 100.0}``).
    progress
        Called as ``progress(fraction, t, t_final)`` after every period.

    Returns
    -------
    TrackingResult
        Same fields and meaning as :func:`~closed_loop.simulate.simulate_tracking`'s; ``wall_time``
        is the time of the loop (s).

    Raises
    ------
    model.errors.InputError
        Missing FMU, unknown variable, joint counts that differ, bad times.
    control_design.errors.SimulationDivergedError
        The plant FMU discarded a step (its state became non-finite).
    """

    plant_path = _existing(plant_fmu, "plant_fmu")
    plant_robot = _plant_robot(plant_path, plant)
    n = plant_robot.n
    py_ctrl: Controller | None = None
    ctrl_path: Path | None = None
    if isinstance(controller, Controller):
        py_ctrl = controller
        if py_ctrl.n != n:
            raise InputError(f"expected {n} joints like plant {plant_robot.name!r}, got {py_ctrl.n}",
                             parameter="controller")
        dt = py_ctrl.dt if rate_hz is None else 1.0 / rate_hz
        if rate_hz is not None and not math.isclose(dt, py_ctrl.dt, rel_tol=1e-12):
            raise InputError(f"the Python controller runs at {py_ctrl.rate_hz:g} Hz, got {rate_hz!r}",
                             parameter="rate_hz")
        kind = py_ctrl.kind
    else:
        ctrl_path = _existing(controller, "controller")
        kind = controller_fmu_kind(ctrl_path)[1]
        dt = 0.0
    sched: Schedule | None = None

    with ExitStack() as stack:
        plant_inst = _cs_instance(stack, plant_path, "plant_fmu", "plant")
        ctrl_inst = None if ctrl_path is None else _cs_instance(stack, ctrl_path, "controller", "controller")
        if ctrl_inst is not None:
            dt = 1.0 / rate_hz if rate_hz is not None else ctrl_inst.fmu.default_step or 0.0
            if not dt > 0:
                raise InputError("expected a control rate (the controller FMU has no default step)",
                                 parameter="rate_hz")
        rate = rate_hz if rate_hz is not None else py_ctrl.rate_hz if py_ctrl is not None else None
        sched = Schedule.build(plant_robot, trajectory, dt, rate_hz=rate, t_final=t_final, q0=q0, qd0=qd0,
                               substeps=substeps)
        x_names = [f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)]
        tau_names = [f"tau_m[{i + 1}]" for i in range(n)]
        plant_inst.start(float(sched.t[0]), _plant_start_values(plant_robot, sched))
        p_read = plant_inst.reader(x_names)
        tau_np, p_write = plant_inst.writer(tau_names)
        p_step = plant_inst.stepper()

        if ctrl_inst is not None:
            groups = ["q_ref", "qd_ref"] + (["qdd_ref"] if ctrl_inst.fmu.has("qdd_ref[1]") else [])
            ref_names = [f"{g}[{i + 1}]" for g in groups for i in range(n)]
            ctrl_inst.start(float(sched.t[0]), dict(controller_parameters or {}))
            tau_m_max = _limits(ctrl_inst.get([f"tau_m_max[{i + 1}]" for i in range(n)]))
            columns = {"q_ref": sched.q_ref, "qd_ref": sched.qd_ref, "qdd_ref": sched.qdd_ref}
            R = np.ascontiguousarray(np.hstack([columns[g] for g in groups]))
            m = R.shape[1]
            u_np, c_write = ctrl_inst.writer(ref_names + x_names)
            c_read = ctrl_inst.reader(tau_names)
            c_step = ctrl_inst.stepper()
        else:
            assert py_ctrl is not None
            tau_m_max = None if py_ctrl.tau_m_max is None else py_ctrl.tau_m_max.copy()

        steps, t, h = sched.steps, sched.t, sched.dt
        Q = np.empty((steps + 1, n))
        QD = np.empty((steps + 1, n))
        TAU = np.empty((steps + 1, n))

        def plant_step(k: int) -> None:
            """Step the plant over ``[t_k, t_k+1]`` with the torques in ``tau_np``; report the progress."""
            tk = float(t[k])
            try:
                p_write()        # refuses non-finite torques
                p_step(tk, h)    # discards a step whose state is not finite
            except FmuCallError as exc:
                raise SimulationDivergedError(
                    f"simulation: the plant FMU rejected the step at t = {tk:g} s ({exc}): the closed loop "
                    f"diverged (controller {kind!r})") from exc
            if progress is not None:
                progress((k + 1) / steps, float(t[k + 1]), float(t[-1]))

        start = time.perf_counter()
        if ctrl_inst is not None:
            for k in range(steps + 1):
                x = p_read()
                Q[k], QD[k] = x[:n], x[n:]
                u_np[:m] = R[k]
                u_np[m:] = x
                c_write()
                tau = c_read()
                TAU[k] = tau
                if k == steps:
                    break
                c_step(float(t[k]), h)
                tau_np[:] = tau
                plant_step(k)
        else:
            assert py_ctrl is not None
            py_ctrl.reset()
            Qr, QDr, QDDr = sched.q_ref, sched.qd_ref, sched.qdd_ref
            for k in range(steps + 1):
                x = p_read()
                q, qd = x[:n].copy(), x[n:].copy()
                Q[k], QD[k] = q, qd
                tau_m = py_ctrl.update(float(t[k]), q, qd, Reference(Qr[k], QDr[k], QDDr[k]))
                TAU[k] = tau_m
                if k == steps:
                    break
                tau_np[:] = tau_m
                plant_step(k)
        wall = time.perf_counter() - start
    assert sched is not None
    return sched.result(plant_robot, kind, Q, QD, TAU, tau_m_max, wall)


# ------------------------------------------------- Model Exchange master (CVode)

class _HeldInputs:
    """The ``input`` of FMPy's CVode solver: the torques are set once per control period, nothing in between."""

    def apply(self, time: float, continuous: bool = True, discrete: bool = True, after_event: bool = False) -> None:
        return None


def run_closed_loop_me(plant_fmu: str | os.PathLike[str], controller: Controller, trajectory: Trajectory, *,
                       plant: Robot | None = None, t_final: float | None = None, q0: Any = None, qd0: Any = None,
                       relative_tolerance: float = 1e-10, progress: Progress | None = None) -> TrackingResult:
    """The Python ``controller`` on the plant FMU in Model Exchange, integrated by CVode between control instants.

    The schedule is :func:`run_closed_loop`'s (the torques computed at ``t_k`` are held over
    ``[t_k, t_k+1]``); the plant FMU starts as there (its start modes settled with zero torque),
    and at each ``t_k`` the master enters Event Mode, sets the torques, lets the FMU settle its
    friction modes (``fmi2NewDiscreteStates``) and restarts FMPy's CVode (BDF, ``relative_tolerance``,
    root finding on the FMU's event indicators: a joint that sticks or breaks loose is an event,
    handled the same way). Without the fixed step, the run differs from the fixed-step engines
    by their RK4 error only.

    Parameters are those of :func:`run_closed_loop` (the Python controller only; no sub-steps).

    Raises
    ------
    model.errors.InputError
        Missing FMU, an FMU without Model Exchange, joint counts that differ.
    control_design.errors.SimulationDivergedError
        The FMU refused a call (its state became non-finite) or CVode failed.
    """
    from fmpy.fmi1 import FMICallException
    from fmpy.sundials import CVodeSolver

    plant_path = _existing(plant_fmu, "plant_fmu")
    plant_robot = _plant_robot(plant_path, plant)
    n = plant_robot.n
    if controller.n != n:
        raise InputError(f"expected {n} joints like plant {plant_robot.name!r}, got {controller.n}",
                         parameter="controller")
    sched = Schedule.build(plant_robot, trajectory, controller.dt, rate_hz=controller.rate_hz, t_final=t_final,
                           q0=q0, qd0=qd0, substeps=1)
    x_names = [f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)]
    tau_names = [f"tau_m[{i + 1}]" for i in range(n)]
    start_values = {k: v for k, v in _plant_start_values(plant_robot, sched).items() if k != "internal_step"}
    steps, t = sched.steps, sched.t
    Q, QD, TAU = (np.empty((steps + 1, n)) for _ in range(3))
    with open_fmu(plant_path, parameter="plant_fmu") as opened:
        if "me" not in opened.interfaces:
            raise InputError(f"{plant_path.name} has no Model Exchange interface", parameter="plant_fmu")
        x_sel, tau_sel = opened.select(x_names), opened.select(tau_names)
        with opened.instance("me", "plant") as inst:
            try:
                inst.start(float(t[0]), start_values)  # start modes settled, then Continuous-Time Mode
                solver = CVodeSolver(nx=opened.n_states, nz=opened.n_event_indicators, **inst.solver_functions(),
                                     input=_HeldInputs(), startTime=float(t[0]), maxStep=sched.dt,
                                     relativeTolerance=relative_tolerance, maxNumSteps=100_000)
                controller.reset()
                Qr, QDr, QDDr = sched.q_ref, sched.qd_ref, sched.qdd_ref
                start = time.perf_counter()
                for k in range(steps + 1):
                    x = inst.get(x_sel)
                    Q[k], QD[k] = x[:n], x[n:]
                    tau_m = controller.update(float(t[k]), x[:n].copy(), x[n:].copy(),
                                              Reference(Qr[k], QDr[k], QDDr[k]))
                    TAU[k] = tau_m
                    if k == steps:
                        break
                    inst.enter_event_mode()
                    inst.set(tau_sel, tau_m)
                    inst.event_iteration()  # the friction modes follow the new torques
                    inst.enter_continuous_time_mode()
                    solver.reset(float(t[k]))
                    tk, t_next = float(t[k]), float(t[k + 1])
                    while tk < t_next and not math.isclose(tk, t_next, rel_tol=1e-12, abs_tol=1e-15):
                        state_event, _, tk = solver.step(tk, t_next)
                        inst.set_time(tk)
                        step_event, terminate = inst.completed_integrator_step()
                        if terminate:
                            raise SimulationDivergedError(
                                f"simulation: the plant FMU asked to terminate at t = {tk:g} s")
                        if state_event or step_event:
                            inst.enter_event_mode()
                            inst.event_iteration()  # a joint sticks or breaks loose
                            inst.enter_continuous_time_mode()
                            solver.reset(tk)
                    inst.set_time(t_next)
                    if progress is not None:
                        progress((k + 1) / steps, t_next, float(t[-1]))
                wall = time.perf_counter() - start
                del solver
            except (FmuCallError, FMICallException, RuntimeError) as exc:  # CVode's calls bypass the adapter
                raise SimulationDivergedError(f"simulation: the Model Exchange closed loop failed ({exc}) "
                                              f"(controller {controller.kind!r})") from exc
    return sched.result(plant_robot, controller.kind, Q, QD, TAU, controller.tau_m_max, wall)


# ------------------------------------------------------------ libcosim master

def run_libcosim_closed_loop(plant_fmu: str | os.PathLike[str], controller_fmu: str | os.PathLike[str],
                             trajectory: Trajectory, *, plant: Robot | None = None, rate_hz: float | None = None,
                             t_final: float | None = None, q0: Any = None, qd0: Any = None,
                             substeps: int | None = None, controller_parameters: Mapping[str, float] | None = None,
                             progress: Progress | None = None, quiet: bool = True) -> TrackingResult:
    """The plant FMU and a controller FMU connected in libcosim, the reference fed from Python.

    libcosim connections carry plant ``q[i]``, ``qd[i]`` to the controller and the
    controller's ``tau_m[i]`` to the plant; before every step the override manipulator
    sets the controller's ``q_ref``, ``qd_ref`` (and ``qdd_ref``) to the trajectory at
    ``t_k``, and the plant states, parameters and the controller's references start
    from their values at ``t_0`` (libcosim initial values). libcosim's fixed-step
    algorithm is Jacobi: the torques computed at ``t_k`` drive the plant over
    ``[t_k+1, t_k+2]``, so the run equals the Python loop with
    :class:`~closed_loop.delay.OnePeriodDelay` around the controller.

    Parameters are those of :func:`run_closed_loop`; ``quiet`` sets libcosim's
    (process-wide) log level to warnings. The result's ``tau_m[k]`` is the torque the
    plant held over ``[t_k, t_k+1]``; ``wall_time`` the time of the stepping loop (s).

    Raises
    ------
    model.errors.InputError
        Missing FMU, unknown variable, a period that is not a whole number of ns.
    fmu.cosim.CosimError
        libcosim refused to load, connect or step.
    """
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver


    plant_path = _existing(plant_fmu, "plant_fmu").resolve()
    ctrl_path = _existing(controller_fmu, "controller_fmu").resolve()
    plant_robot = _plant_robot(plant_path, plant)
    n = plant_robot.n
    kind = controller_fmu_kind(ctrl_path)[1]
    if rate_hz is None:
        with open_fmu(ctrl_path, parameter="controller_fmu") as opened:
            default_step = opened.default_step
        if not default_step:
            raise InputError("expected a control rate (the controller FMU has no default step)", parameter="rate_hz")
        dt = default_step
    else:
        dt = 1.0 / rate_hz
    step_ns = int(round(dt * _NS_PER_S))
    if step_ns < 1 or abs(step_ns - dt * _NS_PER_S) > 1e-6 * max(1.0, dt * _NS_PER_S):
        raise InputError(f"libcosim counts time in ns; the period {dt!r} s is not a whole number of ns",
                         parameter="rate_hz")
    sched = Schedule.build(plant_robot, trajectory, dt, rate_hz=rate_hz, t_final=t_final, q0=q0, qd0=qd0,
                           substeps=substeps)
    if quiet:
        log_output_level(CosimLogLevel.WARNING)

    execution = CosimExecution.from_step_size(step_ns)
    held: list[Any] = []  # slaves, manipulator, observer: released after the execution that uses them
    try:
        index: dict[str, int] = {}
        refs: dict[str, dict[str, int]] = {}
        for name, path in (("plant", plant_path), ("controller", ctrl_path)):
            slave, i = add_slave(execution, path, name)
            held.append(slave)
            index[name] = i
            refs[name] = {v.name.decode(): int(v.reference) for v in execution.slave_variables(i)}

        files = {"plant": plant_path.name, "controller": ctrl_path.name}

        def vrs(slave: str, names: Sequence[str]) -> list[int]:
            missing = [nm for nm in names if nm not in refs[slave]]
            if missing:
                raise InputError(f"no variables {missing} in {files[slave]}", parameter=slave)
            return [refs[slave][nm] for nm in names]

        x_names = [f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)]
        tau_names = [f"tau_m[{i + 1}]" for i in range(n)]
        groups = ["q_ref", "qd_ref"] + (["qdd_ref"] if "qdd_ref[1]" in refs["controller"] else [])
        ref_names = [f"{g}[{i + 1}]" for g in groups for i in range(n)]
        ip, ic = index["plant"], index["controller"]
        plant_x, plant_tau = vrs("plant", x_names), vrs("plant", tau_names)
        ctrl_x, ctrl_tau = vrs("controller", x_names), vrs("controller", tau_names)
        ctrl_ref = vrs("controller", ref_names)
        limit_vrs = vrs("controller", [f"tau_m_max[{i + 1}]" for i in range(n)])

        for src, dst in [(("plant", a), ("controller", b)) for a, b in zip(plant_x, ctrl_x)] + \
                        [(("controller", a), ("plant", b)) for a, b in zip(ctrl_tau, plant_tau)]:
            if execution.connect_real_variables(index[src[0]], src[1], index[dst[0]], dst[1]) != 0:
                raise CosimError(f"libcosim refused the connection {src[0]}:{src[1]} -> {dst[0]}:{dst[1]}: "
                                 f"{last_error()}")
        columns = {"q_ref": sched.q_ref, "qd_ref": sched.qd_ref, "qdd_ref": sched.qdd_ref}
        R = np.hstack([columns[g] for g in groups])
        initial = [(ip, vrs("plant", [nm])[0], v) for nm, v in _plant_start_values(plant_robot, sched).items()]
        initial += [(ic, vr, float(v)) for vr, v in zip(ctrl_ref, R[0])]
        initial += [(ic, vrs("controller", [nm])[0], float(v)) for nm, v in (controller_parameters or {}).items()]
        for i, vr, value in initial:
            if not execution.real_initial_value(i, vr, value):
                raise CosimError(f"libcosim refused the initial value {value!r} of variable {vr} of slave {i}: "
                                 f"{last_error()}")

        manipulator = CosimManipulator.create_override()
        observer = CosimObserver.create_last_value()
        held += [manipulator, observer]
        if not execution.add_manipulator(manipulator) or not execution.add_observer(observer):
            raise CosimError(f"libcosim refused the manipulator or the observer: {last_error()}")

        steps = sched.steps
        Q = np.empty((steps + 1, n))
        QD = np.empty((steps + 1, n))
        TAU = np.empty((steps + 1, n))
        Q[0], QD[0] = sched.q0, sched.qd0
        rows = R.tolist()
        t = sched.t
        start = time.perf_counter()
        for k in range(steps):
            if not manipulator.slave_real_values(ic, ctrl_ref, rows[k]):
                raise CosimError(f"libcosim refused the reference at t = {t[k]:g} s: {last_error()}")
            if not execution.step(1):
                raise CosimError(f"libcosim step {k + 1} (t = {t[k]:g} s) failed: {last_error()}")
            x = observer.last_real_values(ip, plant_x)
            Q[k + 1], QD[k + 1] = x[:n], x[n:]
            TAU[k] = observer.last_real_values(ip, plant_tau)
            if progress is not None:
                progress((k + 1) / steps, float(t[k + 1]), float(t[-1]))
        TAU[steps] = observer.last_real_values(ic, ctrl_tau)  # what the plant would hold from t_N on
        tau_m_max = _limits(np.array(observer.last_real_values(ic, limit_vrs)))
        wall = time.perf_counter() - start
    finally:
        del execution
        held.clear()
    if not (np.all(np.isfinite(Q)) and np.all(np.isfinite(QD))):
        raise SimulationDivergedError(f"simulation: the libcosim closed loop diverged (controller {kind!r})")
    return sched.result(plant_robot, kind, Q, QD, TAU, tau_m_max, wall)


# ------------------------------------------------------- what the demo calls

_BUILT: dict[tuple[Any, ...], tuple[Path, float]] = {}


def _cached_build(key: tuple[Any, ...], path: Path, build: Callable[[], Path]) -> Path:
    """Build ``path`` unless this process built it with the same ``key`` and nobody touched it since."""
    known = _BUILT.get(key)
    if known is not None and path.is_file() and path.stat().st_mtime == known[1]:
        return path
    built = build()
    _BUILT[key] = (built, built.stat().st_mtime)
    return built


def closed_loop_through_fmu(robot: Robot, design: RobotDesign, trajectory: Trajectory,
                            workdir: str | os.PathLike[str], *, controller_fmu: bool, rate_hz: float | None = None,
                            plant: Robot | None = None, plant_fmu: str | os.PathLike[str] | None = None,
                            t_final: float | None = None, saturate: bool = True, progress: Progress | None = None,
                            say: Say | None = None) -> TrackingResult:
    """The design's controller on the plant FMU along ``trajectory``: export what is needed, run the loop.

    Parameters
    ----------
    robot
        The robot (the plant unless ``plant`` is given).
    design
        The control design; its ``controller(rate_hz, saturate)`` is the one run.
    trajectory
        Reference.
    workdir
        Folder for the FMUs (``<plant>.fmu``, ``<robot>_<kind>_controller.fmu``), created only when
        one is built; an FMU this process already built there from the same inputs is reused.
    controller_fmu
        Run the controller as an FMU (True) or as the Python controller (False).
    rate_hz
        Control rate, Hz (default the design's, else :data:`control_design.design.DEFAULT_RATE_HZ`).
    plant
        The simulated robot when it differs from ``robot`` (payload, friction, masses).
    plant_fmu
        An existing plant FMU of ``plant`` to use instead of exporting one.
    t_final
        End time, s (default the end of the trajectory).
    saturate
        Clip at the design's torque limits.
    progress
        ``progress(fraction, t, t_final)`` after every period (e.g. ``closed_loop.ProgressLine``).
    say
        Called with one line per stage (exports, run).

    Returns
    -------
    TrackingResult
        As :func:`closed_loop.simulate.simulate_tracking` returns.
    """
    folder = Path(workdir)
    if plant_fmu is None or controller_fmu:  # created only when an FMU is written there: no empty folder left
        folder.mkdir(parents=True, exist_ok=True)
    plant = robot if plant is None else plant
    controller = design.controller(rate_hz, saturate=saturate)
    if plant_fmu is None:
        path = folder / f"{plant.name}.fmu"
        if say is not None:
            say(f"plant FMU {path}")
        key = ("plant", plant.description.digest(), plant.motor_model, str(path.resolve()))
        plant_path = _cached_build(key, path, lambda: export_fmu(plant, path, step=controller.dt,
                                                                 motor_model=plant.motor_model))
    else:
        plant_path = _existing(plant_fmu, "plant_fmu")
    ctrl: Controller | Path = controller
    if controller_fmu:
        spec = controller_spec(controller, robot)
        cpath = folder / f"{spec.model_identifier}.fmu"
        if say is not None:
            say(f"controller FMU {cpath}")
        key = ("controller", robot.description.digest(), robot.motor_model, spec.model_identifier,
               spec.p_start.tobytes(), spec.step, str(cpath.resolve()))
        ctrl = _cached_build(key, cpath, lambda: build_fmu(spec, cpath))
    if say is not None:
        say(f"closed loop: {design.kind} at {controller.rate_hz:g} Hz through {Path(plant_path).name}"
            + (f" and {Path(ctrl).name}" if controller_fmu else " (Python controller)"))
    return run_closed_loop(plant_path, ctrl, trajectory, plant=plant, rate_hz=controller.rate_hz, t_final=t_final,
                           progress=progress)
