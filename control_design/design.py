"""A whole robot's control design: joint models, one loop per joint, their reports, the controller.

:func:`design_robot` derives the decoupled joint models from the robot's
dynamics along its reference task (:mod:`control_design.joint_model`),
designs one loop per joint (decentralised kinds on the motor-side plant,
computed torque on the double integrator), analyses each
(:func:`~control_design.decentralised.analyse_joint`) and returns a
:class:`RobotDesign` that can build the matching sampled controller.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from model.robot import Robot
from model.trajectory import Trajectory

from .computed_torque import CT_KIND, design_outer_loops
from .controllers import ComputedTorqueController, Controller, DecentralisedController
from .decentralised import (DECENTRALISED_KINDS, DEFAULT_BANDWIDTH, DEFAULT_DAMPING, JointReport, analyse_joint,
                            check_spec, design_joint)
from .joint_model import DecoupledModel, decoupled_model
from .loops import MIN_RATE_PER_BANDWIDTH_HZ, JointLoop, gains_arrays
from .reference import reference_task, reference_task_name

__all__ = ["CONTROLLER_KINDS", "DEFAULT_RATE_HZ", "BANDWIDTH_DEFINITION", "RobotDesign", "design_robot"]

#: Every controller kind the workbench designs and simulates.
CONTROLLER_KINDS: tuple[str, ...] = DECENTRALISED_KINDS + (CT_KIND,)
#: Default control rate, Hz.
DEFAULT_RATE_HZ = 1000.0
BANDWIDTH_DEFINITION = (
    "closed-loop bandwidth: the first frequency where |theta_m / r| (step path: derivative on the measured velocity) "
    "falls to 1/sqrt(2) of its DC value"
)


@dataclass(frozen=True)
class RobotDesign:
    """The designed loops of one robot and everything they were derived from.

    Attributes
    ----------
    robot
        The controller's model.
    kind
        Controller kind.
    bandwidth, damping, phase_margin, rate_hz
        The specification (damping or phase margin may be None; rate None: continuous).
    model
        Decoupled joint models, coupling and torque limits.
    loops
        One loop per joint (motor side, or the computed-torque outer loops).
    reports
        One :class:`~control_design.decentralised.JointReport` per joint (None if not analysed).
    """

    robot: Robot
    kind: str
    bandwidth: float
    damping: float | None
    phase_margin: float | None
    rate_hz: float | None
    model: DecoupledModel
    loops: tuple[JointLoop, ...]
    reports: tuple[JointReport, ...] | None

    @property
    def tau_m_max(self) -> np.ndarray:
        """(n,) motor torque limits, N m."""
        return self.model.limits.tau_m_max

    def controller(self, rate_hz: float | None = None, saturate: bool = True) -> Controller:
        """The sampled controller of this design on ``self.robot`` as its model.

        Parameters
        ----------
        rate_hz
            Control rate, Hz (default: the design's, else :data:`DEFAULT_RATE_HZ`).
        saturate
            Clip the torques at :attr:`tau_m_max`.
        """
        rate = rate_hz or self.rate_hz or DEFAULT_RATE_HZ
        limit = self.tau_m_max if saturate else None
        Kp, Kd, Ki = gains_arrays(self.loops)
        if self.kind == CT_KIND:
            return ComputedTorqueController(self.robot, Kp, Kd, rate, limit)
        return DecentralisedController(self.kind, Kp, Kd, Ki, self.robot.gear_ratio, rate, limit,
                                       J_ff_m=self.model.J_eff_m, B_ff_m=self.model.B_m, gravity_model=self.robot)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: specification, rules, torque limits and one entry per joint."""
        lim = self.model.limits
        joints = []
        for k, jm in enumerate(self.model.joints):
            entry: dict[str, Any] = {"model": jm.to_dict()}
            if self.reports is not None:
                rep = self.reports[k].to_dict()
                peak = self.reports[k].step_peak_tau_m_per_unit_j
                rep["max_step_unsaturated_j"] = float(lim.tau_m_max[k] / peak) if peak > 0 else "inf"
                entry["design"] = rep
            entry["tau_m_max"] = float(lim.tau_m_max[k])
            entry["tau_m_max_source"] = lim.source[k]
            joints.append(entry)
        return {
            "robot": self.robot.name,
            "controller": self.kind,
            "spec": {
                "bandwidth_rad_s": self.bandwidth, "damping": self.damping, "phase_margin_deg": self.phase_margin,
                "rate_hz": self.rate_hz, "bandwidth_definition": BANDWIDTH_DEFINITION,
                "rate_rule": f"rate_hz >= {MIN_RATE_PER_BANDWIDTH_HZ:g} x bandwidth / (2 pi)",
                "inertia_rule": self.model.joints[0].rule if self.model.joints else "max",
                "workspace_samples": self.model.n_samples, "seed": self.model.seed,
                "reference_task": self.model.reference_name,
                "units": "gains *_m motor side (N m/rad, N m s/rad, N m/(rad s)); *_j joint side; computed torque "
                         "outer loops in 1/s^2, 1/s; frequencies rad/s; times s; margins: factor and deg",
            },
            "torque_limit": lim.to_dict(),
            "joints": joints,
        }


def design_robot(robot: Robot, kind: str = "pd", bandwidth: float = DEFAULT_BANDWIDTH, damping: float | None = None, *,
                 phase_margin: float | None = None, rate_hz: float | None = DEFAULT_RATE_HZ,
                 reference: Trajectory | None = None, rule: str = "max", analyse: bool = True,
                 joint_model: DecoupledModel | None = None) -> RobotDesign:
    """Design every joint loop of ``robot``.

    Parameters
    ----------
    robot
        The controller's model.
    kind
        One of :data:`CONTROLLER_KINDS`.
    bandwidth
        Closed-loop bandwidth, rad/s (see :data:`BANDWIDTH_DEFINITION`).
    damping, phase_margin
        Damping ratio, or instead a continuous-loop phase margin in deg (default damping 0.7).
    rate_hz
        Control rate, Hz, or None for continuous-time only.
    reference
        Reference task (default :func:`~control_design.reference.reference_task`).
    rule
        Design inertia of the decoupled joints: 'max' or 'mean'.
    analyse
        Compute the per-joint reports (margins, step metrics, coupling rejection).
    joint_model
        The decoupled model to design on, as :func:`~control_design.joint_model.decoupled_model` of ``robot``
        gives it (default: computed here from ``reference`` and ``rule``, which then are not used); it does not
        depend on the bandwidth, damping or rate, so many designs (a sweep) can share one.

    Raises
    ------
    UnknownControllerError, DesignSpecError, SamplingRateError
    """
    check_spec(kind, bandwidth, damping, phase_margin, rate_hz, CONTROLLER_KINDS)
    if damping is None and phase_margin is None:
        damping = DEFAULT_DAMPING
    if joint_model is None:
        ref = reference_task(robot) if reference is None else reference
        model = decoupled_model(robot, ref, rule=rule,
                                reference_name=reference_task_name(robot) if reference is None else "")
    else:
        model = joint_model
    if kind == CT_KIND:
        loops = design_outer_loops(robot, bandwidth, damping, phase_margin=phase_margin, rate_hz=rate_hz)
        coupling = [0.0] * robot.n  # cancelled by the inverse dynamics when the model is exact
    else:
        loops = tuple(design_joint(p, kind, bandwidth, damping, phase_margin=phase_margin, rate_hz=rate_hz)
                      for p in model.plants())
        coupling = [j.coupling_tau_m for j in model.joints]
    reports = tuple(analyse_joint(lp, c) for lp, c in zip(loops, coupling)) if analyse else None
    return RobotDesign(robot=robot, kind=kind, bandwidth=float(bandwidth), damping=damping, phase_margin=phase_margin,
                       rate_hz=rate_hz, model=model, loops=loops, reports=reports)
