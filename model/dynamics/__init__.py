"""Dynamics of serial arms: Lagrange and Newton-Euler models, motors, parameters, compiled evaluation."""

from .core import Dynamics, NoCompilerWarning
from .motors import MOTOR_MODELS
from .parameters import DynamicsParameters, ParameterLayout, Payload, parameter_layout
from ..errors import SingularDynamicsError
from .symbolic import DynamicsFunctions, build_functions
from .workspace import Workspace

__all__ = [
    "Dynamics",
    "DynamicsFunctions",
    "DynamicsParameters",
    "MOTOR_MODELS",
    "NoCompilerWarning",
    "ParameterLayout",
    "Payload",
    "SingularDynamicsError",
    "Workspace",
    "build_functions",
    "parameter_layout",
]
