"""FMU export: the robot as a native FMI 2.0 FMU (Model Exchange and Co-Simulation).

Data flow: :mod:`fmu.variables` (the one variable table) -> :mod:`fmu.build`
(CasADi C, the wrapper of ``fmu/c/``, gcc and for other platforms
:mod:`fmu.cross` with the table of :mod:`fmu.platforms`, zip) -> :mod:`fmu.simulate` (FMPy)
and :mod:`fmu.cosim` (libcosim) -> :mod:`fmu.validate` (all of it checked
against the Python model). It exports and validates any model spec and knows
nothing of controllers: closed loops through FMUs are :mod:`closed_loop`.
"""

from .archive import FmuArchiveError, check_fmu_archive
from .build import FmuBuildError, build_driver, build_fmu, export_fmu, export_trivial_fmu, tool_version
from .cross import compile_shared
from .platforms import PLATFORMS, Platform, platform_folder, resolve_platforms
from .cosim import CosimError, CosimResult, run_libcosim
from .simulate import SimulationResult, simulate_cs, simulate_me, step_input
from .validate import ValidationReport, validate_fmu
from .variables import ModelSpec, VariableTable, build_table, spec_from_plant, trivial_spec
from .export_checks import SingularInertiaError, check_inertia

__all__ = [
    "PLATFORMS",
    "Platform",
    "compile_shared",
    "platform_folder",
    "resolve_platforms",
    "SingularInertiaError",
    "check_inertia",
    "CosimError",
    "FmuArchiveError",
    "CosimResult",
    "FmuBuildError",
    "ModelSpec",
    "SimulationResult",
    "ValidationReport",
    "VariableTable",
    "build_driver",
    "build_fmu",
    "build_table",
    "check_fmu_archive",
    "export_fmu",
    "export_trivial_fmu",
    "run_libcosim",
    "simulate_cs",
    "simulate_me",
    "spec_from_plant",
    "step_input",
    "trivial_spec",
    "tool_version",
    "validate_fmu",
]

__version__ = tool_version()
