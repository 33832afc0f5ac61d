"""The sections of the demo report: one function per section.

Every section function has the same shape::

    def xxx_section(report: Report, out: Path, <what it shows>, *, plots: bool = True) -> list[Path]

It appends its heading, text, tables and figures to ``report``, writes the files
it draws or dumps under ``out`` (``plots=False``: no PNG or GIF), and returns the
paths it wrote. Images are added by their path relative to ``out``; no absolute
path of this machine goes into the report. A new section (a sweep, a workspace
figure) is one more function of this shape, called from :func:`workbench.demo.run_demo`.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from model.files import write_atomic

from .cmd_design import DESIGN_HEADER, design_rows, save_design_plots
from .cmd_track import TRACKING_HEADER, save_tracking_plots, tracking_rows
from .formatting import SATURATION_HEADER, format_build, format_info, saturation_rows, saturation_warnings
from .outputs import write_json
from .report import Report

if TYPE_CHECKING:
    from closed_loop.result import TrackingResult
    from control_design.design import RobotDesign
    from control_design.joint_model import TorqueLimits
    from fmu.validate import ValidationReport
    from model.codegen import BuildInfo
    from model.robot import Robot
    from model.trajectory import Trajectory

__all__ = ["design_section", "fmu_section", "motion_section", "robot_section", "task_section",
           "torque_limit_section", "tracking_section"]


def _rel(path: Path, out: Path) -> str:
    return path.relative_to(out).as_posix()


def robot_section(report: Report, out: Path, robot: Robot, build: BuildInfo) -> list[Path]:
    """The robot's joint table, inertial and motor data (exact values) and its compiled dynamics."""
    report.heading("Robot")
    report.code(format_info(robot.description))
    report.text("Dynamics: symbolic Lagrange model (CasADi), checked against Newton-Euler and Pinocchio in the tests; "
                f"compiled C, {format_build(build, full_path=False)}.")
    return []


def task_section(report: Report, out: Path, robot: Robot, trajectory: Trajectory, name: str) -> list[Path]:
    """The reference task: its waypoints and timing."""
    report.heading("Task")
    report.text(f"`{name}`: quintic joint segments through the waypoints below, stopping at each; "
                f"{len(trajectory.t)} samples over {trajectory.t[-1] - trajectory.t[0]:g} s.")
    units = ["rad" if lk.is_revolute else "m" for lk in robot.description.links]
    report.table(["t [s]"] + [f"q{j + 1} [{u}]" for j, u in enumerate(units)],
                 [[float(t), *map(float, q)] for t, q in zip(trajectory.t_via, trajectory.q_via)])
    return []


def torque_limit_section(report: Report, out: Path, limits: TorqueLimits, joints: list[str]) -> list[Path]:
    """The motor torque limits, where each comes from, and the needs the default rule sized them on."""
    report.heading("Motor torque limits", 3)
    report.text("Every controller clips its motor torques at these limits. A limit comes from the robot file "
                "(`torque_limit`, a motor rating) or, when the file states none, from the default rule: "
                f"{limits.rule}.")
    report.table(["motor", "joint", "limit [N m]", "from", "task peak [N m]", "gravity hold [N m]"],
                 [[k + 1, name, float(limits.tau_m_max[k]), limits.provenance(k), float(limits.tau_m_peak_task[k]),
                   float(limits.tau_m_hold[k])] for k, name in enumerate(joints)])
    return []


