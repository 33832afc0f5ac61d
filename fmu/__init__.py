"""FMU export: the robot as a native FMI 2.0 or FMI 3.0 FMU (Model Exchange and Co-Simulation in one file).

Data flow: :mod:`fmu.variables` (the one variable table) -> :mod:`fmu.build`
(CasADi C, the wrapper of ``fmu/c/``, the host's compiler (``$CC``, else gcc or cc) and, for
the other platforms, zig's clang through :mod:`fmu.cross` with the table of
:mod:`fmu.platforms`, zip) -> :mod:`fmu.simulate` (FMPy) and :mod:`fmu.cosim` (libcosim, FMI
2.0 only) -> :mod:`fmu.validate` (all of it checked against the Python model). An FMU is read through
:mod:`fmu.opened` (``open_fmu``) and run through :mod:`fmu.instance` (``Instance``). It exports and validates any model spec and knows
nothing of controllers: closed loops through FMUs are :mod:`closed_loop`.
"""

from model.lazy import export_names, lazy_exports
from model.version import __version__ as __version__

#: Submodule -> the names the package exports from it, imported on first use (:mod:`model.lazy`).
_EXPORTS = {
    "archive": ("FmuArchiveError", "check_fmu_archive"),
    "build": ("FmuBuildError", "build_driver", "build_fmu", "export_fmu", "export_trivial_fmu", "tool_version"),
    "cross": ("compile_shared",),
    "platforms": ("PLATFORMS", "Platform", "platform_folder", "resolve_platforms"),
    "cosim": ("CosimError", "CosimResult", "run_libcosim"),
    "simulate": ("SimulationResult", "simulate_cs", "simulate_me", "step_input"),
    "validate": ("ValidationReport", "validate_fmu"),
    "variables": ("ModelSpec", "VariableTable", "build_table", "spec_from_plant", "trivial_spec"),
    "export_checks": ("SingularInertiaError", "check_inertia"),
    "limits": ("limits_h",),
    "ls_ref": ("read_experiment", "replay_problems"),
}

__all__ = export_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
