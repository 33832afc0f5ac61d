"""Robot description, kinematics, inverse kinematics, trajectories and dynamics of serial arms."""

from .description import (
    BUILTIN_ROBOTS,
    InertiaConsistencyWarning,
    LinkDescription,
    RobotDescription,
    RobotDescriptionError,
    load_description,
)
from .robot import Robot, load_robot

__all__ = [
    "BUILTIN_ROBOTS",
    "InertiaConsistencyWarning",
    "LinkDescription",
    "Robot",
    "RobotDescription",
    "RobotDescriptionError",
    "load_description",
    "load_robot",
]
