"""Dynamics of serial arms: Lagrange and Newton-Euler models, motors, parameters, compiled evaluation."""

from .core import Dynamics, NoCompilerWarning
from .motors import MOTOR_MODELS
from .parameters import ParameterLayout, parameter_layout
from .symbolic import DynamicsFunctions, build_functions

__all__ = [
    "Dynamics",
    "DynamicsFunctions",
    "MOTOR_MODELS",
    "NoCompilerWarning",
    "ParameterLayout",
    "build_functions",
    "parameter_layout",
]
