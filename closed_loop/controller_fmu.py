"""Controller FMUs: the control laws of :mod:`control_design.laws` as FMI 2.0 FMUs.

A controller FMU is built by the same variable table (:mod:`fmu.variables`) and
C wrapper (``fmu/c/``) as the plant: a :class:`~fmu.variables.ModelSpec` with no
states (``nx = 0``) whose output function is the controller's own CasADi
Function (:func:`control_design.laws.controller_function`: the law, then the
saturation), ``tau_m = out(x, u, p)``, so its outputs depend directly on its
inputs (direct feedthrough) and it computes what the Python controller computes.
Inputs are the reference and the measured state, parameters the law's (all
tunable):

================  ==========================================================
inputs            ``q_ref[i]``, ``qd_ref[i]`` (``qdd_ref[i]`` for 'pd-ff' and
                  'ct'), ``q[i]``, ``qd[i]`` (rad or m, /s, /s^2)
output            ``tau_m[i]``, motor torque, N m
'pd', 'pd-g',     ``Kp[i]`` (N m/rad), ``Kd[i]`` (N m s/rad), motor side;
'pd-ff'           ``gear_ratio[i]``; ``tau_m_max[i]`` (N m); 'pd-ff':
                  ``J_ff_m[i]`` (kg m^2), ``B_ff_m[i]`` (N m s/rad);
                  'pd-g': the controller model's ``model.*`` parameters
'ct'              ``Kp[i]`` (1/s^2), ``Kd[i]`` (1/s), ``gear_ratio[i]``,
                  ``tau_m_max[i]`` (N m) and the controller model's ``model.*``
                  parameters (payload, friction, gravity); the model itself
                  (Newton-Euler ``rne``) is generated into the FMU's C
================  ==========================================================

A controller without saturation gets :data:`~control_design.laws.NO_LIMIT` as
its limit (a no-op on finite torques).

'pid' has the parameters of 'pd' plus ``Ki[i]`` (N m/(rad s)), and its
integrator ``z[i]`` (motor rad s) is a sampled discrete state of the FMU
(:class:`fmu.variables.DiscreteStates`): ``tau_m`` is computed from ``z_k``
and the inputs, and each sample period (``1 / rate_hz``, baked in as the law's
``dt``) ``fmi2DoStep`` ticks ``z_{k+1} = z_next(inputs, z_k)`` (conditional
integration against wind-up), exactly as the Python controller's ``update``.
A communication step must be a whole number of periods (each a tick, inputs
held); any other step is ``fmi2Error``. The PID FMU is Co-Simulation only: its
state changes on a clock, which FMI 2.0 Model Exchange can only approximate
by time events whose inputs the importer may already have changed.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import casadi as ca
import numpy as np

from control_design.controllers import ComputedTorqueController, Controller, LawController
from control_design.design import RobotDesign
from control_design.laws import NO_LIMIT
from control_design.reference import Reference
from fmu.build import build_fmu
from fmu.opened import open_fmu
from fmu.variables import DiscreteStates, ModelSpec, Quantity, fmu_identifier
from model.robot import Robot
from model.errors import InputError

__all__ = [
    "CONTROLLER_FMU_KINDS",
    "NO_LIMIT",
    "ControllerFmuReport",
    "controller_spec",
    "export_controller_fmu",
    "controller_fmu_kind",
    "validate_controller_fmu",
]

#: Controller kinds a controller FMU can carry.
CONTROLLER_FMU_KINDS: tuple[str, ...] = ("pd", "pd-g", "pd-ff", "pid", "ct")

_NAME_PATTERN = re.compile(r"^(?P<robot>.+) (?P<kind>pd|pd-g|pd-ff|pid|ct) controller$")

#: The law in words, for the FMU description.
_LAW_TEXT = {
    "pd": "decentralised PD on the motor angle tau_m = Kp G (q_ref - q) + Kd G (qd_ref - qd)",
    "pd-ff": "decentralised PD on the motor angle tau_m = Kp G (q_ref - q) + Kd G (qd_ref - qd)"
             " + J_ff_m G qdd_ref + B_ff_m G qd_ref",
    "pd-g": "decentralised PD on the motor angle tau_m = Kp G (q_ref - q) + Kd G (qd_ref - qd) + g(q) / G",
    "ct": "computed torque tau_m = rne(q, qd, qdd_ref + Kd (qd_ref - qd) + Kp (q_ref - q)) / G",
    "pid": "decentralised PID on the motor angle tau_m = Kp G (q_ref - q) + Kd G (qd_ref - qd) + Ki z, "
           "z_next = z + dt G (q_ref - q) once per period unless the saturated output winds up",
}
#: FMU parameter order (the law's inputs are matched by name).
_PARAMETER_ORDER = ("Kp", "Kd", "Ki", "gear_ratio", "tau_m_max", "J_ff_m", "B_ff_m", "p_model")
#: FMU input name of each law signal.
_SIGNAL_NAMES = {"q_d": "q_ref", "qd_d": "qd_ref", "qdd_d": "qdd_ref", "q": "q", "qd": "qd"}

Progress = Callable[[str], None]


def _units(robot: Robot) -> tuple[list[str], list[str], list[str]]:
    links = robot.description.links
    pos = ["rad" if lk.is_revolute else "m" for lk in links]
    return pos, [f"{u}/s" for u in pos], [f"{u}/s2" for u in pos]


def _model_params(robot: Robot, uses: str) -> tuple[list[Quantity], np.ndarray, list[bool], list[float | None],
                                                     list[float | None]]:
    """The controller model's parameter vector ``p`` as FMU parameters ``model.<name>``."""
    layout = robot.dynamics.layout
    quantities = [Quantity(f"model.{nm}", unit, f"controller model ({uses}): {text}")
                  for nm, unit, text in zip(layout.names, layout.units, layout.descriptions)]
    # the plant FMU's conventions (fmu.variables.spec_from_plant): gravity fixed, physical signs as ranges
    nonneg = ("payload_mass", "viscous_friction", "coulomb_friction_pos")
    tunable = [not nm.startswith("gravity") for nm in layout.names]
    lo: list[float | None] = [0.0 if nm.split("[")[0] in nonneg else None for nm in layout.names]
    hi: list[float | None] = [0.0 if nm.split("[")[0] == "coulomb_friction_neg" else None for nm in layout.names]
    return quantities, robot.parameters.vector.copy(), tunable, lo, hi


