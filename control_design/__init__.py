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

from model.lazy import export_names, lazy_exports

#: Submodule -> the names the package exports from it, imported on first use (:mod:`model.lazy`).
_EXPORTS = {
    "computed_torque": ("CT_KIND", "ModelMismatch", "design_outer_loops", "outer_loop_plant", "plant_with_mismatch"),
    "controllers": ("ComputedTorqueController", "Controller", "DecentralisedController", "LawController"),
    "decentralised": (
        "DECENTRALISED_KINDS", "DEFAULT_BANDWIDTH", "DEFAULT_DAMPING", "JointReport", "analyse_joint", "design_joint",
        "pd_gains", "pid_gains", "second_order_bandwidth_ratio"
    ),
    "design": ("CONTROLLER_KINDS", "DEFAULT_RATE_HZ", "RobotDesign", "design_robot"),
    "errors": (
        "ControlDesignError", "DesignSpecError", "SamplingRateError", "SimulationDivergedError",
        "TrajectoryLimitError", "UnknownControllerError"
    ),
    "joint_model": (
        "CouplingTorques", "DecoupledModel", "JointModel", "TorqueLimits", "coupling_torques", "decoupled_model",
        "effective_inertia_m", "sample_configurations", "torque_limits"
    ),
    "loops": ("MIN_RATE_PER_BANDWIDTH_HZ", "JointGains", "JointLoop", "JointPlant", "check_rate", "gains_arrays"),
    "laws": ("LAW_KINDS", "NO_LIMIT", "ControlLaw", "control_law", "controller_function", "saturation"),
    "plots": ("bode_plot", "step_plot"),
    "reference": ("Reference", "check_trajectory_limits", "reference_task", "task_trajectory"),
    "responses": (
        "BodeResponse", "DisturbanceRejection", "Margins", "StepResponse", "bode_response", "closed_loop_bandwidth",
        "disturbance_rejection", "margins", "step_response"
    ),
}

__all__ = export_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
