"""FMU export: the robot as a native FMI 2.0 FMU (Model Exchange and Co-Simulation).

Data flow: :mod:`fmu.variables` (the one variable table) -> :mod:`fmu.build`
(CasADi C, the wrapper of ``fmu/c/``, gcc, zip) -> :mod:`fmu.simulate` (FMPy)
and :mod:`fmu.cosim` (libcosim) -> :mod:`fmu.validate` (all of it checked
against the Python model).
"""

__version__ = "0.1.0"

from .build import FmuBuildError, build_driver, build_fmu, export_fmu, export_trivial_fmu
from .cosim import CosimError, CosimResult, run_libcosim
from .simulate import SimulationResult, simulate_cs, simulate_me, step_input
from .validate import ValidationReport, validate_fmu
from .variables import ModelSpec, VariableTable, build_table, spec_from_plant, trivial_spec


# The closed-loop names need control_design (python-control, SciPy: ~0.8 s to import):
# loaded on first access, so ``import fmu`` stays light.
_LAZY = {
    "ControllerFmuReport": "controller_fmu", "controller_fmu_kind": "controller_fmu",
    "controller_spec": "controller_fmu", "export_controller_fmu": "controller_fmu",
    "validate_controller_fmu": "controller_fmu",
    "OnePeriodDelay": "master", "closed_loop_through_fmu": "master", "run_closed_loop": "master",
    "run_libcosim_closed_loop": "master",
    "SingularInertiaError": "export_checks", "check_inertia": "export_checks",
    "StickSlipResult": "reference", "simulate_stick_slip": "reference",
}


def __getattr__(name: str) -> object:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "SingularInertiaError",
    "StickSlipResult",
    "check_inertia",
    "simulate_stick_slip",
    "ControllerFmuReport",
    "OnePeriodDelay",
    "closed_loop_through_fmu",
    "controller_fmu_kind",
    "controller_spec",
    "export_controller_fmu",
    "run_closed_loop",
    "run_libcosim_closed_loop",
    "validate_controller_fmu",
    "CosimError",
    "CosimResult",
    "FmuBuildError",
    "ModelSpec",
    "SimulationResult",
    "ValidationReport",
    "VariableTable",
    "build_driver",
    "build_fmu",
    "build_table",
    "export_fmu",
    "export_trivial_fmu",
    "run_libcosim",
    "simulate_cs",
    "simulate_me",
    "spec_from_plant",
    "step_input",
    "trivial_spec",
    "validate_fmu",
]