def design_section(report: Report, out: Path, design: RobotDesign, label: str, *, plots: bool = True) -> list[Path]:
    """One controller's design: gains, margins (continuous and sampled), step metrics; Bode and step plots."""
    kind = design.kind
    report.heading(f"{label} (`{kind}`)", 3)
    if kind == "ct":
        report.text("Outer loops designed as double integrators (gains in 1/s^2 and 1/s, joint side); the inverse "
                    "dynamics cancels the coupling when the model is exact.")
    else:
        report.text("Gains on the motor side (N m/rad, N m s/rad); effective inertia B_ii/G^2 at its workspace "
                    "maximum; coupling = the other joints' inertia, Coriolis and gravity torques reduced by 1/G.")
    report.table(DESIGN_HEADER, design_rows(design))
    report.text(f"`_d`: the loop sampled at {design.rate_hz:g} Hz (zero-order hold and one period of delay); "
                "PM phase margin, GM gain margin, w_c gain crossover, w_bw closed-loop bandwidth, OS overshoot, "
                "t_s settling time (2 %).")
    folder = out / f"design_{kind}"
    folder.mkdir(parents=True, exist_ok=True)
    files = [write_json(folder / "design.json", design.to_dict())]
    if plots:
        paths = save_design_plots(design, folder)
        report.figures([(_rel(p, out), f"{label}: {p.stem.replace('_', ' ', 1)} (continuous and sampled)")
                        for p in paths])
        files += paths
    return files


def fmu_section(report: Report, out: Path, fmu_path: Path, validation: ValidationReport) -> list[Path]:
    """The exported FMU and its validation: verdict, one row per numerical check, the full log folded."""
    named = dataclasses.replace(validation, fmu=fmu_path.name)  # the file's name, not this machine's folder
    summary = named.format()
    files = [write_atomic(out / "fmu_validation.txt", summary + "\n")]
    report.heading("FMU")
    verdict = "passed every check" if validation.ok else f"FAILED {len(validation.problems())} checks"
    report.text(f"`{fmu_path.name}`: FMI 2.0, Co-Simulation and Model Exchange in one file, C only at run time; "
                f"validation {verdict} (`manip validate-fmu {fmu_path.name}`).")
    report.table(["", "check", "figure", "value", "bound"],
                 [["ok" if c.passed else "FAIL", c.name, c.what, float(c.value), float(c.bound)]
                  for c in validation.checks])
    for problem in validation.description_problems + validation.binary_problems:
        report.text(f"Problem: {problem}")
    report.details("The whole validation log (also in `fmu_validation.txt`)", summary)
    return files


def tracking_section(report: Report, out: Path, label: str, result: TrackingResult, limits: TorqueLimits, *,
                     python_diff: float | None = None, plots: bool = True,
                     warn: Callable[[str], None] | None = None) -> list[Path]:
    """One closed-loop run: errors, peak torques, saturation (which motor, how long, which limit), plots.

    ``python_diff``: largest difference from the same loop in pure Python (rad or m), if it was run;
    ``warn``: called with one line per motor that reached its torque limit.
    """
    met = result.metrics()
    report.heading(label, 3)
    text = f"Plant FMU + Python `{result.controller}` controller at {result.rate_hz:g} Hz"
    if python_diff is not None:
        text += f"; largest difference from the pure Python closed loop: {python_diff:.3e} (rad or m)"
    report.text(text + ".")
    report.table(TRACKING_HEADER, tracking_rows(met))
    lines = saturation_warnings(met, limits)
    if lines:
        report.text(f"Saturation: {len(lines)} of {len(met.joints)} motors reached their torque limit; past it the "
                    "loop is not the designed one. " + " ".join(f"{line[0].upper()}{line[1:]}." for line in lines))
        report.table(SATURATION_HEADER, saturation_rows(met, limits))
    else:
        report.text("No motor reached its torque limit.")
    for line in lines:
        if warn is not None:
            warn(line)
    if not plots:
        return []
    paths = save_tracking_plots(result, out, prefix=f"track_{result.controller}_", limits=limits)
    report.figures([(_rel(p, out), f"{label}: {p.stem.split('_', 2)[2].replace('_', ' ')}") for p in paths])
    return paths


def motion_section(report: Report, out: Path, robot: Robot, result: TrackingResult, label: str,
                   progress: Callable[[int, int], object] | None = None) -> list[Path]:
    """A GIF of the arm along a closed-loop run."""
    from .animation import animate_arm  # matplotlib's animation writer: only when the GIF is drawn

    gif = animate_arm(robot, result.t, result.q, out / f"{robot.description.identifier}_motion.gif",
                      progress=progress)
    report.heading("Motion")
    report.image(_rel(gif, out), f"{robot.name} following the task under {label} (through the FMU)")
    return [gif]
