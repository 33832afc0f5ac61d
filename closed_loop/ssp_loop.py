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

import json
import os
import tempfile
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from control_design.controllers import Controller
from control_design.reference import Reference
from fmu.build import build_fmu, export_fmu
from fmu.ssp import NOMINAL, SspComponent, check_set_name, SspConnection, read_resource, run_fmpy, run_libcosim, write_ssp
from model.dynamics.parameters import DynamicsParameters
from model.errors import InputError
from model.robot import Robot
from model.trajectory import Trajectory

from .delay import OnePeriodDelay
from .kernel import closed_loop_kernel
from .reference_controller import reference_controller_spec
from .result import TrackingResult
from .schedule import Schedule
from .simulate import simulate_tracking

__all__ = ["LoopVariant", "LoopSpec", "FmpyStart", "export_loop_ssp", "loop_parts", "variant_plant",
           "compiled_reference", "validate_loop_ssp", "SspCheck", "IMPORTERS", "SSP_TOLERANCE", "NOTES", "loop_reference",
           "REFERENCE_FILE"]

#: Largest joint-angle difference (rad, or m for a prismatic joint) allowed between an importer's run of the SSP and
#: the compiled closed loop on its schedule, at every control instant. Both integrate the same plant by the same
#: fixed-step RK4 in compiled C and evaluate the same law's generated C, so they differ by rounding only
#: (measured 4e-15 on the SCARA pick-and-place under 'ct' over 15 s); 1e-9 is issue 25's bound, far above it.
SSP_TOLERANCE = 1e-9
#: The archive path of the exporter's notes: how to rebuild the controller and the trajectory.
NOTES = "resources/workbench_loop.json"

#: The archive path (without its suffix, which is the file's own) of the copy of a waypoint or trajectory file.
REFERENCE_FILE = "resources/reference"

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
    try:
        params = DynamicsParameters(robot.parameters.layout, np.array([own[k] for k in robot.parameters.as_dict()]))
    except InputError as exc:
        given = ",".join(f"{k}={v:g}" for k, v in values.items())
        raise InputError(f"{given}: {exc}", parameter="variant") from None
    return robot.with_parameters(params)


@dataclass(frozen=True)
class LoopSpec:
    """What a loop SSP is exported from, besides the robot: the design (:func:`control_design.design_robot`'s
    ``kind``, ``bandwidth`` rad/s, ``damping``, ``phase_margin`` deg, ``rate_hz``), the reference as ``manip track``
    takes it (``task``, or a ``waypoints`` file, TOML or CSV, with ``segment_time`` s; or a ``trajectory`` file,
    CSV, :mod:`model.trajectory_file`) and the plant variants. In the SSP's :data:`NOTES` a file is named by its
    copy in the archive (:data:`REFERENCE_FILE` and its suffix)."""

    kind: str
    bandwidth: float | None = None
    damping: float | None = None
    phase_margin: float | None = None
    rate_hz: float | None = None
    task: str | None = None
    segment_time: float | None = None
    variants: tuple[LoopVariant, ...] = ()
    waypoints: str | None = None
    trajectory: str | None = None

    @property
    def reference_file(self) -> str | None:
        """The waypoint or trajectory file, if the reference is one."""
        return self.waypoints if self.waypoints is not None else self.trajectory

    def as_json(self) -> str:
        """The spec as JSON (the SSP's :data:`NOTES`)."""
        data = {k: getattr(self, k) for k in ("kind", "bandwidth", "damping", "phase_margin", "rate_hz", "task",
                                               "segment_time", "waypoints", "trajectory")}
        data["variants"] = [{"name": v.name, "values": dict(v.values)} for v in self.variants]
        return json.dumps(data, indent=2, allow_nan=False) + "\n"

    @classmethod
    def from_json(cls, text: str, where: str) -> "LoopSpec":
        """The spec of :meth:`as_json`; ``where`` names the file in an error."""
        try:
            data = json.loads(text)
            variants = tuple(LoopVariant(str(v["name"]), {str(k): float(x) for k, x in v["values"].items()})
                             for v in data.pop("variants"))
            return cls(variants=variants, **data)
        except (ValueError, KeyError, TypeError, AttributeError) as exc:
            raise InputError(f"{where}: not a loop description written by manip export-ssp ({exc})",
                             parameter="ssp") from None


