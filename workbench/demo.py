"""``manip demo``: the whole workbench on one robot, end to end, into one report.

Steps: build the model (compiled dynamics), design decentralised PD and
computed-torque loops, export and validate the plant FMU, run the reference
task (the seed's pick-and-place on the SCARA) closed loop through the FMU and
compare it with the pure Python closed loop, animate the arm, and write
``report.md`` / ``report.html`` with every number and plot.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, TextIO

import numpy as np

import fmu
from closed_loop import TrackingResult, closed_loop_through_fmu, simulate_tracking
from control_design import design_robot, reference_task
from control_design.design import RobotDesign
from control_design.reference import reference_task_name
from model.files import write_atomic
from model.robot import load_robot

from .animation import animate_arm
from .cmd_design import save_design_plots
from .cmd_track import save_tracking_plots
from .formatting import format_build, format_info
from .outputs import write_json
from .report import Report

__all__ = ["DemoResult", "run_demo", "Progress"]

#: Controllers the demo designs and runs: (kind, label).
DEMO_CONTROLLERS = (("pd", "decentralised PD"), ("ct", "computed torque"))


class Progress:
    """Numbered step lines with elapsed time on a text stream."""

    def __init__(self, total: int, stream: TextIO = sys.stdout) -> None:
        self.total, self.k, self.stream, self.t0 = total, 0, stream, time.perf_counter()

    def step(self, text: str) -> None:
        self.k += 1
        print(f"[{self.k}/{self.total}] {text} (t = {time.perf_counter() - self.t0:.1f} s)", file=self.stream, flush=True)

    def note(self, text: str) -> None:
        print(f"      {text}", file=self.stream, flush=True)


@dataclass
class DemoResult:
    """What the demo wrote and the headline numbers."""

    out: Path
    report_md: Path
    report_html: Path
    fmu_path: Path
    fmu_ok: bool
    files: list[Path] = field(default_factory=list)
    max_error: dict[str, list[float]] = field(default_factory=dict)
    fmu_vs_python: dict[str, float] = field(default_factory=dict)


def _rel(path: Path, out: Path) -> str:
    return path.relative_to(out).as_posix()


def _design_section(report: Report, kind: str, label: str, design: RobotDesign, out: Path) -> list[Path]:
    report.heading(f"{label} ({kind})", 3)
    assert design.reports is not None
    if kind == "ct":
        report.text("Outer loops designed as double integrators (gains in 1/s^2 and 1/s, joint side); the inverse "
                     "dynamics cancels the coupling when the model is exact.")
    else:
        report.text("Gains on the motor side (N m/rad, N m s/rad); effective inertia B_ii/G^2 at its workspace "
                     "maximum; coupling = the other joints' inertia, Coriolis and gravity torques reduced by 1/G.")
    rows = []
    for rep in design.reports:
        gm = rep.gain_margin_d
        rows.append([rep.name, rep.Kp_m, rep.Kd_m, rep.crossover, rep.phase_margin, rep.phase_margin_d,
                     20 * math.log10(gm) if math.isfinite(gm) else "inf", rep.bandwidth, rep.rise_time,
                     rep.overshoot, rep.settling_time])
    report.table(["joint", "Kp", "Kd", "w_c [rad/s]", "PM [deg]", f"PM at {design.rate_hz:g} Hz [deg]",
                  "GM sampled [dB]", "bandwidth [rad/s]", "rise [s]", "overshoot [%]", "settling [s]"], rows)
    folder = out / f"design_{kind}"
    folder.mkdir(parents=True, exist_ok=True)
    write_json(folder / "design.json", design.to_dict())
    paths = save_design_plots(design, folder)
    for path in paths:
        report.image(_rel(path, out), f"{label}: {path.stem.replace('_', ' ', 1)} (continuous and sampled)")
    return [folder / "design.json", *paths]


def _tracking_rows(result: TrackingResult) -> list[list[object]]:
    met = result.metrics()
    return [[j, u, r, m, tq] for j, u, r, m, tq in zip(met.joints, met.units, met.rms_error, met.max_error,
                                                       met.peak_motor_torque)]


def run_demo(robot_name: str = "scara", out: str | Path = "out", *, bandwidth: float = 50.0, damping: float = 0.7,
             rate_hz: float = 1000.0, gif: bool = True, stream: TextIO = sys.stdout) -> DemoResult:
    """Run the end-to-end demo on ``robot_name`` (built-in or TOML) and write everything under ``out``.

    Parameters
    ----------
    robot_name
        Built-in name or TOML path.
    out
        Output folder (created).
    bandwidth, damping, rate_hz
        Design specification: closed-loop bandwidth (rad/s), damping, control rate (Hz).
    gif
        Also write the animation of the arm (the slowest step, about 10 s).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    progress = Progress(9 if gif else 8, stream)
    files: list[Path] = []

    progress.step(f"loading {robot_name} and building its compiled dynamics")
    robot = load_robot(robot_name)
    build = format_build(robot.dynamics.compile())
    progress.note(build)
    report = Report(f"{robot.name}: manipulator-workbench report")
    report.text(f"Generated by `manip demo --robot {robot_name}` on {time.strftime('%Y-%m-%d %H:%M:%S')}. "
                f"Specification: bandwidth {bandwidth:g} rad/s, damping {damping:g}, control rate {rate_hz:g} Hz.")
    report.heading("Robot")
    report.code(format_info(robot.description))
    report.text(f"Dynamics: symbolic Lagrange model (CasADi), checked against Newton-Euler and Pinocchio in the "
                f"tests; compiled C {build}.")

    trajectory = reference_task(robot)
    report.heading("Task")
    task_name = reference_task_name(robot).replace("_", "-")
    report.text(f"{task_name}: quintic joint segments through the waypoints below, stopping at each; "
                f"{len(trajectory.t)} samples over {trajectory.t[-1] - trajectory.t[0]:g} s.")
    units = ["rad" if lk.is_revolute else "m" for lk in robot.description.links]
    report.table(["t [s]"] + [f"q{j + 1} [{u}]" for j, u in enumerate(units)],
                 [[t, *q] for t, q in zip(trajectory.t_via, trajectory.q_via)])

    progress.step("designing the joint loops (decentralised PD and computed torque)")
    report.heading("Control design")
    designs = {}
    for kind, label in DEMO_CONTROLLERS:
        designs[kind] = design_robot(robot, kind, bandwidth, damping, rate_hz=rate_hz)
        files += _design_section(report, kind, label, designs[kind], out)
        progress.note(f"{label}: {len(designs[kind].loops)} loops designed")

    progress.step("exporting the plant as an FMI 2.0 FMU (Co-Simulation + Model Exchange)")
    fmu_path = fmu.export_fmu(robot, out / f"{robot.description.identifier}.fmu", step=1.0 / rate_hz)
    files.append(fmu_path)
    progress.note(f"wrote {fmu_path}")

    progress.step("validating the FMU (FMPy checks, CS and ME against the Python model, state, derivatives, libcosim)")
    validation = fmu.validate_fmu(fmu_path, progress=lambda msg: progress.note(msg))
    summary = validation.format()
    write_atomic(out / "fmu_validation.txt", summary + "\n")
    files.append(out / "fmu_validation.txt")
    report.heading("FMU")
    report.text(f"`{fmu_path.name}`: FMI 2.0, Co-Simulation and Model Exchange in one file, C only at run time.")
    report.code(summary)

    progress.step("closed loop through the plant FMU, and the same loop in pure Python")
    report.heading("Closed-loop tracking through the FMU")
    max_error: dict[str, list[float]] = {}
    fmu_vs_python: dict[str, float] = {}
    fmu_results: dict[str, TrackingResult] = {}
    for kind, label in DEMO_CONTROLLERS:
        design = designs[kind]
        via_fmu = closed_loop_through_fmu(robot, design, trajectory, out / "cosim", controller_fmu=False,
                                          plant_fmu=fmu_path)
        python = simulate_tracking(robot, design.controller(rate_hz), trajectory)
        fmu_results[kind] = via_fmu
        diff = float(np.max(np.abs(via_fmu.q - python.q)))
        fmu_vs_python[kind] = diff
        max_error[kind] = via_fmu.metrics().max_error.tolist()
        report.heading(label, 3)
        report.text(f"Plant FMU + Python controller at {rate_hz:g} Hz; largest difference from the pure Python "
                    f"closed loop: {diff:.3e} (rad or m).")
        report.table(["joint", "unit", "RMS error", "max error", "peak motor torque [N m]"], _tracking_rows(via_fmu))
        paths = save_tracking_plots(via_fmu, out, prefix=f"track_{kind}_")
        files += paths
        for path in paths:
            report.image(_rel(path, out), f"{label}: {path.stem.split('_', 2)[2].replace('_', ' ')}")
        progress.note(f"{label}: max error {np.max(max_error[kind]):.3e}, FMU vs Python {diff:.3e}")
    metrics = {kind: fmu_results[kind].metrics().to_dict() for kind in fmu_results}
    write_json(out / "metrics.json", metrics)
    files.append(out / "metrics.json")

    # --- sweep section (workbench/report_sweep.py): one self-contained call ---
    progress.step("a robustness sweep: computed torque over payload x friction, compiled loops on Dask")
    from .report_sweep import sweep_section

    files += sweep_section(report, robot_name, out / "sweep", rate_hz=rate_hz, bandwidth=bandwidth, note=progress.note,
                           rel_to=out)
    # --- end of the sweep section ---

    if gif:
        progress.step("animating the arm along the closed-loop motion")
        res = fmu_results["ct"]
        gif_path = animate_arm(robot, res.t, res.q, out / f"{robot.description.identifier}_motion.gif",
                               progress=lambda k, total: k % 50 == 0 and progress.note(f"frame {k} of {total}"))
        files.append(gif_path)
        report.heading("Motion")
        report.image(_rel(gif_path, out), f"{robot.name} following the task under computed torque (through the FMU)")

    progress.step("writing the report")
    md, html = report.write(out)
    files += [md, html]
    progress.step(f"done: open {html}")
    print(f"wrote {len(files)} files under {out}/:", file=stream)
    for path in files:
        print(f"  {path}", file=stream)
    return DemoResult(out=out, report_md=md, report_html=html, fmu_path=fmu_path, fmu_ok=validation.ok, files=files,
                      max_error=max_error, fmu_vs_python=fmu_vs_python)
