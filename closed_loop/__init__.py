"""Closed loops: a controller driving a robot plant, in Python or through FMUs.

The layer above the design (:mod:`control_design`) and the FMU export
(:mod:`fmu`): one :class:`~closed_loop.schedule.Schedule` (control instants
``t0 + k h``, references, start state, RK4 sub-steps) and one
:class:`~closed_loop.result.TrackingResult` for every loop:

* :func:`~closed_loop.simulate.simulate_tracking` - the pure Python loop (compiled dynamics, RK4);
* :func:`~closed_loop.kernel.closed_loop_kernel` - the same loop compiled whole: one C call per run;
* :func:`closed_loop.sweep` (:mod:`closed_loop.sweep`, spec in :mod:`~closed_loop.sweep_spec`) - thousands of
  compiled runs over varied plants and designs on Dask; it runs closed loops, so it lives here, above
  :mod:`control_design`;
* :func:`~closed_loop.master.run_closed_loop` - the plant FMU (and a controller FMU) through FMPy;
* :func:`~closed_loop.master.run_libcosim_closed_loop` - both FMUs connected in libcosim;
* :class:`~closed_loop.delay.OnePeriodDelay` - the Python loop as libcosim's Jacobi coupling runs it;
* :mod:`~closed_loop.controller_fmu` - the control laws as FMUs;
* :mod:`~closed_loop.plots` (``manip track`` is :mod:`workbench.cmd_track`).

Dependencies point one way: ``model <- control_design <- closed_loop -> fmu``.
"""

from .controller_fmu import (CONTROLLER_FMU_KINDS, ControllerFmuReport, controller_fmu_kind, controller_spec,
                             export_controller_fmu, validate_controller_fmu)
from .delay import OnePeriodDelay
from .kernel import ClosedLoopKernel, KernelRun, closed_loop_kernel
from .master import closed_loop_through_fmu, run_closed_loop, run_closed_loop_me, run_libcosim_closed_loop
from .plots import joint_plot, torque_plot, tracking_error_plot
from .progress import ProgressLine
from .result import TrackingMetrics, TrackingResult
from .schedule import MAX_SUBSTEP, Schedule, default_substeps
from .simulate import simulate_tracking
from .sweep_spec import SweepSpec, SweepSpecError, load_spec, spec_from_dict
from .sweep import SweepResult, sweep  # noqa: E402 - the function `closed_loop.sweep`; the module stays importable

__all__ = [
    "CONTROLLER_FMU_KINDS",
    "ClosedLoopKernel",
    "KernelRun",
    "SweepResult",
    "SweepSpec",
    "SweepSpecError",
    "ControllerFmuReport",
    "MAX_SUBSTEP",
    "OnePeriodDelay",
    "ProgressLine",
    "Schedule",
    "TrackingMetrics",
    "TrackingResult",
    "closed_loop_kernel",
    "closed_loop_through_fmu",
    "controller_fmu_kind",
    "controller_spec",
    "default_substeps",
    "export_controller_fmu",
    "joint_plot",
    "load_spec",
    "run_closed_loop",
    "run_closed_loop_me",
    "run_libcosim_closed_loop",
    "simulate_tracking",
    "spec_from_dict",
    "sweep",
    "torque_plot",
    "tracking_error_plot",
    "validate_controller_fmu",
]
