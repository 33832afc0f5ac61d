"""Control design: decentralised joint loops, computed torque, responses, closed-loop tracking, plots.

Data flow: robot model -> :mod:`~control_design.joint_model` (each joint seen
from its motor) -> :mod:`~control_design.decentralised` /
:mod:`~control_design.computed_torque` (one loop per joint, on
:mod:`~control_design.loops`) -> :mod:`~control_design.responses` (margins,
Bode, steps: result objects) -> :mod:`~control_design.controllers` (sampled
``update(t, q, qd, ref) -> tau_m``) -> :mod:`~control_design.simulate`
(nonlinear closed loop, metrics) -> :mod:`~control_design.plots` (figures).
:mod:`~control_design.design` ties them together for a whole robot and
:mod:`~control_design.commands` exposes ``manip design`` and ``manip track``.
"""

from .computed_torque import CT_KIND, ModelMismatch, design_outer_loops, outer_loop_plant, plant_with_mismatch
from .controllers import ComputedTorqueController, Controller, DecentralisedController
from .decentralised import (DECENTRALISED_KINDS, DEFAULT_BANDWIDTH, DEFAULT_DAMPING, JointReport, analyse_joint,
                            design_joint, pd_gains, pid_gains, second_order_bandwidth_ratio)
from .design import CONTROLLER_KINDS, DEFAULT_RATE_HZ, RobotDesign, design_robot
from .errors import (ControlDesignError, DesignSpecError, SamplingRateError, SimulationDivergedError,
                     TrajectoryLimitError, UnknownControllerError)
from .joint_model import (CouplingTorques, DecoupledModel, JointModel, TorqueLimits, coupling_torques, decoupled_model,
                          effective_inertia_m, sample_configurations, torque_limits)
from .loops import MIN_RATE_PER_BANDWIDTH_HZ, JointGains, JointLoop, JointPlant, check_rate, gains_arrays
from .plots import bode_plot, joint_plot, step_plot, torque_plot, tracking_error_plot
from .reference import Reference, check_trajectory_limits, reference_task, task_trajectory
from .responses import (BodeResponse, DisturbanceRejection, Margins, StepResponse, bode_response,
                        closed_loop_bandwidth, disturbance_rejection, margins, step_response)
from .simulate import ProgressLine, TrackingMetrics, TrackingResult, simulate_tracking

__all__ = [
    "BodeResponse",
    "CONTROLLER_KINDS",
    "CT_KIND",
    "ComputedTorqueController",
    "ControlDesignError",
    "Controller",
    "CouplingTorques",
    "DECENTRALISED_KINDS",
    "DEFAULT_BANDWIDTH",
    "DEFAULT_DAMPING",
    "DEFAULT_RATE_HZ",
    "DecentralisedController",
    "DecoupledModel",
    "DesignSpecError",
    "DisturbanceRejection",
    "JointGains",
    "JointLoop",
    "JointModel",
    "JointPlant",
    "JointReport",
    "MIN_RATE_PER_BANDWIDTH_HZ",
    "Margins",
    "ModelMismatch",
    "ProgressLine",
    "Reference",
    "RobotDesign",
    "SamplingRateError",
    "SimulationDivergedError",
    "StepResponse",
    "TorqueLimits",
    "TrackingMetrics",
    "TrackingResult",
    "TrajectoryLimitError",
    "UnknownControllerError",
    "analyse_joint",
    "bode_plot",
    "bode_response",
    "check_rate",
    "check_trajectory_limits",
    "closed_loop_bandwidth",
    "coupling_torques",
    "decoupled_model",
    "design_joint",
    "design_outer_loops",
    "design_robot",
    "disturbance_rejection",
    "effective_inertia_m",
    "gains_arrays",
    "joint_plot",
    "margins",
    "outer_loop_plant",
    "pd_gains",
    "pid_gains",
    "plant_with_mismatch",
    "reference_task",
    "sample_configurations",
    "second_order_bandwidth_ratio",
    "simulate_tracking",
    "step_plot",
    "step_response",
    "task_trajectory",
    "torque_limits",
    "torque_plot",
    "tracking_error_plot",
]
