"""Closed loops: a controller driving a robot plant, in Python or through FMUs.

The layer above the design (:mod:`control_design`) and the FMU export
(:mod:`fmu`): one :class:`~closed_loop.schedule.Schedule` (control instants
``t0 + k h``, references, start state, RK4 sub-steps) and one
:class:`~closed_loop.result.TrackingResult` for every loop:

* :func:`~closed_loop.simulate.simulate_tracking` - the pure Python loop (compiled dynamics, RK4);
* :func:`~closed_loop.kernel.closed_loop_kernel` - the same loop compiled whole: one C call per run;
* :func:`~closed_loop.sweep.run_sweep` (spec in :mod:`~closed_loop.sweep_spec`) - thousands of
  compiled runs over varied plants and designs on Dask; it runs closed loops, so it lives here, above
  :mod:`control_design`;
* :func:`~closed_loop.master.run_closed_loop` - the plant FMU (and a controller FMU) through FMPy;
* :func:`~closed_loop.master.run_libcosim_closed_loop` - both FMUs connected in libcosim;
* :class:`~closed_loop.delay.OnePeriodDelay` - the Python loop as libcosim's Jacobi coupling runs it;
* :mod:`~closed_loop.controller_fmu` - the control laws as FMUs;
* :mod:`~closed_loop.plots` (``manip track`` is :mod:`workbench.cmd_track`).

Dependencies point one way: ``model <- control_design <- closed_loop -> fmu``.
"""

from model.lazy import export_names, lazy_exports

#: Submodule -> the names the package exports from it, imported on first use (:mod:`model.lazy`).
_EXPORTS = {
    "controller_fmu": (
        "CONTROLLER_FMU_KINDS", "ControllerFmuReport", "controller_fmu_kind", "controller_spec",
        "export_controller_fmu", "validate_controller_fmu"
    ),
    "delay": ("OnePeriodDelay",),
    "kernel": ("ClosedLoopKernel", "KernelRun", "closed_loop_kernel"),
    "master": ("closed_loop_through_fmu", "run_closed_loop", "run_closed_loop_me",
               "run_libcosim_closed_loop"),
    "plots": ("joint_plot", "torque_plot", "tracking_error_plot"),
    "progress": ("ProgressLine",),
    "result": ("TrackingMetrics", "TrackingResult"),
    "schedule": ("MAX_SUBSTEP", "Schedule", "default_substeps"),
    "simulate": ("simulate_tracking",),
    "sweep_spec": ("SweepSpec", "SweepSpecError", "load_spec", "spec_from_dict"),
    "sweep": ("SweepResult", "run_sweep"),
}

__all__ = export_names(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
