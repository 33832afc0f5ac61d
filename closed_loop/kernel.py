"""The compiled closed loop: one C call runs a whole :func:`~closed_loop.simulate.simulate_tracking`.

One library per (robot, motor model, controller kind), built by the one pipeline
(:func:`model.codegen.build_library`) and cached on disk: the plant's step functions
(:mod:`model.plant`, built with ``link_mass_scale``: the link masses and inertias
times a last parameter), the plant's fixed-step rule ``model/dynamics/c/plant_step.c``
(the one the Python loop and the FMU run: RK4 sub-steps, stick-slip friction events
located by bisection, the settle loop), the law's
:func:`~control_design.laws.controller_function` (the same Function the Python
controller runs) and the handwritten loop ``closed_loop/c/kernel.c``. Everything a
sweep varies is an input, so one compiled kernel serves every case: the plant
parameter vector ``p`` (payload, friction, gravity), the link-mass scale, the
controller's parameters (gains, limits, the model's ``p``), and the
:class:`~closed_loop.schedule.Schedule` (control rate: periods and sub-steps, the
reference samples) with an optional one-period delay (as
:class:`~closed_loop.delay.OnePeriodDelay`).

The loop does the Python loop's arithmetic (the same rule in C, the same sub-steps,
the schedule's reference arrays, ``-ffp-contract=off``), so the samples agree with
:func:`~closed_loop.simulate.simulate_tracking` to rounding (the tests hold them to
1e-12; the only difference is the link-mass scale, a multiplication by 1.0 where the
Python loop's plant folds the masses into constants). Metrics are accumulated in C
during the run.

Drive trains (:mod:`model.drive_train`: elastic gears, current loops, friction peaks) are the
same plant with more states: the kernel carries the plant's whole state (``nx``, ``nz``
friction modes), starts it as the Python loop does (the static equilibrium of
:func:`~model.drive_train.equilibrium_state` under the plant's gravity), and a motor-side
law, the P-PI cascade (kind ``'cascade'``, :func:`~control_design.cascade.cascade_law`),
reads the rotor angles and speeds, its integrators started holding the arm
(:meth:`~control_design.cascade.CascadeController.holding_state`); on the Manutec r3 the
samples agree with the Python loop's to rounding (``tests/closed_loop/test_kernel_drive_trains.py``).
A plant without Coulomb friction (nothing stuck) skips the event indicators altogether: its
cost is that of the plain RK4 loop.
"""

from __future__ import annotations

import ctypes
import dataclasses
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping
import numpy as np

from control_design.cascade import CascadeController, cascade_fingerprint, cascade_law
from control_design.controllers import LawController
from control_design.reference import Reference
from control_design.errors import DesignSpecError
from control_design.laws import control_law, controller_function, law_fingerprint
from model.codegen import PLANT_STEP_SOURCES, CompiledLibrary, Progress, build_library
from model.compiled_plant import PLANT_STATUS, plant_entry_points
from model.dynamics.core import source_fingerprint
from model.dynamics.parameters import DynamicsParameters
from model.dynamics.singular import singular_dynamics_error
from model.errors import NumericalError
from model.drive_train import drive_layout, equilibrium_state, has_drive_trains
from model.plant import STEP_FUNCTIONS, build_plant
from model.robot import Robot
from model.errors import ToolchainError

from .result import SATURATION_MARGIN, TrackingResult
from .schedule import Schedule

__all__ = ["KERNEL_SOURCE", "ClosedLoopKernel", "KernelRun", "closed_loop_kernel"]

#: The handwritten loop around the generated functions.
KERNEL_SOURCE = Path(__file__).resolve().parent / "c" / "kernel.c"
_N_METRICS = 5

_P = ctypes.c_void_p
_ARGTYPES = [_P, _P, _P, _P, _P, ctypes.c_double, *([_P] * 16)]
_PLANT_PREFIX = "plant_"