def _vector_parameter(name: str, kind: str, robot: Robot) -> tuple[list[str], str, float | None]:
    """Per-joint units, description and lower bound of the law parameter ``name``."""
    n = robot.n
    if name == "Kp":
        return (["1/s2"] * n, "outer-loop proportional gain (wn^2)", None) if kind == "ct" else \
            (["N.m/rad"] * n, "motor-side proportional gain", None)
    if name == "Ki":
        return ["N.m.s-1/rad"] * n, "motor-side integral gain", None
    if name == "Kd":
        return (["1/s"] * n, "outer-loop derivative gain (2 zeta wn)", None) if kind == "ct" else \
            (["N.m.s/rad"] * n, "motor-side derivative gain", None)
    if name == "gear_ratio":
        return (["" if lk.is_revolute else "rad/m" for lk in robot.description.links],
                "reduction ratio G (motor angle = G q)", None)
    if name == "tau_m_max":
        return ["N.m"] * n, "motor torque limit", 0.0
    if name == "J_ff_m":
        return ["kg.m2"] * n, "fed-forward decoupled inertia, motor side", 0.0
    if name == "B_ff_m":
        return ["N.m.s/rad"] * n, "fed-forward viscous friction, motor side", 0.0
    raise InputError(f"the law parameter {name!r} has no FMU variable", parameter="controller")


