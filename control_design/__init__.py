"""Control design: decentralised joint loops, computed torque, responses, control laws, plots.

Data flow: robot model -> :mod:`~control_design.joint_model` (each joint seen
from its motor) -> :mod:`~control_design.decentralised` /
:mod:`~control_design.computed_torque` (one loop per joint, on
:mod:`~control_design.loops`) -> :mod:`~control_design.responses` (margins,
Bode, steps: result objects) -> :mod:`~control_design.plots` (figures);
:mod:`~control_design.laws` (each control law once, a CasADi Function) ->
:mod:`~control_design.controllers` (sampled ``update(t, q, qd, ref) -> tau_m``).
:mod:`~control_design.design` ties them together for a whole robot and
:mod:`workbench.cmd_design` exposes ``manip design``. Closed loops (the
nonlinear simulation, FMU masters, ``manip track``) are the layer above,
:mod:`closed_loop`.
"""

from .computed_torque import CT_KIND, ModelMismatch, design_outer_loops, outer_loop_plant, plant_with_mismatch
from .controllers import ComputedTorqueController, Controller, DecentralisedController, LawController
from .decentralised import (DECENTRALISED_KINDS, DEFAULT_BANDWIDTH, DEFAULT_DAMPING, JointReport, analyse_joint,
                            design_joint, pd_gains, pid_gains, second_order_bandwidth_ratio)
from .design import CONTROLLER_KINDS, DEFAULT_RATE_HZ, RobotDesign, design_robot
from .errors import (ControlDesignError, DesignSpecError, SamplingRateError, SimulationDivergedError,
                     TrajectoryLimitError, UnknownControllerError)
from .joint_model import (CouplingTorques, DecoupledModel, JointModel, TorqueLimits, coupling_torques, decoupled_model,
                          effective_inertia_m, sample_configurations, torque_limits)
from .loops import MIN_RATE_PER_BANDWIDTH_HZ, JointGains, JointLoop, JointPlant, check_rate, gains_arrays
from .laws import LAW_KINDS, NO_LIMIT, ControlLaw, control_law, controller_function, saturation
from .plots import bode_plot, step_plot
from .reference import Reference, check_trajectory_limits, reference_task, task_trajectory
from .responses import (BodeResponse, DisturbanceRejection, Margins, StepResponse, bode_response,
                        closed_loop_bandwidth, disturbance_rejection, margins, step_response)

__all__ = [
    "BodeResponse",
    "CONTROLLER_KINDS",
    "CT_KIND",
    "ComputedTorqueController",
    "ControlDesignError",
    "ControlLaw",
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
    "LAW_KINDS",
    "LawController",
    "MIN_RATE_PER_BANDWIDTH_HZ",
    "Margins",
    "ModelMismatch",
    "NO_LIMIT",
    "Reference",
    "RobotDesign",
    "SamplingRateError",
    "SimulationDivergedError",
    "StepResponse",
    "TorqueLimits",
    "TrajectoryLimitError",
    "UnknownControllerError",
    "analyse_joint",
    "bode_plot",
    "bode_response",
    "check_rate",
    "check_trajectory_limits",
    "closed_loop_bandwidth",
    "control_law",
    "controller_function",
    "coupling_torques",
    "decoupled_model",
    "design_joint",
    "design_outer_loops",
    "design_robot",
    "disturbance_rejection",
    "effective_inertia_m",
    "gains_arrays",
    "margins",
    "outer_loop_plant",
    "pd_gains",
    "pid_gains",
    "plant_with_mismatch",
    "reference_task",
    "sample_configurations",
    "saturation",
    "second_order_bandwidth_ratio",
    "step_plot",
    "step_response",
    "task_trajectory",
    "torque_limits",
]
