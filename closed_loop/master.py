"""Closed-loop co-simulation masters: a controller driving the plant FMU at the control rate.

The timing is the one :class:`~closed_loop.schedule.Schedule` of every loop, that of
:func:`closed_loop.simulate.simulate_tracking`, so the results compare sample by sample: at ``t_k = t0 + k h`` (integer k, never a
running sum; ``h = 1 / rate_hz``) the controller reads the plant state and the
reference ``trajectory.path`` at ``t_k``; its motor torques are held over
``[t_k, t_k+1]`` (zero-order hold) while the plant FMU takes one
``fmi2DoStep(t_k, h)``, integrated inside the FMU by RK4 in ``substeps`` equal
sub-steps (its ``internal_step`` is set to ``h / substeps``, the same sub-step
as the Python loop's).

* :func:`run_closed_loop` - FMPy's low-level ``FMU2Slave`` (Gauss-Seidel order:
  plant outputs -> controller -> plant inputs within the same instant). The
  controller is a Python :class:`~control_design.controllers.Controller` or a
  controller FMU (:mod:`closed_loop.controller_fmu`), whose torques go to the plant
  without leaving C buffers.
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
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from control_design.controllers import Controller
from control_design.design import RobotDesign
from control_design.errors import SimulationDivergedError
from control_design.laws import NO_LIMIT
from control_design.reference import Reference
from fmu.archive import check_fmu_archive
from fmu.build import build_fmu, export_fmu
from fmu.cosim import CosimError, add_slave, last_error
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


class _Instance:
    """One FMPy Co-Simulation instance with value references resolved once and ctypes buffers."""

    def __init__(self, path: Path, name: str, workdir: str) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        check_fmu_archive(path)  # a stranger's FMU: refused before anything is extracted
        self.md = read_model_description(str(path))
        if self.md.coSimulation is None:
            raise InputError(f"{path.name} has no Co-Simulation interface", parameter=name)
        unzip = extract(str(path), unzipdir=os.path.join(workdir, name))
        self.vr = {v.name: int(v.valueReference) for v in self.md.modelVariables}
        self.name = name
        self.path = path
        self.slave = FMU2Slave(guid=self.md.guid, unzipDirectory=unzip,
                               modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.live = False

    def refs(self, names: Sequence[str]) -> Any:
        from fmpy.fmi2 import fmi2ValueReference

        missing = [nm for nm in names if nm not in self.vr]
        if missing:
            raise InputError(f"no variables {missing} in {self.path.name}", parameter=self.name)
        return (fmi2ValueReference * len(names))(*[self.vr[nm] for nm in names])

    def start(self, t0: float, values: Mapping[str, float]) -> None:
        """Instantiate, set ``values`` in initialization mode, exit it."""
        s = self.slave
        s.instantiate()
        self.live = True
        s.setupExperiment(startTime=t0)
        s.enterInitializationMode()
        if values:
            names = list(values)
            s.setReal(list(self.refs(names)), [float(values[nm]) for nm in names])
        s.exitInitializationMode()

    def get(self, names: Sequence[str]) -> np.ndarray:
        return np.array(self.slave.getReal(list(self.refs(names))))

    def close(self) -> None:
        """Terminate and free the instance (its library with it); only unload the library if never instantiated."""
        from fmpy.fmi1 import FMICallException

        if not self.live:
            self.slave.freeLibrary()
            return
        self.live = False
        try:
            self.slave.terminate()
        except FMICallException:
            pass  # an instance in error mode refuses fmi2Terminate; it is freed all the same
        finally:
            self.slave.freeInstance()


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
    """Run a controller on the plant FMU along ``trajectory`` with FMPy's ``FMU2Slave``.

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
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import fmi2Real

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

    with tempfile.TemporaryDirectory(prefix="mw_master_") as work:
        plant_inst: _Instance | None = None
        ctrl_inst: _Instance | None = None
        try:
            plant_inst = _Instance(plant_path, "plant", work)
            ctrl_inst = None if ctrl_path is None else _Instance(ctrl_path, "controller", work)
            if ctrl_inst is not None:
                step = ctrl_inst.md.defaultExperiment.stepSize if ctrl_inst.md.defaultExperiment else None
                dt = 1.0 / rate_hz if rate_hz is not None else float(step) if step else 0.0
                if not dt > 0:
                    raise InputError("expected a control rate (the controller FMU has no default step)",
                                     parameter="rate_hz")
            rate = rate_hz if rate_hz is not None else py_ctrl.rate_hz if py_ctrl is not None else None
            sched = Schedule.build(plant_robot, trajectory, dt, rate_hz=rate, t_final=t_final, q0=q0, qd0=qd0,
                                   substeps=substeps)
            x_names = [f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)]
            tau_names = [f"tau_m[{i + 1}]" for i in range(n)]
            x_vr, tau_vr = plant_inst.refs(x_names), plant_inst.refs(tau_names)
            plant_inst.start(float(sched.t[0]), _plant_start_values(plant_robot, sched))
            x_buf = (fmi2Real * (2 * n))()
            x_np = np.ctypeslib.as_array(x_buf)
            tau_buf = (fmi2Real * n)()
            tau_np = np.ctypeslib.as_array(tau_buf)

            if ctrl_inst is not None:
                groups = ["q_ref", "qd_ref"] + (["qdd_ref"] if "qdd_ref[1]" in ctrl_inst.vr else [])
                ref_names = [f"{g}[{i + 1}]" for g in groups for i in range(n)]
                u_vr = ctrl_inst.refs(ref_names + x_names)
                y_vr = ctrl_inst.refs(tau_names)
                ctrl_inst.start(float(sched.t[0]), dict(controller_parameters or {}))
                tau_m_max = _limits(ctrl_inst.get([f"tau_m_max[{i + 1}]" for i in range(n)]))
                columns = {"q_ref": sched.q_ref, "qd_ref": sched.qd_ref, "qdd_ref": sched.qdd_ref}
                R = np.ascontiguousarray(np.hstack([columns[g] for g in groups]))
                m = R.shape[1]
                u_buf = (fmi2Real * (m + 2 * n))()
                u_np = np.ctypeslib.as_array(u_buf)
            else:
                assert py_ctrl is not None
                tau_m_max = None if py_ctrl.tau_m_max is None else py_ctrl.tau_m_max.copy()

            steps, t, h = sched.steps, sched.t, sched.dt
            Q = np.empty((steps + 1, n))
            QD = np.empty((steps + 1, n))
            TAU = np.empty((steps + 1, n))
            p_comp = plant_inst.slave.component
            p_get, p_set, p_step = (plant_inst.slave.fmi2GetReal, plant_inst.slave.fmi2SetReal,
                                    plant_inst.slave.fmi2DoStep)
            n2 = 2 * n

            def plant_step(k: int) -> None:
                """Step the plant over ``[t_k, t_k+1]`` with the torques in ``tau_buf``; report the progress."""
                tk = float(t[k])
                try:
                    p_set(p_comp, tau_vr, n, tau_buf)  # refuses non-finite torques
                    p_step(p_comp, tk, h, 1)           # discards a step whose state is not finite
                except FMICallException as exc:
                    raise SimulationDivergedError(
                        f"simulation: the plant FMU rejected the step at t = {tk:g} s ({exc}): the closed loop "
                        f"diverged (controller {kind!r})") from exc
                if progress is not None:
                    progress((k + 1) / steps, float(t[k + 1]), float(t[-1]))

            start = time.perf_counter()
            if ctrl_inst is not None:
                c_comp = ctrl_inst.slave.component
                c_get, c_set, c_step = (ctrl_inst.slave.fmi2GetReal, ctrl_inst.slave.fmi2SetReal,
                                        ctrl_inst.slave.fmi2DoStep)
                mu = m + n2
                for k in range(steps + 1):
                    p_get(p_comp, x_vr, n2, x_buf)
                    Q[k], QD[k] = x_np[:n], x_np[n:]
                    u_np[:m] = R[k]
                    u_np[m:] = x_np
                    c_set(c_comp, u_vr, mu, u_buf)
                    c_get(c_comp, y_vr, n, tau_buf)
                    TAU[k] = tau_np
                    if k == steps:
                        break
                    c_step(c_comp, float(t[k]), h, 1)
                    plant_step(k)
            else:
                assert py_ctrl is not None
                py_ctrl.reset()
                Qr, QDr, QDDr = sched.q_ref, sched.qd_ref, sched.qdd_ref
                for k in range(steps + 1):
                    p_get(p_comp, x_vr, n2, x_buf)
                    q, qd = x_np[:n].copy(), x_np[n:].copy()
                    Q[k], QD[k] = q, qd
                    tau_m = py_ctrl.update(float(t[k]), q, qd, Reference(Qr[k], QDr[k], QDDr[k]))
                    TAU[k] = tau_m
                    if k == steps:
                        break
                    tau_np[:] = tau_m
                    plant_step(k)
            wall = time.perf_counter() - start
        finally:
            for inst in (ctrl_inst, plant_inst):
                if inst is not None:
                    inst.close()
    assert sched is not None
    return sched.result(plant_robot, kind, Q, QD, TAU, tau_m_max, wall)


