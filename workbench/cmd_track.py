"""``manip track``: closed-loop tracking of a task on the nonlinear model, from the command line.

``manip track ROBOT --controller KIND [--task pick-and-place | --waypoints FILE | --trajectory FILE.csv]
[--segment-time S] [--rate HZ] [--payload KG] --out DIR`` simulates the closed loop on the nonlinear model and
writes ``DIR/metrics.json`` and ``DIR/tracking_error.png``, ``DIR/torques.png``,
``DIR/joints.png``, ``DIR/tracking.csv`` (:func:`write_tracking_csv`) and ``DIR/tracking.npz`` (t, q, q_ref:
the run that ``manip teach ROBOT --result DIR`` plays); progress goes to stderr. ``--controller cascade`` is the
motor-side P-PI cascade of the robot file's ``[cascade]`` table (:mod:`control_design.cascade`), at its ``rate``
unless ``--rate`` is given. With a plant/model mismatch
(``--payload``, ``--friction-scale``, ``--mass-scale``) the same controller also
runs on the exact plant and ``metrics.json`` reports both and their ratio.
``--out`` is checked before the simulation starts.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from .args import add_no_plots, add_spec_args, controller_kind, finite_or_fail
from .formatting import format_table, saturation_warnings
from .outputs import check_out_dir, out_dir, save_figure, write_json
from .replay import REPLAY_FILE, save_replay

if TYPE_CHECKING:
    from closed_loop.result import TrackingMetrics, TrackingResult
    from control_design.joint_model import TorqueLimits

__all__ = ["TRACKING_CSV", "TRACKING_HEADER", "register", "run_track", "save_tracking_plots", "tracking_rows",
           "write_tracking_csv"]

#: The time series of a run, beside metrics.json.
TRACKING_CSV = "tracking.csv"


def write_tracking_csv(result: TrackingResult, path: Path) -> Path:
    """Write ``time`` (s), then per joint ``q_<joint>``, ``qd_<joint>``, ``q_ref_<joint>`` (link side: rad, rad/s
    or m, m/s) and ``tau_m_<joint>`` (the motor torque demand held over the period, N m, motor side), atomically;
    one row per control instant, 17 significant digits (a float64 read back exactly)."""
    from model.files import write_atomic

    names = list(result.joints)
    header = ["time"] + [f"{k}_{j}" for k in ("q", "qd", "q_ref", "tau_m") for j in names]
    data = np.column_stack([result.t, result.q, result.qd, result.q_ref, result.tau_m])
    lines = [",".join(header)] + [",".join(f"{v:.17g}" for v in row) for row in data]
    return write_atomic(path, "\n".join(lines) + "\n")


def save_tracking_plots(result: TrackingResult, out: Path, prefix: str = "",
                        limits: TorqueLimits | None = None) -> list[Path]:
    """Write ``{prefix}tracking_error.png``, ``{prefix}torques.png`` and ``{prefix}joints.png``.

    ``limits``: the design's torque limits, whose provenance labels the limit lines of the torque plot.
    """
    from closed_loop.plots import joint_plot, torque_plot, tracking_error_plot

    sources = None if limits is None else [limits.provenance(j) for j in range(result.G.size)]
    figures = (("tracking_error", tracking_error_plot(result)), ("torques", torque_plot(result, limit_sources=sources)),
               ("joints", joint_plot(result)))
    return [save_figure(fig, out / f"{prefix}{name}.png") for name, fig in figures]


def _noted(progress: Callable[[float, float, float], None], note: str) -> Callable[[float, float, float], None]:
    """``progress`` that first prints ``note`` on stderr, at its first call (when the simulation starts)."""
    said = []

    def report(fraction: float, t: float, t_final: float) -> None:
        if not said:
            print(note, file=sys.stderr, flush=True)
            said.append(True)
        progress(fraction, t, t_final)

    return report


def run_track(args: argparse.Namespace) -> int:
    """``manip track``: simulate the closed loop along a task, write metrics.json and plots."""
    from closed_loop.progress import ProgressLine
    from closed_loop.simulate import simulate_tracking
    from control_design.computed_torque import ModelMismatch, plant_with_mismatch
    from control_design.design import design_robot
    from control_design.errors import DesignSpecError
    from control_design.reference import reference_task_name, reference_task_rule, reference_trajectory
    from model.robot import load_robot

    kind = controller_kind(args.controller, extra=("cascade",))
    finite_or_fail(args.rate, "--rate")
    finite_or_fail(args.segment_time, "--segment-time")
    if args.payload is not None and not (math.isfinite(args.payload) and args.payload >= 0):
        raise DesignSpecError(f"--payload: expected a mass >= 0 kg, got {args.payload!r}")
    check_out_dir(args.out)
    robot = load_robot(args.robot)
    if args.trajectory is not None:  # a trajectory file (manip retime, manip excite): its samples as they are
        task = str(args.trajectory)
    else:
        task = reference_task_name(robot) if args.task is None and args.waypoints is None else args.task
    traj = reference_trajectory(robot, task, args.waypoints, args.trajectory, args.segment_time)
    if kind == "cascade":
        return _run_cascade(args, robot, traj, task)
    if args.rate is None:
        from control_design.design import DEFAULT_RATE_HZ
        args.rate = DEFAULT_RATE_HZ
    design = design_robot(robot, kind, args.bandwidth, args.damping, phase_margin=args.phase_margin, rate_hz=args.rate,
                          analyse=False)
    mismatch = ModelMismatch(payload_mass=args.payload or 0.0, friction_scale=args.friction_scale,
                             link_mass_scale=args.mass_scale)
    plant = robot if mismatch.is_exact else plant_with_mismatch(robot, mismatch)
    controller = design.controller(args.rate, saturate=not args.no_saturation)
    progress = ProgressLine("track", sys.stderr)
    if args.task is None and args.waypoints is None and args.trajectory is None:  # said when the run starts
        progress = _noted(progress, f"manip track: no --task: following {task!r} ({reference_task_rule(robot)})")
    result = simulate_tracking(plant, controller, traj, progress=progress)
    met = result.metrics()
    out = out_dir(args.out)
    data = met.to_dict()
    data.update({
        "task": str(args.waypoints) if args.waypoints else task, "duration_s": float(result.t[-1] - result.t[0]),
        "bandwidth_rad_s": args.bandwidth, "damping": design.damping, "phase_margin_deg": args.phase_margin,
        "plant": mismatch.describe(), "payload_kg": mismatch.payload_mass,
        "tau_m_max": None if result.tau_m_max is None else result.tau_m_max.tolist(), "substeps": result.substeps,
        "torque_limit": design.model.limits.to_dict(),
    })
    if not mismatch.is_exact:
        # The effect of the mismatch: the same controller on the exact plant, for comparison.
        nominal = simulate_tracking(robot, design.controller(args.rate, saturate=not args.no_saturation), traj,
                                    progress=ProgressLine("track (exact plant)", sys.stderr)).metrics()
        data["exact_plant"] = {"rms_error": nominal.rms_error.tolist(), "max_error": nominal.max_error.tolist(),
                               "peak_motor_torque": nominal.peak_motor_torque.tolist()}
        data["max_error_ratio"] = [float(a / b) if b > 0 else None for a, b in zip(met.max_error, nominal.max_error)]
    write_json(out / "metrics.json", data)
    write_tracking_csv(result, out / TRACKING_CSV)
    save_replay(result, out / REPLAY_FILE)  # for `manip teach ROBOT --result DIR`
    if not args.no_plots:
        save_tracking_plots(result, out, limits=design.model.limits)
    print(f"{robot.name}: {kind} at {args.rate:g} Hz, {mismatch.describe()}, {result.t[-1] - result.t[0]:g} s "
          f"simulated in {met.wall_time:.2f} s")
    print(format_table(TRACKING_HEADER, tracking_rows(met)))
    if "max_error_ratio" in data:
        ratios = ", ".join("-" if r is None else f"{r:.3g}" for r in data["max_error_ratio"])
        print(f"max error / max error on the exact plant: {ratios}")
    for line in saturation_warnings(met, design.model.limits):
        print(f"manip track: warning: {line}", file=sys.stderr)
    plots = " (--no-plots: no PNG files)" if args.no_plots else " and 3 PNG files"
    print(f"wrote {out / 'metrics.json'}, {out / TRACKING_CSV}, {out / REPLAY_FILE} (for manip teach --result){plots}")
    return 0


def _run_cascade(args: argparse.Namespace, robot: Any, traj: Any, task: str) -> int:
    """``manip track --controller cascade``: the robot file's P-PI cascade on the plant as it is."""
    from closed_loop.progress import ProgressLine
    from closed_loop.simulate import simulate_tracking
    from control_design.cascade import cascade_from_robot
    from control_design.errors import DesignSpecError

    for flag, value, neutral in (("--payload", args.payload, None), ("--friction-scale", args.friction_scale, 1.0),
                                 ("--mass-scale", args.mass_scale, 1.0)):
        if value != neutral:
            raise DesignSpecError(f"{flag}: the cascade runs on the robot as it is (no model mismatch), got {value!r}")
    controller = cascade_from_robot(robot, args.rate)
    result = simulate_tracking(robot, controller, traj, progress=ProgressLine("track", sys.stderr))
    met = result.metrics()
    out = out_dir(args.out)
    data = met.to_dict()
    data.update({"task": task, "duration_s": float(result.t[-1] - result.t[0]), "substeps": result.substeps,
                 "cascade": {key: list(v) if isinstance(v, tuple) else v
                             for key, v in robot.description.extra["cascade"].items()}})
    write_json(out / "metrics.json", data)
    write_tracking_csv(result, out / TRACKING_CSV)
    save_replay(result, out / REPLAY_FILE)
    if not args.no_plots:
        save_tracking_plots(result, out)
    print(f"{robot.name}: cascade at {controller.rate_hz:g} Hz, {result.t[-1] - result.t[0]:g} s simulated in "
          f"{met.wall_time:.2f} s")
    print(format_table(TRACKING_HEADER, tracking_rows(met)))
    print(f"wrote {out / 'metrics.json'}, {out / TRACKING_CSV}, {out / REPLAY_FILE}"
          f"{'' if args.no_plots else ' and 3 PNG files'}")
    return 0