def controller_spec(controller: Controller, robot: Robot, *, model_identifier: str | None = None) -> ModelSpec:
    """The :class:`~fmu.variables.ModelSpec` of a controller FMU running ``controller``'s law.

    Parameters
    ----------
    controller
        A :class:`~control_design.controllers.DecentralisedController` of kind 'pd', 'pd-g',
        'pd-ff' or 'pid' (its integrator a sampled discrete state, period ``1 / rate_hz``), or a
        :class:`~control_design.controllers.ComputedTorqueController`; its Function
        (law and saturation) is the FMU's output function, its parameter values (gains, gear
        ratios, limits, model parameters) the FMU's parameter start values, its rate (Hz) the
        FMU's default communication step ``1 / rate_hz`` (s).
    robot
        The robot the controller drives (joint names, units).
    model_identifier
        C identifier of the FMU (default ``<robot>_<kind>_controller``).

    Raises
    ------
    model.errors.InputError
        A kind not in :data:`CONTROLLER_FMU_KINDS`, or a joint
        count that differs from the robot's.
    """
    kind = controller.kind
    if kind not in CONTROLLER_FMU_KINDS:
        raise InputError(f"expected a kind in {CONTROLLER_FMU_KINDS} (stateless laws), got {kind!r}",
                         parameter="controller")
    if not isinstance(controller, LawController):
        raise InputError(f"expected a DecentralisedController or ComputedTorqueController, "
                         f"got {type(controller).__name__}", parameter="controller")
    n = robot.n
    if controller.n != n:
        raise InputError(f"expected {n} joints like robot {robot.name!r}, got {controller.n}", parameter="controller")
    pos, vel, acc = _units(robot)
    names = [lk.name or f"joint {i + 1}" for i, lk in enumerate(robot.description.links)]
    idx = range(n)
    function = controller.function
    law = controller.law
    args: dict[str, ca.SX] = {}

    inputs: list[Quantity] = []
    u_parts: list[ca.SX] = []
    what = {"q_ref": ("reference position", pos), "qd_ref": ("reference velocity", vel),
            "qdd_ref": ("reference acceleration", acc), "q": ("measured position", pos),
            "qd": ("measured velocity", vel)}
    for fmu_name in ("q_ref", "qd_ref", "qdd_ref", "q", "qd"):
        signal = next((s for s in law.signals if _SIGNAL_NAMES[s] == fmu_name), None)
        if signal is None:
            continue
        text, units = what[fmu_name]
        inputs += [Quantity(f"{fmu_name}[{i + 1}]", units[i], f"{text} of joint {i + 1} ({names[i]})") for i in idx]
        args[signal] = ca.SX.sym(fmu_name, n)
        u_parts.append(args[signal])

    values = controller.parameter_values()
    params: list[Quantity] = []
    p_start: list[np.ndarray] = []
    p_tunable: list[bool] = []
    p_min: list[float | None] = []
    p_max: list[float | None] = []
    p_parts: list[ca.SX] = []
    for name in sorted(values, key=lambda k: _PARAMETER_ORDER.index(k) if k in _PARAMETER_ORDER else -1):
        if name == "dt":  # the PID law's period: the FMU's sample period, a constant of its C
            args[name] = ca.SX(float(values[name][0]))
            continue
        if name == "p_model":
            model = controller.model if isinstance(controller, ComputedTorqueController) else \
                controller.gravity_model  # type: ignore[attr-defined]
            uses = "inverse dynamics" if kind == "ct" else "gravity compensation"
            pq, ps, pt, plo, phi = _model_params(model, uses)
            params += pq
            p_start.append(ps)
            p_tunable += pt
            p_min += plo
            p_max += phi
        else:
            units, text, lo = _vector_parameter(name, kind, robot)
            params += [Quantity(f"{name}[{i + 1}]", units[i], f"{text}, joint {i + 1} ({names[i]})") for i in idx]
            p_start.append(values[name])
            p_tunable += [True] * n
            p_min += [lo] * n
            p_max += [None] * n
        args[name] = ca.SX.sym(name, values[name].size)
        p_parts.append(args[name])
    discrete = None
    if law.states:  # 'pid': the integrator z, a sampled discrete state
        args["z"] = ca.SX.sym("z", n)
    y = function(*[args[function.name_in(i)] for i in range(function.n_in())])

    x = ca.SX.sym("x", 0)
    u = ca.vertcat(*u_parts)
    p = ca.vertcat(*p_parts)
    if law.states:
        tau, z_next = y
        d = args["z"]
        ode = ca.Function("ode", [x, u, p, d], [ca.SX(0, 1)], ["x", "u", "p", "d"], ["xdot"])
        out = ca.Function("out", [x, u, p, d], [ca.densify(tau)], ["x", "u", "p", "d"], ["y"])
        tick = ca.Function("tick", [x, u, p, d], [ca.densify(z_next)], ["x", "u", "p", "d"], ["d_next"])
        states = tuple(Quantity(f"z[{i + 1}]", "rad.s", f"integrator of the motor-angle error of joint {i + 1} "
                                f"({names[i]}), sampled") for i in idx)
        discrete = DiscreteStates(states, np.zeros(n), float(values["dt"][0]), tick)
    else:
        ode = ca.Function("ode", [x, u, p], [ca.SX(0, 1)], ["x", "u", "p"], ["xdot"])
        out = ca.Function("out", [x, u, p], [ca.densify(y)], ["x", "u", "p"], ["y"])
    outputs = tuple(Quantity(f"tau_m[{i + 1}]", "N.m", f"motor torque of joint {i + 1} ({names[i]}), saturated")
                    for i in idx)
    ident = fmu_identifier(model_identifier, f"{robot.name}_{kind}_controller")
    return ModelSpec(
        model_identifier=ident,
        model_name=f"{robot.name} {kind} controller",
        description=(f"{kind} controller of {robot.name} sampled at {controller.rate_hz:g} Hz "
                     f"({'integrator a sampled state' if discrete else 'stateless'}, direct "
                     f"feedthrough): {_LAW_TEXT[kind]}, saturated at +-tau_m_max"),
        ode=ode, out=out,
        states=(), x_start=np.zeros(0),
        inputs=tuple(inputs),
        params=tuple(params), p_start=np.concatenate(p_start), p_tunable=tuple(p_tunable), p_min=tuple(p_min),
        p_max=tuple(p_max),
        outputs=outputs, output_state=(-1,) * n,
        step=controller.dt,
        discrete=discrete,
    )


