"""Robot description, kinematics, inverse kinematics, trajectories and dynamics of serial arms.

Importing the package reads no symbolic library: CasADi is imported by the
modules that build symbolic functions (:mod:`model.kinematics`,
:mod:`model.dynamics`, ...) when a robot first uses them, so ``manip robots``
and ``manip info`` start fast. The dynamics class is :class:`model.dynamics.Dynamics`.
"""

from .chain import Chain, build_chain
from .description import BUILTIN_ROBOTS, InertiaConsistencyWarning, LinkDescription, RobotDescription, RobotDescriptionError
from .errors import InputError, NumericalError, SingularDynamicsError, ToolchainError, WorkbenchError
from .loading import load_description
from .clik import CLIKResult, clik, seed_clik_task
from .ik import IKResult, IKSolution, NoClosedFormError, WorkspaceError
from .robot import Robot, load_robot
from .singularity import SingularityReport
from .tasks import BUILTIN_TASKS, PICK_AND_PLACE, Task, WaypointError, find_task, load_waypoints, pick_and_place, robot_tasks
from .trajectory import JointPath, Trajectory, ctraj, jtraj, straight_line, trapezoidal, via_points

__all__ = [
    "Chain",
    "build_chain",
    "find_task",
    "robot_tasks",
    "CLIKResult",
    "InputError",
    "NumericalError",
    "ToolchainError",
    "WorkbenchError",
    "IKResult",
    "IKSolution",
    "NoClosedFormError",
    "SingularDynamicsError",
    "SingularityReport",
    "WorkspaceError",
    "clik",
    "seed_clik_task",
    "BUILTIN_ROBOTS",
    "BUILTIN_TASKS",
    "InertiaConsistencyWarning",
    "JointPath",
    "LinkDescription",
    "PICK_AND_PLACE",
    "Robot",
    "RobotDescription",
    "RobotDescriptionError",
    "Task",
    "Trajectory",
    "WaypointError",
    "ctraj",
    "jtraj",
    "load_description",
    "load_robot",
    "load_waypoints",
    "pick_and_place",
    "straight_line",
    "trapezoidal",
    "via_points",
]
