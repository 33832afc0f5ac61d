"""Dynamics of serial arms: Lagrange and Newton-Euler models, motors, parameters, compiled evaluation."""

from model.lazy import export_names, lazy_exports

from ..errors import SingularDynamicsError  # model.errors is light: imported at once

#: Submodule -> the names the package exports from it, imported on first use (:mod:`model.lazy`).
_EXPORTS = {
    "core": ("Dynamics", "NoCompilerWarning"),
    "motors": ("MOTOR_MODELS",),
    "parameters": ("DynamicsParameters", "ParameterLayout", "Payload", "parameter_layout"),
    "symbolic": ("DynamicsFunctions", "build_functions"),
    "workspace": ("Workspace",),
}

__all__ = export_names(_EXPORTS) + ["SingularDynamicsError"]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