@dataclass(frozen=True)
class KernelRun:
    """The metrics of one compiled closed-loop run (per joint, as :class:`~closed_loop.result.TrackingMetrics`).

    Attributes
    ----------
    max_error, rms_error
        (n,) max and RMS ``|q_ref - q|`` over the control samples, rad or m.
    peak_motor_torque, peak_motor_velocity
        (n,) max ``|tau_m|`` (N m) and ``|qd_m|`` (rad/s: ``G qd``, or an elastic gear's rotor speed).
    saturated_fraction
        (n,) fraction of the samples with ``|tau_m|`` at its limit.
    diverged
        True if the state became non-finite; the run stopped there (metrics up to it).
    t_end
        Time of the last sample reached, s.
    result
        The samples as a :class:`~closed_loop.result.TrackingResult` when recorded (and not diverged), else None.
    """

    max_error: np.ndarray
    rms_error: np.ndarray
    peak_motor_torque: np.ndarray
    peak_motor_velocity: np.ndarray
    saturated_fraction: np.ndarray
    diverged: bool
    t_end: float
    result: TrackingResult | None = None


class ClosedLoopKernel:
    """The compiled closed loop of one robot (as the controller's model) and one controller kind.

    Parameters
    ----------
    robot
        The controller's robot model; the plant is this robot with other parameters and link masses.
    kind
        The controller kind (:data:`~control_design.laws.LAW_KINDS`, or ``'cascade'``: the P-PI cascade).
    progress
        Receives the build's :class:`~model.codegen.BuildEvent` (a cache hit is one event).
    """

    def __init__(self, robot: Robot, kind: str, progress: Progress | None = None) -> None:
        self.robot = robot
        self.kind = kind
        n = robot.n
        desc = robot.description
        self.layout = drive_layout(desc)
        self.drive_trains = has_drive_trains(desc)
        self.law = cascade_law(n) if kind == "cascade" else control_law(kind, n, robot)
        #: The law reads the rotor angles and speeds (q_m, qd_m) in place of q, qd.
        self.motor_side = kind == "cascade"
        self.function = controller_function(self.law)
        self.controller_name = self.function.name()
        key = (f"closed-loop kernel|{kind}|{n}|{law_fingerprint()}|{desc.digest()}|{robot.motor_model}"
               f"|{','.join(STEP_FUNCTIONS)}|{source_fingerprint()}")
        if kind == "cascade":
            key += f"|{cascade_fingerprint()}"
        stem = f"kernel-{desc.identifier}-{robot.motor_model}-{kind}"
        self.library: CompiledLibrary
        self.library, self.build_info = build_library(
            stem, key, lambda: [*build_plant(robot, link_mass_scale=True).step_functions(_PLANT_PREFIX), self.function],
            progress=progress, extra_sources=(KERNEL_SOURCE, *PLANT_STEP_SOURCES))
        fn = self.library.symbol("mw_closed_loop")
        fn.restype = ctypes.c_int
        fn.argtypes = _ARGTYPES
        self._fn = fn
        self._plant = plant_entry_points(self.library, _PLANT_PREFIX)
        self._ctrl = self.library.entry_points(self.controller_name)
        f = self.function
        self._in_names = [f.name_in(i) for i in range(f.n_in())]
        self._state_index = self._in_names.index("z") if "z" in self._in_names else -1
        rotor = np.full(n, -1, dtype=np.int64)
        rotor[list(self.layout.elastic)] = np.arange(self.layout.ne)
        self._rotor = rotor

    def run(self, controller: "LawController | CascadeController", schedule: Schedule,
            plant_parameters: DynamicsParameters, *, link_mass_scale: float = 1.0, delay: bool = False, record: bool = False,
            values: Mapping[str, Any] | None = None) -> KernelRun:
        """Run ``controller`` on the plant along ``schedule`` in one C call.

        Parameters
        ----------
        controller
            A controller of this kernel's kind and robot (e.g. ``design.controller(rate)``, or
            :func:`~control_design.cascade.cascade_from_robot` for ``'cascade'``); its rate must be
            the schedule's.
        schedule
            The run's instants, references, start state and sub-steps (:meth:`Schedule.build`).
        plant_parameters
            The plant's parameter vector (payload, friction, gravity) on this robot's layout.
        link_mass_scale
            Plant link masses and inertias = this times the model's (> 0).
        delay
            Torques reach the plant one period late (:class:`~closed_loop.delay.OnePeriodDelay`).
        record
            Also return the samples (:attr:`KernelRun.result`).
        values
            Parameter inputs of the law that replace ``controller``'s, by name (e.g. the ``Kp``, ``Kd``, ``Ki``
            of another design at the same rate: a sweep over gains needs no new controller per case).

        Raises
        ------
        control_design.errors.DesignSpecError
            A controller of another kind or joint count, a rate that is not the schedule's, a bad scale.
        model.errors.SingularDynamicsError
            B(q) is singular at a state the run reached (naming the joint, ``q`` and the time).
        """
        n = self.robot.n
        if getattr(controller, "kind", None) != self.kind or controller.n != n:
            raise DesignSpecError(f"expected a {self.kind!r} controller of {n} joints, "
                                  f"got {getattr(controller, 'kind', type(controller).__name__)!r}",
                                  parameter="controller")
        if abs(controller.dt - schedule.dt) > 1e-15 * schedule.dt:
            raise DesignSpecError(f"its period {controller.dt:g} s is not the schedule's {schedule.dt:g} s",
                                  parameter="controller")
        if not (np.isfinite(link_mass_scale) and link_mass_scale > 0):
            raise DesignSpecError(f"expected a factor > 0, got {link_mass_scale!r}", parameter="link_mass_scale")
        p = np.append(self.robot.dynamics.check_parameters(plant_parameters).vector, float(link_mass_scale))
        own = controller.parameter_values()
        if values:
            unknown = [k for k in values if k not in own]
            if unknown:
                raise DesignSpecError(f"{unknown[0]!r} is not a parameter of the {self.kind!r} law "
                                      f"(expected one of {', '.join(own)})", parameter="values")
            own.update({k: np.broadcast_to(np.asarray(v, dtype=np.float64), own[k].shape) for k, v in values.items()})
        values = own
        inputs: list[np.ndarray | None] = []
        for i, name in enumerate(self._in_names):
            if i < len(self.law.signals) or i == self._state_index:
                inputs.append(None)
            else:
                inputs.append(np.ascontiguousarray(values[name], dtype=np.float64))
        ctrl_in = (ctypes.c_void_p * len(inputs))(*[None if a is None else a.ctypes.data for a in inputs])
        steps = schedule.steps
        lay = self.layout
        dims = np.array([n, len(inputs), len(self.law.signals), self._state_index, int(delay), schedule.substeps,
                         steps, lay.nx, lay.nz, int(self.motor_side)], dtype=np.int64)
        G = np.ascontiguousarray(controller.G, dtype=np.float64)
        tau_sat = None if controller.tau_m_max is None else np.ascontiguousarray(controller.tau_m_max * SATURATION_MARGIN)
        refs = [np.ascontiguousarray(a, dtype=np.float64) for a in (schedule.q_ref, schedule.qd_ref, schedule.qdd_ref)]
        x0, z0 = self._start(controller, schedule, plant_parameters, float(link_mass_scale))
        metrics = np.zeros((_N_METRICS, n))
        fault = np.zeros(1 + lay.nx)
        traj = [np.empty((steps + 1, n)) for _ in range(3)] if record else [None, None, None]
        qdm = np.empty((steps + 1, n)) if record and lay.ne else None
        last = ctypes.c_longlong(0)

        def ptr(a: np.ndarray | None) -> int | None:
            return None if a is None else a.ctypes.data

        status = self._fn(ctypes.cast(self._plant, _P), self._ctrl[0], self._ctrl[1], ptr(dims), ctrl_in,
                          float(schedule.dt), ptr(p), ptr(G), ptr(tau_sat), *(ptr(a) for a in refs),
                          ptr(x0), ptr(z0), ptr(self._rotor) if lay.ne else None, ptr(metrics),
                          *(ptr(a) for a in traj), ptr(qdm), ctypes.byref(last), ptr(fault))
        # a failure in the period from t_k leaves last = k + 1 (the loop's counter moved on), one at the start 0
        t_fail = float(schedule.t[min(max(int(last.value) - 1, 0), steps)])
        if status == 2:
            raise singular_dynamics_error(self.robot.description, int(fault[0]) - 1, fault[1:1 + n],
                                          f"in the compiled closed loop, in the period from t = {t_fail:g} s")
        if status <= -10:
            raise NumericalError(f"closed-loop kernel {self.kind!r}: the plant's fixed-step rule failed: "
                                 f"{PLANT_STATUS.get(status + 10, status + 10)} in the period from t = {t_fail:g} s")
        if status < 0:
            raise (NumericalError if status == -4 else ToolchainError)(  # -4: an evaluation of the generated code failed
                f"closed-loop kernel {self.kind!r}: failed with status {status}")
        k = int(last.value)
        result = None
        if record and status == 0:
            result = schedule.result(self.robot, self.kind, *traj, controller.tau_m_max, 0.0)
            if qdm is not None:
                result = dataclasses.replace(result, rotor_qd=qdm)
        return KernelRun(max_error=metrics[0].copy(), rms_error=metrics[1].copy(), peak_motor_torque=metrics[2].copy(),
                         peak_motor_velocity=metrics[3].copy(), saturated_fraction=metrics[4].copy(),
                         diverged=status == 1, t_end=float(schedule.t[min(k, steps)]), result=result)


    def plant_gravity(self, q: np.ndarray, plant_parameters: DynamicsParameters, link_mass_scale: float = 1.0
                      ) -> np.ndarray:
        """(n,) the plant's gravity torque at ``q`` (joint side, N m or N) with its link masses scaled.

        Gravity is linear in each body's mass and first moment, and the scale multiplies both for the links
        and neither for the payload: ``g_s = g_payload + s g_links`` with ``g_links`` the plant without its
        payload and ``g_payload = g - g_links``. At ``s = 1`` it is ``gravload(q, p)`` itself.
        """
        g = self.robot.gravload(q, plant_parameters)
        if link_mass_scale == 1.0:
            return g
        links = self.robot.gravload(q, plant_parameters.with_payload(0.0, [0.0, 0.0, 0.0]))
        return (g - links) + link_mass_scale * links

    def _start(self, controller: Any, schedule: Schedule, plant_parameters: DynamicsParameters,
               link_mass_scale: float) -> tuple[np.ndarray, np.ndarray | None]:
        """The start state (nx,) and the controller state's start (n,) or None (zero), as the Python loop's."""
        n, lay = self.robot.n, self.layout
        x0 = np.concatenate([schedule.q0, schedule.qd0])
        if not (self.drive_trains or self.motor_side):
            return np.ascontiguousarray(x0), None
        g = self.plant_gravity(schedule.q0, plant_parameters, link_mass_scale)
        if lay.nx > 2 * n:  # as simulate_tracking: the static equilibrium, then the start speeds
            x0 = equilibrium_state(self.robot.description, schedule.q0, g)
            x0[n:2 * n] = schedule.qd0
        z0 = None
        if self.motor_side:
            G = np.asarray(controller.G, dtype=float)
            qm, qdm = lay.motor_state(x0, G)
            ref = Reference(schedule.q_ref[0], schedule.qd_ref[0], schedule.qdd_ref[0])
            z0 = np.ascontiguousarray(controller.holding_state(qm, qdm, ref, g / G), dtype=np.float64)
        return np.ascontiguousarray(x0, dtype=np.float64), z0


_KERNELS: dict[tuple[str, str, str], ClosedLoopKernel] = {}
_KERNELS_LOCK = threading.Lock()


def closed_loop_kernel(robot: Robot, kind: str, progress: Progress | None = None) -> ClosedLoopKernel:
    """The :class:`ClosedLoopKernel` of ``robot`` and ``kind``, built (or loaded from the disk cache) once per process."""
    key = (robot.description.digest(), robot.motor_model, kind)
    with _KERNELS_LOCK:
        if key not in _KERNELS:
            _KERNELS[key] = ClosedLoopKernel(robot, kind, progress)
        kernel = _KERNELS[key]
    if kernel.robot is not robot:  # the same physical robot: the kernel is valid, it must use the caller's object
        kernel = _rebind(kernel, robot)
    return kernel


def _rebind(kernel: ClosedLoopKernel, robot: Robot) -> ClosedLoopKernel:
    other = object.__new__(ClosedLoopKernel)
    other.__dict__.update(kernel.__dict__)
    other.robot = robot
    return other