def loop_reference(robot: Robot, spec: LoopSpec) -> Trajectory:
    """The trajectory of ``spec``, read as ``manip track`` reads its ``--task``, ``--waypoints`` or ``--trajectory``
    (:func:`~control_design.reference.task_trajectory`, :func:`~model.trajectory_file.read_trajectory`, then
    :func:`~control_design.reference.check_trajectory_limits`): the same trajectory, the same one-line errors.

    Raises
    ------
    control_design.errors.DesignSpecError
        A trajectory file with a segment time, both files.
    model.tasks.WaypointError, model.trajectory_file.TrajectoryFileError
        A bad file (naming it, the line and the joint).
    """
    from control_design.errors import DesignSpecError
    from control_design.reference import reference_trajectory

    if spec.waypoints is not None and spec.trajectory is not None:
        raise DesignSpecError("expected a waypoint file or a trajectory file, not both", parameter="trajectory")
    return reference_trajectory(robot, spec.task, spec.waypoints, spec.trajectory, spec.segment_time)


def loop_parts(robot: Robot, spec: LoopSpec) -> tuple[Controller, Trajectory]:
    """The controller (designed on ``robot``, saturated) and the trajectory (:func:`loop_reference`) of ``spec``."""
    from control_design.decentralised import DEFAULT_BANDWIDTH
    from control_design.design import DEFAULT_RATE_HZ, design_robot

    traj = loop_reference(robot, spec)
    rate = DEFAULT_RATE_HZ if spec.rate_hz is None else spec.rate_hz
    design = design_robot(robot, spec.kind, DEFAULT_BANDWIDTH if spec.bandwidth is None else spec.bandwidth,
                          spec.damping, phase_margin=spec.phase_margin, rate_hz=rate, analyse=False)
    return design.controller(rate), traj


