"""Robot description, kinematics, inverse kinematics, trajectories and dynamics of serial arms.

Importing the package reads no symbolic library: CasADi is imported by the
modules that build symbolic functions (:mod:`model.kinematics`,
:mod:`model.dynamics`, ...) when a robot first uses them, so ``manip robots``
and ``manip info`` start fast. The dynamics class is :class:`model.dynamics.Dynamics`.
"""

from .lazy import export_names, lazy_exports
from .version import __version__ as __version__

#: Submodule -> the names the package exports from it, imported on first use (:mod:`model.lazy`).
_EXPORTS = {
    "chain": ("Chain", "build_chain"),
    "description": (
        "BUILTIN_ROBOTS", "InertiaConsistencyWarning", "LinkDescription", "RobotDescription", "RobotDescriptionError"
    ),
    "errors": ("InputError", "NumericalError", "SingularDynamicsError", "ToolchainError", "WorkbenchError"),
    "loading": ("load_description",),
    "clik": ("CLIKResult", "clik", "seed_clik_task"),
    "ik": ("IKResult", "IKSolution", "NoClosedFormError", "WorkspaceError"),
    "robot": ("Robot", "load_robot"),
    "singularity": ("SingularityReport",),
    "tasks": (
        "BUILTIN_TASKS", "PICK_AND_PLACE", "Task", "WaypointError", "find_task", "load_waypoints", "pick_and_place",
        "robot_tasks"
    ),
    "trajectory": ("JointPath", "Trajectory", "ctraj", "jtraj", "straight_line", "trapezoidal", "via_points"),
}

__all__ = export_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