def export_controller_fmu(design: RobotDesign | Controller, path: str | os.PathLike[str], *,
                          rate_hz: float | None = None, robot: Robot | None = None, saturate: bool = True,
                          progress: Progress | None = None) -> Path:
    """Export the controller of ``design`` as an FMI 2.0 FMU (Co-Simulation and Model Exchange; 'pid':
    Co-Simulation only, its integrator a sampled discrete state).

    Parameters
    ----------
    design
        A :class:`~control_design.design.RobotDesign` (its ``controller(rate_hz, saturate)`` is
        exported) or a ready :class:`~control_design.controllers.Controller`.
    path
        The ``.fmu`` to write; parent folders are created.
    rate_hz
        Control rate, Hz: the FMU's default communication step is ``1 / rate_hz`` s (default the
        design's rate; ignored for a ready controller, which has its own).
    robot
        The robot driven (default ``design.robot``; required with a ready controller).
    saturate
        Clip at the design's torque limits (with a design only).
    progress
        Called with one line per build stage.

    Returns
    -------
    Path
        The written FMU.

    Raises
    ------
    model.errors.InputError
        Missing robot, joint counts that differ.
    fmu.build.FmuBuildError
        The generated C did not compile.
    """
    if isinstance(design, RobotDesign):
        controller = design.controller(rate_hz, saturate=saturate)
        robot = design.robot if robot is None else robot
    elif isinstance(design, Controller):
        controller = design
        if robot is None:
            raise InputError("expected the Robot the controller drives when exporting a ready Controller",
                             parameter="robot")
    else:
        raise InputError(f"expected a RobotDesign or a Controller, got {type(design).__name__}", parameter="design")
    return build_fmu(controller_spec(controller, robot), path, progress=progress)


def controller_fmu_kind(path: str | os.PathLike[str]) -> tuple[str, str]:
    """``(robot, kind)`` of a controller FMU written by :func:`export_controller_fmu` (from its modelName).

    Raises
    ------
    fmu.archive.FmuArchiveError
        Not a file, not a zip archive, or an archive that breaks a limit of :mod:`fmu.archive`.
    model.errors.InputError
        An unreadable model description, or not a controller FMU of this workbench.
    """
    with open_fmu(path, parameter="path") as fmu:  # the archive is checked before its description is parsed
        model_name = fmu.md.modelName
    match = _NAME_PATTERN.match(model_name or "")
    if match is None:
        raise InputError(f"{str(path)!r} is not a controller FMU (modelName {model_name!r})", parameter="path")
    return match["robot"], match["kind"]


# ----------------------------------------------------------------- validation