# ------------------------------------------------- Model Exchange master (CVode)

class _HeldInputs:
    """The ``input`` of FMPy's CVode solver: the torques are set once per control period, nothing in between."""

    def apply(self, time: float, continuous: bool = True, discrete: bool = True, after_event: bool = False) -> None:
        return None


def _event_iteration(fmu: Any) -> None:
    """``fmi2NewDiscreteStates`` until nothing changes (the friction modes settle in the FMU)."""
    needed, terminate = True, False
    while needed and not terminate:
        needed, terminate, *_ = fmu.newDiscreteStates()
    if terminate:
        raise SimulationDivergedError("simulation: the plant FMU asked to terminate at an event")


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
    ValueError
        Missing FMU, an FMU without Model Exchange, joint counts that differ.
    control_design.errors.SimulationDivergedError
        The FMU refused a call (its state became non-finite) or CVode failed.
    """
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Model
    from fmpy.sundials import CVodeSolver

    plant_path = _existing(plant_fmu, "plant_fmu")
    plant_robot = _plant_robot(plant_path, plant)
    n = plant_robot.n
    if controller.n != n:
        raise InputError(f"expected {n} joints like plant {plant_robot.name!r}, got {controller.n}",
                         parameter="controller")
    sched = Schedule.build(plant_robot, trajectory, controller.dt, rate_hz=controller.rate_hz, t_final=t_final,
                           q0=q0, qd0=qd0, substeps=1)
    check_fmu_archive(plant_path)
    md = read_model_description(str(plant_path))
    if md.modelExchange is None:
        raise InputError(f"plant_fmu: {plant_path.name} has no Model Exchange interface")
    nx, nz = md.numberOfContinuousStates, md.numberOfEventIndicators
    vr = {v.name: int(v.valueReference) for v in md.modelVariables}
    x_vr = [vr[f"q[{i + 1}]"] for i in range(n)] + [vr[f"qd[{i + 1}]"] for i in range(n)]
    tau_vr = [vr[f"tau_m[{i + 1}]"] for i in range(n)]
    start_values = {k: v for k, v in _plant_start_values(plant_robot, sched).items() if k != "internal_step"}
    steps, t = sched.steps, sched.t
    Q, QD, TAU = (np.empty((steps + 1, n)) for _ in range(3))
    with tempfile.TemporaryDirectory(prefix="mw_master_me_") as work:
        fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(plant_path), unzipdir=work),
                        modelIdentifier=md.modelExchange.modelIdentifier, instanceName="plant")
        fmu.instantiate()
        try:
            fmu.setupExperiment(startTime=float(t[0]))
            fmu.enterInitializationMode()
            fmu.setReal([vr[k] for k in start_values], [float(v) for v in start_values.values()])
            fmu.exitInitializationMode()
            _event_iteration(fmu)
            fmu.enterContinuousTimeMode()
            solver = CVodeSolver(nx=nx, nz=nz, get_x=fmu.getContinuousStates, set_x=fmu.setContinuousStates,
                                 get_dx=fmu.getDerivatives, get_z=fmu.getEventIndicators,
                                 get_nominals=fmu.getNominalsOfContinuousStates, set_time=fmu.setTime,
                                 input=_HeldInputs(), startTime=float(t[0]), maxStep=sched.dt,
                                 relativeTolerance=relative_tolerance, maxNumSteps=100_000)
            controller.reset()
            Qr, QDr, QDDr = sched.q_ref, sched.qd_ref, sched.qdd_ref
            start = time.perf_counter()
            for k in range(steps + 1):
                x = np.array(fmu.getReal(x_vr))
                Q[k], QD[k] = x[:n], x[n:]
                tau_m = controller.update(float(t[k]), x[:n].copy(), x[n:].copy(), Reference(Qr[k], QDr[k], QDDr[k]))
                TAU[k] = tau_m
                if k == steps:
                    break
                fmu.enterEventMode()
                fmu.setReal(tau_vr, [float(v) for v in tau_m])
                _event_iteration(fmu)  # the friction modes follow the new torques
                fmu.enterContinuousTimeMode()
                solver.reset(float(t[k]))
                tk, t_next = float(t[k]), float(t[k + 1])
                while tk < t_next and not math.isclose(tk, t_next, rel_tol=1e-12, abs_tol=1e-15):
                    state_event, _, tk = solver.step(tk, t_next)
                    fmu.setTime(tk)
                    step_event, terminate = fmu.completedIntegratorStep()
                    if terminate:
                        raise SimulationDivergedError(f"simulation: the plant FMU asked to terminate at t = {tk:g} s")
                    if state_event or step_event:
                        fmu.enterEventMode()
                        _event_iteration(fmu)  # a joint sticks or breaks loose
                        fmu.enterContinuousTimeMode()
                        solver.reset(tk)
                fmu.setTime(t_next)
                if progress is not None:
                    progress((k + 1) / steps, t_next, float(t[-1]))
            wall = time.perf_counter() - start
            del solver
        except (FMICallException, RuntimeError) as exc:
            raise SimulationDivergedError(f"simulation: the Model Exchange closed loop failed ({exc}) "
                                          f"(controller {controller.kind!r})") from exc
        finally:
            try:
                fmu.terminate()
            except FMICallException:
                pass  # an instance in error mode refuses fmi2Terminate; it is freed all the same
            fmu.freeInstance()
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
        from fmpy import read_model_description

        de = read_model_description(str(ctrl_path)).defaultExperiment
        if de is None or not de.stepSize:
            raise InputError("expected a control rate (the controller FMU has no default step)", parameter="rate_hz")
        dt = float(de.stepSize)
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
