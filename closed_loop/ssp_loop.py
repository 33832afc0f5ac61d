"""The closed loop as an SSP (:mod:`fmu.ssp`): plant FMU + controller FMU with its reference, parameter variants.

:func:`export_loop_ssp` writes the plant FMU (its start state the trajectory's start), the controller FMU
of :func:`closed_loop.reference_controller.reference_controller_spec` (the law with the reference inside,
inputs ``q``, ``qd``, output ``tau_m``), the connections plant ``q[i]``, ``qd[i]`` -> controller and
controller ``tau_m[i]`` -> plant, and one plant parameter set per variant (all the plant's dynamics
parameters and ``internal_step = h / substeps``, the sub-steps of :func:`~closed_loop.schedule.default_substeps`
for that variant's plant).

Both importers step Jacobi (every FMU, then the connections), so the torque computed at ``t_k`` drives the
plant over ``[t_k+1, t_k+2]``; they differ at the start:

* libcosim moves the connected values at its initialisation: the plant's first period gets the law at
  ``t_0`` on the true start state, the loop of :class:`~closed_loop.delay.OnePeriodDelay`
  (:func:`compiled_reference` with ``importer="libcosim"``: the compiled kernel, ``delay=True``);
* FMPy starts every connector at 0.0: the plant's first period gets no torque, its second the law at
  ``t_0`` evaluated on ``q = qd = 0`` (:class:`FmpyStart`, run on the compiled plant by
  :func:`~closed_loop.simulate.simulate_tracking`).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from control_design.controllers import Controller
from control_design.reference import Reference
from fmu.build import build_fmu, export_fmu
from fmu.ssp import NOMINAL, SspComponent, SspConnection, write_ssp
from model.dynamics.parameters import DynamicsParameters
from model.errors import InputError
from model.robot import Robot
from model.trajectory import Trajectory

from .kernel import closed_loop_kernel
from .reference_controller import reference_controller_spec
from .result import TrackingResult
from .schedule import Schedule
from .simulate import simulate_tracking

__all__ = ["LoopVariant", "FmpyStart", "export_loop_ssp", "variant_plant", "compiled_reference", "IMPORTERS"]

#: The importers :func:`compiled_reference` knows the start of.
IMPORTERS = ("libcosim", "fmpy")

Say = Callable[[str], None]


@dataclass(frozen=True)
class LoopVariant:
    """A plant parameter set: its name and the plant parameters it changes (name -> value, e.g. ``payload_mass``)."""

    name: str
    values: Mapping[str, float]


def variant_plant(robot: Robot, values: Mapping[str, float]) -> Robot:
    """``robot`` with the dynamics parameters ``values`` (names of ``robot.parameters.as_dict()``) changed.

    Raises
    ------
    model.errors.InputError
        An unknown parameter name (the known ones listed), a value the parameters refuse (e.g. a negative mass).
    """
    own = robot.parameters.as_dict()
    unknown = [k for k in values if k not in own]
    if unknown:
        raise InputError(f"no plant parameter {unknown[0]!r}; expected one of {', '.join(own)}", parameter="variant")
    own.update({k: float(v) for k, v in values.items()})
    params = DynamicsParameters(robot.parameters.layout, np.array([own[k] for k in robot.parameters.as_dict()]))
    return robot.with_parameters(params)


class FmpyStart(Controller):
    """``inner`` as FMPy's ``simulate_ssp`` runs a direct-feedthrough controller FMU: one period late, no torque
    over the first period, and at ``t_0`` the law evaluated on ``q = qd = 0`` (FMPy's connector start)."""

    def __init__(self, inner: Controller) -> None:
        super().__init__(inner.n, inner.rate_hz, inner.G, inner.tau_m_max)
        self.inner = inner
        self.kind = inner.kind
        self._held: np.ndarray | None = None

    def reset(self) -> None:
        self.inner.reset()
        self._held = None

    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        if self._held is None:
            self._held = self.inner.update(t, np.zeros(self.n), np.zeros(self.n), ref)
            return np.zeros(self.n)
        out, self._held = self._held, self.inner.update(t, q, qd, ref)
        return out


def compiled_reference(robot: Robot, plant: Robot, controller: Controller, trajectory: Trajectory,
                       importer: str) -> TrackingResult:
    """The compiled closed loop on the schedule ``importer`` runs the SSP with (module docstring): ``controller``
    (designed on ``robot``) on ``plant``; 'libcosim' by the compiled kernel with its one-period delay, 'fmpy' by
    :func:`simulate_tracking` (compiled plant) with :class:`FmpyStart`."""
    if importer not in IMPORTERS:
        raise InputError(f"expected one of {IMPORTERS}, got {importer!r}", parameter="importer")
    sched = Schedule.build(plant, trajectory, controller.dt, rate_hz=controller.rate_hz)
    if importer == "fmpy":
        return simulate_tracking(plant, FmpyStart(controller), trajectory, substeps=sched.substeps)
    run = closed_loop_kernel(robot, controller.kind).run(controller, sched, plant.parameters, delay=True,
                                                         record=True)
    if run.result is None:
        raise InputError(f"the compiled closed loop diverged at t = {run.t_end:g} s", parameter="controller")
    return run.result


def export_loop_ssp(robot: Robot, controller: Controller, trajectory: Trajectory, path: str | os.PathLike[str], *,
                    variants: tuple[LoopVariant, ...] = (), say: Say | None = None) -> Path:
    """Write ``path`` (``.ssp``): ``controller`` (designed on ``robot``) driving ``robot``'s plant FMU along
    ``trajectory``, with the nominal plant parameter set and one per ``variants``; from the trajectory's start
    to its end at the controller's rate.

    Raises
    ------
    model.errors.InputError
        A variant named :data:`fmu.ssp.NOMINAL` or twice, an unknown plant parameter, a trajectory that is not
        a joint path.
    fmu.build.FmuBuildError
        The generated C did not compile.
    """
    names = [v.name for v in variants]
    if NOMINAL in names or len(set(names)) != len(names):
        raise InputError(f"expected distinct variant names other than {NOMINAL!r}, got {names}", parameter="variant")
    n = robot.n
    dt = controller.dt
    sched = Schedule.build(robot, trajectory, dt, rate_hz=controller.rate_hz)
    plant_sets: dict[str, dict[str, float]] = {}
    for name, values in [(NOMINAL, {})] + [(v.name, dict(v.values)) for v in variants]:
        plant = variant_plant(robot, values)
        sub = Schedule.build(plant, trajectory, dt, rate_hz=controller.rate_hz).substeps
        plant_sets[name] = {**plant.parameters.as_dict(), "internal_step": dt / sub}
    x = [f"q[{i + 1}]" for i in range(n)] + [f"qd[{i + 1}]" for i in range(n)]
    tau = [f"tau_m[{i + 1}]" for i in range(n)]
    with tempfile.TemporaryDirectory(prefix="mw_ssp_") as work:
        plant_fmu = Path(work) / "plant.fmu"
        if say is not None:
            say(f"plant FMU of {robot.name}")
        x0 = np.concatenate([sched.q0, sched.qd0])
        if np.array_equal(_fmu_start(robot, dt), x0):
            export_fmu(robot, plant_fmu, step=dt)
        else:
            _plant_fmu_from(robot, dt, x0, plant_fmu)
        ctrl_fmu = Path(work) / "controller.fmu"
        if say is not None:
            say(f"{controller.kind} controller FMU with the reference ({trajectory.path.t_start:g} to "
                f"{trajectory.path.t_end:g} s)")
        build_fmu(reference_controller_spec(controller, robot, trajectory), ctrl_fmu)
        components = [SspComponent("plant", plant_fmu, tuple(tau), tuple(x), plant_sets),
                      SspComponent("controller", ctrl_fmu, tuple(x), tuple(tau), {})]
        connections = [SspConnection("plant", v, "controller", v) for v in x] + \
                      [SspConnection("controller", v, "plant", v) for v in tau]
        return write_ssp(path, f"{robot.name} {controller.kind} closed loop", components, connections,
                         start=float(sched.t[0]), stop=float(sched.t[-1]), step=dt)


def _fmu_start(robot: Robot, dt: float) -> np.ndarray:
    from fmu.variables import spec_from_plant
    from model.plant import build_plant

    return np.asarray(spec_from_plant(build_plant(robot), dt).x_start)


def _plant_fmu_from(robot: Robot, dt: float, x0: np.ndarray, path: Path) -> None:
    """A plant FMU starting at ``x0`` (its states' start values; no FMI-LS-REF experiment, which starts elsewhere)."""
    from fmu.variables import spec_from_plant
    from model.plant import build_plant

    build_fmu(replace(spec_from_plant(build_plant(robot), dt), x_start=np.asarray(x0, dtype=float)), path)
