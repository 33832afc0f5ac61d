"""The report's robustness section: a small sweep of the computed-torque loop, self-contained.

:func:`sweep_section` runs a 2-D grid (payload mass x friction scale, unknown to the
controller) with the compiled closed loop on the embedded Dask cluster, writes its table,
summary and plots under ``out`` and adds a heading, a paragraph, the summary table and the
figures to the :class:`~workbench.report.Report` it is given. One call from the demo.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

from .report import Report

__all__ = ["DEMO_BOUND", "DEMO_SWEEP", "SWEEP_DIR", "sweep_section"]

#: The demo's sweep: computed torque on a 6 x 6 grid of plant payload and friction.
DEMO_SWEEP = {"controller": "ct", "method": "grid", "samples": 6, "seed": 0,
              "vary": {"payload_mass": [0.0, 3.0], "friction_scale": [0.5, 2.0]}}

#: The sweep's folder in the report's folder.
SWEEP_DIR = "sweep"
#: The error bound whose exceedance the section reports: 1 mrad (revolute joints) or 1 mm (prismatic).
DEMO_BOUND = 1e-3


def sweep_section(report: Report, out: Path, robot: str, *, plots: bool = True, rate_hz: float = 1000.0,
                  bandwidth: float | None = None, note: Callable[[str], None] | None = None) -> list[Path]:
    """Run the demo sweep on ``robot`` (name or file) into ``out/sweep`` and add its section to ``report``.

    The shape of the sections of :mod:`workbench.sections` (``out`` is the report's folder); ``plots``
    False: the table and summary only. The bound of the exceedance probability is :data:`DEMO_BOUND`.
    Returns the files written.
    """
    from closed_loop.sweep import nominal_run, run_sweep
    from closed_loop.sweep_spec import spec_from_dict

    data = {**DEMO_SWEEP, "robot": str(robot), "rate_hz": rate_hz}
    if bandwidth is not None:
        data["bandwidth"] = bandwidth
    spec = spec_from_dict({**data, "bound": DEMO_BOUND}, "demo sweep")
    nominal = float(nominal_run(spec).max_error.max())  # the same spec: its setup serves the worst-case re-run too
    result = run_sweep(spec, out / SWEEP_DIR, workers=min(2, os.cpu_count() or 1), plots=plots)
    s = result.summary
    b = s["bound"]
    q = s["max_error_quantiles"]
    w = s["worst_case"]
    unit = s["max_error_unit"]
    report.heading("Robustness sweep")
    report.text(f"The computed-torque design on {spec.n_cases} plants: payload {spec.vary['payload_mass'][0]:g} to "
                f"{spec.vary['payload_mass'][1]:g} kg and friction x{spec.vary['friction_scale'][0]:g} to "
                f"x{spec.vary['friction_scale'][1]:g} (a {spec.samples} x {spec.samples} grid), unknown to the "
                f"controller; each case is the whole {rate_hz:g} Hz task in the compiled closed loop, run on "
                f"{result.workers} Dask worker processes in {result.wall_time:.1f} s (`manip sweep`). "
                f"On the exact plant the max error is {nominal:.3g} {unit}; the bound is {DEMO_BOUND:g} {unit}.")
    report.table(["quantity", "value"], [
        ["cases (diverged)", f"{s['cases']} ({s['diverged']})"],
        [f"max error, median [{unit}]", q["0.5"]],
        [f"max error, 95 % [{unit}]", q["0.95"]],
        [f"P(max error > {b['max_error']:.3g})", f"{b['probability']:.3f} (95 % CI {b['ci95'][0]:.3f} to {b['ci95'][1]:.3f})"],
        ["worst case", ", ".join(f"{k} = {v:.3g}" for k, v in w["parameters"].items()) + f": {w['max_error']:.3g}"],
    ])
    captions = {"heatmap_max_error": "max error over the payload x friction grid",
                "hist_max_error": "distribution of the worst-joint max error, the bound dashed",
                "worst_case_tracking_error": "the worst case re-run: tracking error per joint"}
    for stem, caption in captions.items():
        path = out / SWEEP_DIR / f"{stem}.png"
        if path.is_file():
            report.image(path.relative_to(out).as_posix(), caption)
    if note is not None:
        note(f"{spec.n_cases} cases in {result.wall_time:.1f} s; P(max error > {b['max_error']:.3g}) = "
             f"{b['probability']:.3f}")
    return list(result.files)
