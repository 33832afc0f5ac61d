"""The report's retime section: the reference task at the fastest the motors allow, and tracked there.

:func:`retime_section` retimes the robot's reference task (the SCARA's is the seed's pick-and-place) within
90 % of the motor torque limits, along the straight segments (stopping at every waypoint, as the task is
planned) and along a C2 spline through the waypoints; writes ``out/retime/`` (each motion's trajectory CSV,
``retime.json`` and figure) and tracks both motions under computed torque on the nonlinear plant with the
limits on, then adds a heading, a paragraph, one table and the figures. One call from the demo; cheap (the
retimes take a tenth of a second each, the two closed loops a few seconds at most).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable

import numpy as np

from .outputs import save_figure, write_json
from .report import Report

if TYPE_CHECKING:  # pragma: no cover
    from control_design.design import RobotDesign
    from model.robot import Robot
    from model.tasks import Task

__all__ = ["RETIME_DIR", "RETIME_MARGIN", "retime_section"]

#: The section's folder in the report's folder.
RETIME_DIR = "retime"
#: Share of the motor torque limits the retimed motions use (the rest is the tracking loop's).
RETIME_MARGIN = 0.9


def retime_section(report: Report, out: Path, robot: "Robot", task: "Task", design: "RobotDesign", *,
                   rate_hz: float = 1000.0, plots: bool = True, note: Callable[[str], None] | None = None) -> list[Path]:
    """Retime ``task`` within :data:`RETIME_MARGIN` of ``design``'s torque limits, track it with ``design``
    (computed torque), write ``out/retime`` and add the section to ``report``; returns the files written."""
    from closed_loop.simulate import simulate_tracking
    from model.trajectory_file import write_trajectory

    from .cmd_retime import retime_task
    from .retime_plots import retime_figure

    folder = out / RETIME_DIR
    folder.mkdir(parents=True, exist_ok=True)
    planned = task.n_segments * task.segment_time
    files: list[Path] = []
    rows = []
    figures = []
    for blend, label in ((False, "straight segments, stopping at each waypoint"), (True, "C2 spline, not stopping")):
        kind = "blend" if blend else "straight"
        motion = retime_task(robot, task, blend=blend, torque_margin=RETIME_MARGIN)
        traj = motion.trajectory()
        files.append(write_trajectory(folder / f"{kind}.csv", traj, robot.description.joint_names))
        files.append(write_json(folder / f"{kind}.json", motion.to_dict()))
        met = simulate_tracking(robot, design.controller(rate_hz), traj).metrics()
        peak = float(np.max(met.peak_motor_torque / design.tau_m_max))
        rows.append([label, motion.duration, planned / motion.duration, 100.0 * motion.check().torque * RETIME_MARGIN,
                     float(np.max(met.max_error)), 100.0 * peak, 100.0 * float(np.max(met.saturated_fraction))])
        if plots:
            path = save_figure(retime_figure(robot, motion, title=f"{robot.name}: {task.name} retimed ({kind})"),
                               folder / f"{kind}.png")
            files.append(path)
            figures.append((path.relative_to(out).as_posix(), f"{label}: path speed against its limits, "
                                                              "motor torques against theirs"))
        if note is not None:
            note(f"{kind}: {motion.duration:.3f} s ({planned / motion.duration:.2f} x faster), tracked with peak "
                 f"{100 * peak:.1f} % of a motor limit, saturated {100 * float(np.max(met.saturated_fraction)):g} %")
    report.heading("Retimed within the limits")
    report.text(f"The task `{task.name}` is planned as {task.n_segments} quintic segments of {task.segment_time:g} s "
                f"({planned:g} s). `manip retime` finds the fastest motion along the same path that keeps every motor "
                f"within {100 * RETIME_MARGIN:g} % of its torque limit (the full inverse dynamics: link inertias, "
                "reflected rotors, gears, friction); the rest of each motor's torque is left to the feedback. Each "
                f"motion is then tracked under computed torque at {rate_hz:g} Hz on the nonlinear plant with the "
                "torques clipped at the limits (the files are in `retime/`; `manip track --trajectory` follows them).")
    report.table(["path", "duration [s]", "faster by", "torque used [% of limit]", "tracked: max error",
                  "tracked: peak torque [% of limit]", "saturated [% of run]"], rows)
    if figures:
        report.figures(figures)
    return files