@dataclass(frozen=True)
class ControllerFmuReport:
    """Checks of a controller FMU: FMPy's validation, the binary, and the law against the Python controller.

    Attributes
    ----------
    description_problems, binary_problems
        FMPy's ``validate_fmu`` findings and the binary's (non-FMI exports, libraries beyond libc/libm).
    samples
        Random (seeded) input vectors evaluated by both.
    max_abs_diff, max_rel_diff
        Largest ``|tau_fmu - tau_python|`` (N m) and the same over ``1 + |tau_python|``.
    saturated_fraction
        Fraction of the sampled torques at their limit (the test exercises the clipping too).
    """

    fmu: str
    description_problems: tuple[str, ...]
    binary_problems: tuple[str, ...]
    samples: int
    max_abs_diff: float
    max_rel_diff: float
    saturated_fraction: float

    def problems(self, tol: float = 1e-12) -> list[str]:
        """Everything that failed; the law must agree within ``tol`` relative (round-off of a few operations)."""
        found = list(self.description_problems) + list(self.binary_problems)
        if not self.max_rel_diff <= tol:
            found.append(f"controller law differs from the Python controller by {self.max_rel_diff:.3e} "
                         f"(relative to 1 + |tau_m|), above {tol:g}")
        return found

    def format(self) -> str:
        """A few lines for a report."""
        return (f"controller FMU {self.fmu}\n"
                f"  FMPy validation: {len(self.description_problems)} problems; binary: "
                f"{len(self.binary_problems)} problems\n"
                f"  law vs Python over {self.samples} random inputs: max |d tau_m| = {self.max_abs_diff:.3e} N m "
                f"(relative {self.max_rel_diff:.3e}), {100 * self.saturated_fraction:.0f} % of the torques saturated")


def validate_controller_fmu(path: str | os.PathLike[str], controller: Controller, *, samples: int = 200,
                            seed: int = 0) -> ControllerFmuReport:
    """Validate a controller FMU against the Python ``controller`` it was exported from.

    FMPy validates ``modelDescription.xml``; the binary must export ``fmi2`` functions
    only. Then ``samples`` seeded random references (positions within +-2 rad or m
    of zero, velocities +-2 /s, accelerations +-20 /s^2) and measured states go
    through ``fmi2SetReal`` / ``fmi2GetReal`` of a Co-Simulation instance and
    through ``controller.update``;
    the tracking errors are drawn log-uniformly between 1e-6 and 1e-1 so that the
    torques fall on both sides of the limits.
    """
    from fmu.validate import binary_problems, model_description_problems

    path = str(path)
    described = tuple(model_description_problems(path))
    binary = tuple(binary_problems(path)[0])
    n = controller.n
    rng = np.random.default_rng(seed)
    worst_abs = worst_rel = 0.0
    saturated = 0
    with open_fmu(path, parameter="path") as fmu, fmu.instance("cs", "controller_check") as slave:
        slave.start(0.0)
        groups = ["q_ref", "qd_ref"] + (["qdd_ref"] if fmu.has("qdd_ref[1]") else []) + ["q", "qd"]
        inputs = fmu.select([f"{g}[{i + 1}]" for g in groups for i in range(n)])
        outputs = fmu.select([f"tau_m[{i + 1}]" for i in range(n)])
        controller.reset()
        for k in range(samples):
            qr, qdr = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)
            qddr = rng.uniform(-20, 20, n)
            scale = 10.0 ** rng.uniform(-6.0, -1.0)
            q, qd = qr + scale * rng.uniform(-1, 1, n), qdr + 10.0 * scale * rng.uniform(-1, 1, n)
            values = {"q_ref": qr, "qd_ref": qdr, "qdd_ref": qddr, "q": q, "qd": qd}
            slave.set(inputs, np.concatenate([values[g] for g in groups]))
            fmu_tau = slave.get(outputs)
            slave.do_step(k * controller.dt, controller.dt)
            py_tau = controller.update(k * controller.dt, q, qd, Reference(qr, qdr, qddr))
            diff = np.abs(fmu_tau - py_tau)
            worst_abs = max(worst_abs, float(diff.max()))
            worst_rel = max(worst_rel, float(np.max(diff / (1.0 + np.abs(py_tau)))))
            if controller.tau_m_max is not None:
                saturated += int(np.sum(np.abs(py_tau) >= controller.tau_m_max))
        slave.terminate()
    return ControllerFmuReport(path, described, binary, samples, worst_abs, worst_rel, saturated / (samples * n))
