"""The demo's drive-train section: the robot file's P-PI cascade on the elastic plant, its reference, its Bode plot.

For a robot with drive trains (elastic gears, current loops, friction peaks: :mod:`model.drive_train`) and a
``[cascade]`` table: the cascade's margins and gear resonances on the elastic joint model and on the rigid one
(:mod:`control_design.cascade_design`), the Bode plot of the elastic speed loops, and the closed loop along the
robot's first task with its link-side speeds over the ``[cascade] reference`` result when the file names one.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Callable

import numpy as np

from closed_loop import TrackingResult, simulate_tracking
from control_design.cascade import cascade_from_robot
from control_design.cascade_design import bode_figure, cascade_loops
from control_design.reference import reference_task_name
from model.robot import Robot
from model.tasks import find_task

from .cmd_track import TRACKING_HEADER, tracking_rows, write_tracking_csv
from .outputs import save_figure
from .report import Report

__all__ = ["drive_train_section", "reference_speeds", "speeds_figure"]


def reference_speeds(robot: Robot) -> tuple[np.ndarray, np.ndarray] | None:
    """``(t, W)`` of the ``[cascade] reference`` CSV (times s; (N, n) link-side speeds rad/s), or None."""
    desc = robot.description
    name = desc.extra.get("cascade", {}).get("reference")
    if not name:
        return None
    data = np.genfromtxt(Path(desc.path).resolve().parent / name, delimiter=",", skip_header=1)
    return data[:, 0], data[:, 1:1 + desc.n]


def speeds_figure(result: TrackingResult, reference: tuple[np.ndarray, np.ndarray] | None) -> Any:
    """Each joint's link-side speed, the run over the reference (if any): one panel per joint."""
    from matplotlib.figure import Figure

    n = result.q.shape[1]
    cols = 2 if n > 1 else 1
    rows = math.ceil(n / cols)
    fig = Figure(figsize=(9.0, 2.2 * rows))
    t_end = reference[0][-1] if reference is not None else result.t[-1]
    keep = result.t <= t_end + 1e-12
    for j in range(n):
        ax = fig.add_subplot(rows, cols, j + 1)
        if reference is not None:
            ax.plot(reference[0], reference[1][:, j], color="k", lw=2.5, alpha=0.35, label="reference")
        ax.plot(result.t[keep], result.qd[keep, j], color="C0", lw=1.0, label="workbench")
        ax.set_title(result.joints[j], fontsize=9)
        ax.set_ylabel("qd, rad/s", fontsize=8)
        ax.tick_params(labelsize=7)
        if j == 0:
            ax.legend(fontsize=7)
    fig.supxlabel("t, s", fontsize=9)
    fig.tight_layout()
    return fig


def drive_train_section(report: Report, out: Path, robot: Robot, *, plots: bool = True,
                        note: Callable[[str], object] | None = None) -> tuple[list[Path], TrackingResult]:
    """Write the section (module docstring); returns the files written and the closed-loop run."""
    files: list[Path] = []
    report.heading("Drive trains: the P-PI cascade on the elastic plant")
    loops = cascade_loops(robot)
    report.text("Per joint the motor-side cascade (position P, speed PI, current demand) on the joint model with its "
                "gear (elastic: two masses on a spring), the current loop and the arm frozen at rest; margins by "
                "python-control, on the elastic model and on the rigid one a rigid-model design would assume.")
    rows = []
    for c in loops:
        gm, pm, _, wcp = c.margins["speed"]
        gm_r, pm_r, _, wcp_r = c.margins_rigid["speed"]
        rows.append([c.name, "-" if math.isnan(c.resonance) else f"{c.resonance:.1f}",
                     "-" if math.isnan(c.antiresonance) else f"{c.antiresonance:.1f}", f"{wcp:.1f}", f"{pm:.1f}",
                     f"{gm:.2f}", f"{wcp_r:.1f}", f"{pm_r:.1f}", f"{c.margins['position'][1]:.1f}"])
    report.table(["joint", "w_r [rad/s]", "w_a [rad/s]", "speed crossover", "PM [deg]", "GM", "rigid: crossover",
                  "rigid: PM", "position PM"], rows)
    if plots:
        path = save_figure(bode_figure(loops), out / "cascade_bode.png")
        files.append(path)
        report.image(path.name, "Speed loops of the elastic joints: elastic model (solid) and rigid model (dotted); "
                                "dashed: the gear resonance")
    controller = cascade_from_robot(robot)
    task = find_task(robot.description, reference_task_name(robot))
    traj = task.trajectory(controller.dt)
    reference = reference_speeds(robot)
    if note is not None:
        note(f"cascade at {controller.rate_hz:g} Hz along {task.name!r}")
    result = simulate_tracking(robot, controller, traj)
    files.append(write_tracking_csv(result, out / "cascade_tracking.csv"))
    report.text(f"Closed loop: the cascade at {controller.rate_hz:g} Hz (Python loop, the plant's fixed-step rule "
                f"in C, {result.substeps} RK4 sub-steps per period) along the task `{task.name}`, from the static "
                f"equilibrium (gears twisted to hold gravity).")
    report.table(TRACKING_HEADER, tracking_rows(result.metrics()))
    if reference is not None:
        t_ref, W = reference
        span = W.max(axis=0) - W.min(axis=0)
        sim = np.column_stack([np.interp(t_ref, result.t, result.qd[:, j]) for j in range(robot.n)])
        worst = np.abs(sim - W).max(axis=0) / np.where(span > 0, span, 1.0)
        report.text("Largest difference from the reference result, % of each joint's range (every reference time, "
                    "friction events included): " + ", ".join(f"{nm} {100 * v:.3f}" for nm, v in
                                                               zip(result.joints, worst)) + ".")
    if plots:
        path = save_figure(speeds_figure(result, reference), out / "cascade_speeds.png")
        files.append(path)
        report.image(path.name, "Link-side joint speeds: the workbench's run (blue) over the reference (grey)"
                     if reference is not None else "Link-side joint speeds")
    return files, result