#: Columns of :func:`tracking_rows`.
TRACKING_HEADER = ("joint", "unit", "RMS error", "max error", "peak tau_m [N m]", "peak qd_m [rad/s]", "at limit [%]")


def tracking_rows(met: TrackingMetrics) -> list[list[object]]:
    """One row per joint (:data:`TRACKING_HEADER`): errors (rad or m), peak motor torque and speed, saturation."""
    return [[name, met.units[j], float(met.rms_error[j]), float(met.max_error[j]), float(met.peak_motor_torque[j]),
             float(met.peak_motor_velocity[j]), 100.0 * float(met.saturated_fraction[j])]
            for j, name in enumerate(met.joints)]


def register(subparsers: Any, full: bool = True) -> None:
    """Add the ``track`` sub-command to ``manip``'s sub-parsers (``full=False``: its name and help only)."""
    p = subparsers.add_parser("track", help="simulate closed-loop tracking of a task on the nonlinear model")
    p.set_defaults(func=run_track)
    if not full:
        return
    add_spec_args(p)
    for action in p._actions:  # track also runs the robot file's P-PI cascade
        if "--controller" in action.option_strings:
            action.metavar = action.metavar[:-1] + ",cascade}"
            action.help = (action.help or "") + "; cascade: the robot file's [cascade] P-PI loop on the motor side"
    src = p.add_mutually_exclusive_group()
    src.add_argument("--task", default=None,
                     help="a [[tasks]] entry of the robot file or 'tour' (default: the file's first task, else tour)")
    src.add_argument("--waypoints", default=None, metavar="FILE", help="TOML or CSV joint waypoint file")
    src.add_argument("--trajectory", default=None, metavar="FILE.csv",
                     help="trajectory file: time, q_<joint>.., qd_<joint>.., qdd_<joint>.. (manip retime, manip excite)")
    p.add_argument("--segment-time", type=float, default=None, metavar="S", help="duration of every segment, s (default 3)")
    p.add_argument("--payload", type=float, default=None, metavar="KG",
                   help="payload on the simulated arm only (unknown to the controller), kg")
    p.add_argument("--friction-scale", type=float, default=1.0, metavar="X", help="plant friction = X times the model's")
    p.add_argument("--mass-scale", type=float, default=1.0, metavar="X", help="plant link masses = X times the model's")
    p.add_argument("--no-saturation", action="store_true", help="do not clip motor torques at their limits")
    add_no_plots(p)
    p.set_defaults(func=run_track, rate=None)  # None: the design's default rate, or the [cascade] table's