class FmpyStart(OnePeriodDelay):
    """``inner`` as FMPy's ``simulate_ssp`` runs a direct-feedthrough controller FMU: one period late, no torque
    over the first period, and at ``t_0`` the law evaluated on ``q = qd = 0`` (FMPy's connector start)."""

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
                    variants: tuple[LoopVariant, ...] = (), notes: LoopSpec | None = None,
                    say: Say | None = None) -> Path:
    """Write ``path`` (``.ssp``): ``controller`` (designed on ``robot``) driving ``robot``'s plant FMU along
    ``trajectory``, with the nominal plant parameter set and one per ``variants``; from the trajectory's start
    to its end at the controller's rate. ``notes`` (what ``controller`` and ``trajectory`` were made from) is
    stored as :data:`NOTES`, for :func:`validate_loop_ssp`.

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
    check_set_name(*names)  # before the builds
    n = robot.n
    dt = controller.dt
    ctrl_spec = reference_controller_spec(controller, robot, trajectory)  # a law or trajectory refused first
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
        build_fmu(ctrl_spec, ctrl_fmu)
        components = [SspComponent("plant", plant_fmu, tuple(tau), tuple(x), plant_sets),
                      SspComponent("controller", ctrl_fmu, tuple(x), tuple(tau), {})]
        connections = [SspConnection("plant", v, "controller", v) for v in x] + \
                      [SspConnection("controller", v, "plant", v) for v in tau]
        extra: dict[str, str | bytes] = {}
        if notes is not None:
            source = notes.reference_file
            if source is not None:
                copy = REFERENCE_FILE + Path(source).suffix.lower()
                extra[copy] = Path(source).read_bytes()
                notes = replace(notes, **{"waypoints" if notes.waypoints is not None else "trajectory": copy})
            extra[NOTES] = notes.as_json()
        return write_ssp(path, f"{robot.name} {controller.kind} closed loop", components, connections,
                         start=float(sched.t[0]), stop=float(sched.t[-1]), step=dt, extra=extra)


def _fmu_start(robot: Robot, dt: float) -> np.ndarray:
    from fmu.variables import spec_from_plant
    from model.plant import build_plant

    return np.asarray(spec_from_plant(build_plant(robot), dt).x_start)


def _plant_fmu_from(robot: Robot, dt: float, x0: np.ndarray, path: Path) -> None:
    """A plant FMU starting at ``x0`` (its states' start values; no FMI-LS-REF experiment, which starts elsewhere)."""
    from fmu.variables import spec_from_plant
    from model.plant import build_plant

    build_fmu(replace(spec_from_plant(build_plant(robot), dt), x_start=np.asarray(x0, dtype=float)), path)


@dataclass(frozen=True)
class SspCheck:
    """One run of a loop SSP: the parameter set, the importer, the largest joint difference from the compiled loop
    (rad or m, over every control instant after the start), the control instants compared, and the largest
    difference from the nominal set's run of the same importer (0 for the nominal set)."""

    variant: str
    importer: str
    max_error: float
    samples: int
    from_nominal: float

    @property
    def ok(self) -> bool:
        """Within :data:`SSP_TOLERANCE`."""
        return bool(self.max_error <= SSP_TOLERANCE)


def validate_loop_ssp(path: str | os.PathLike[str], *, importers: tuple[str, ...] = IMPORTERS,
                      say: Say | None = None) -> list[SspCheck]:
    """Run every parameter set of the loop SSP ``path`` (:func:`export_loop_ssp`) in each of ``importers`` and
    compare the plant's joint angles with :func:`compiled_reference` at every control instant.

    Raises
    ------
    model.errors.InputError
        Not an SSP written by :func:`export_loop_ssp` (no :data:`NOTES`, no plant FMU recording its robot).
    """
    from fmu.robot_resource import reload_fmu_robot

    src = Path(path)
    if not src.is_file() or not zipfile.is_zipfile(src):
        raise InputError(f"expected an SSP file (a zip archive), got {str(src)!r}", parameter="ssp")
    text = read_resource(src, NOTES)
    if text is None:
        raise InputError(f"{src.name}: no {NOTES}: not a closed loop written by manip export-ssp", parameter="ssp")
    spec = LoopSpec.from_json(text.decode("utf-8", "replace"), f"{src.name}:{NOTES}")
    with tempfile.TemporaryDirectory(prefix="mw_ssp_") as work:
        plant_fmu = Path(work) / "plant.fmu"
        data = read_resource(src, "resources/plant.fmu")
        if data is None:
            raise InputError(f"{src.name}: no resources/plant.fmu", parameter="ssp")
        plant_fmu.write_bytes(data)
        robot = reload_fmu_robot(plant_fmu)
        if robot is None:
            raise InputError(f"{src.name}: its plant FMU records no robot", parameter="ssp")
        copy = spec.reference_file
        if copy is not None:  # the archive's copy of the waypoint or trajectory file, read as the exporter read it
            data = read_resource(src, copy)
            if data is None:
                raise InputError(f"{src.name}: no {copy}, which its {NOTES} names", parameter="ssp")
            local = Path(work) / Path(copy).name
            local.write_bytes(data)
            spec = replace(spec, **{"waypoints" if spec.waypoints is not None else "trajectory": str(local)})
        controller, trajectory = loop_parts(robot, spec)
    n = robot.n
    outputs = [f"plant.q[{i + 1}]" for i in range(n)]
    checks: list[SspCheck] = []
    nominal: dict[str, np.ndarray] = {}
    for variant in [NOMINAL] + [v.name for v in spec.variants]:
        values = {} if variant == NOMINAL else dict(next(v.values for v in spec.variants if v.name == variant))
        plant = variant_plant(robot, values)
        for importer in importers:
            if say is not None:
                say(f"{variant}: {importer}")
            ref = compiled_reference(robot, plant, controller, trajectory, importer)
            steps = ref.t.size - 1
            if importer == "fmpy":
                Q = run_fmpy(src, variant, outputs, start=float(ref.t[0]), stop=float(ref.t[-1]),
                             step=controller.dt)
            else:
                Q = run_libcosim(src, variant, outputs, steps=steps)
            if variant == NOMINAL:
                nominal[importer] = Q
            checks.append(SspCheck(variant, importer, float(np.max(np.abs(Q - ref.q[1:]))), steps,
                                   float(np.max(np.abs(Q - nominal[importer])))))
    return checks
