"""``manip retime``: the fastest motion along a task's path within the motor torque, speed and acceleration limits.

``manip retime ROBOT [--task T | --waypoints F] [--blend] [--torque-margin 0.9] [--velocity-limit V]
[--acceleration-limit A] [--velocity-scale X] [--acceleration-scale X] [--grid N] [--dt S] [--smooth S] --out DIR``
writes ``DIR/trajectory.csv`` (time, q, qd, qdd per joint, SI; ``manip track ROBOT --trajectory`` follows it),
``DIR/retime.json`` (duration, limits and where they come from, the worst use of each) and ``DIR/retime.png``
(path speed against its limit curve, torques against their limits). The motor torque limits are those
``manip design`` and ``manip track`` use (the robot file's ``torque_limit``, else the default rule), so a
tracked retimed motion is held to the limits it was planned within. ``--out`` is checked before the work.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import TYPE_CHECKING, Any

import numpy as np

from .args import UsageError, add_no_plots, bounded_int, per_joint_flag
from .outputs import check_out_dir, out_dir, save_figure, write_json

if TYPE_CHECKING:  # pragma: no cover
    from model.retime import Retiming
    from model.robot import Robot
    from model.tasks import Task

__all__ = ["TRAJECTORY_FILE", "register", "run_retime", "retime_task", "chosen_task"]

#: The trajectory file a retime writes (and ``manip track --trajectory`` reads).
TRAJECTORY_FILE = "trajectory.csv"


def _factor(value: float, flag: str) -> float:
    if not (math.isfinite(value) and value > 0.0):
        raise UsageError(f"{flag}: expected a finite factor > 0, got {value!r}")
    return value


def chosen_task(robot: "Robot", task: str | None, waypoints: str | None) -> "Task":
    """The task to retime: a waypoint file, a named task of the robot (or ``tour``), else the reference task."""
    from control_design.reference import reference_task_name
    from model.tasks import find_task, load_waypoints

    if waypoints is not None:
        return load_waypoints(waypoints, robot.description)
    return find_task(robot.description, reference_task_name(robot) if task is None else task)


def retime_task(robot: "Robot", task: "Task", *, blend: bool = False, torque_margin: float = 0.9,
                velocity_limit: Any = None, acceleration_limit: Any = None, velocity_scale: float = 1.0,
                acceleration_scale: float = 1.0, grid: int = 1000) -> "Retiming":
    """Retime ``task`` on ``robot`` within the design's motor torque limits (robot file or default rule).

    The defaults are :data:`model.retime.DEFAULT_TORQUE_MARGIN` and :data:`model.retime.DEFAULT_GRID`.
    """
    from control_design.joint_model import sample_configurations, torque_limits
    from control_design.reference import reference_task
    from model.retime import retime, retime_limits

    tau = torque_limits(robot, reference_task(robot), sample_configurations(robot)).tau_m_max
    limits = retime_limits(robot, tau, torque_margin=torque_margin, velocity_limit=velocity_limit,
                           acceleration_limit=acceleration_limit, velocity_scale=velocity_scale,
                           acceleration_scale=acceleration_scale)
    return retime(robot, task.waypoints, limits, blend=blend, grid=grid)


def run_retime(args: argparse.Namespace) -> int:
    """``manip retime``: retime the task, write trajectory.csv, retime.json and the figure."""
    from model.robot import load_robot
    from model.trajectory_file import write_trajectory

    if not (0.0 < args.torque_margin <= 1.0):
        raise UsageError(f"--torque-margin: expected a share of the motor torque limits in (0, 1], got {args.torque_margin!r}")
    if not (math.isfinite(args.dt) and 0.0 < args.dt <= 0.1):
        raise UsageError(f"--dt: expected a sampling period in (0, 0.1] s, got {args.dt!r}")
    if not (math.isfinite(args.smooth) and 0.0 <= args.smooth <= 0.1):
        raise UsageError(f"--smooth: expected a window in [0, 0.1] s, got {args.smooth!r}")
    _factor(args.velocity_scale, "--velocity-scale")
    _factor(args.acceleration_scale, "--acceleration-scale")
    check_out_dir(args.out)
    robot = load_robot(args.robot)
    velocity = per_joint_flag(args.velocity_limit, robot.n, "--velocity-limit", "rad/s or m/s")
    acceleration = per_joint_flag(args.acceleration_limit, robot.n, "--acceleration-limit", "rad/s^2 or m/s^2")
    task = chosen_task(robot, args.task, args.waypoints)
    print(f"manip retime: {robot.name}, task {task.name!r} ({task.n_segments} segments), "
          f"{'blended spline' if args.blend else 'straight segments'}, {args.grid} grid intervals", file=sys.stderr,
          flush=True)
    motion = retime_task(robot, task, blend=args.blend, torque_margin=args.torque_margin, velocity_limit=velocity,
                         acceleration_limit=acceleration, velocity_scale=args.velocity_scale,
                         acceleration_scale=args.acceleration_scale, grid=args.grid)
    traj = motion.trajectory(args.dt, smooth=args.smooth)
    out = out_dir(args.out)
    write_trajectory(out / TRAJECTORY_FILE, traj, robot.description.joint_names)
    planned = task.n_segments * task.segment_time
    check = motion.check()
    data = motion.to_dict()
    file_use = float(np.max(np.abs(robot.rne_batch(traj.q, traj.qd, traj.qdd)) / motion.limits.tau_max))
    data.update({"task": str(args.waypoints) if args.waypoints else task.name, "planned_duration_s": planned,
                 "speed_up": planned / motion.duration, "file": TRAJECTORY_FILE, "file_duration_s": float(traj.t[-1]),
                 "smooth_s": args.smooth, "sample_step_s": float(np.max(np.diff(traj.t))), "samples": int(traj.t.size),
                 "file_torque_use": file_use})
    write_json(out / "retime.json", data)
    if not args.no_plots:
        from .retime_plots import retime_figure

        save_figure(retime_figure(robot, motion), out / "retime.png")
    print(f"{robot.name}: {task.name} retimed from {planned:g} s ({task.n_segments} x {task.segment_time:g} s as "
          f"planned) to {motion.duration:.4g} s ({planned / motion.duration:.3g} x faster), solved in "
          f"{motion.solve_time:.2f} s")
    print(f"at the grid points, at most {100 * check.torque:.6g} % of the torque bound ({100 * args.torque_margin:g} % "
          f"of the motor limits; motor {check.torque_joint + 1})"
          + (f", {100 * check.velocity:.4g} % of a velocity limit" if check.velocity > 0 else "")
          + (f", {100 * check.acceleration:.4g} % of an acceleration limit" if check.acceleration > 0 else ""))
    if args.smooth > 0.0:
        print(f"{TRAJECTORY_FILE}: the law averaged over {args.smooth:g} s (ramps where it switches; "
              f"{traj.t[-1]:.4g} s), its torques at most {100 * file_use:.4g} % of the bound")
    plots = " (--no-plots: no PNG)" if args.no_plots else f" and {out / 'retime.png'}"
    print(f"wrote {out / TRAJECTORY_FILE} ({traj.t.size} samples, at most {np.max(np.diff(traj.t)):.6g} s apart; "
          f"manip track {args.robot} --trajectory {out / TRAJECTORY_FILE}), {out / 'retime.json'}{plots}")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``retime`` sub-command to ``manip``'s sub-parsers."""
    p = subparsers.add_parser("retime", help="the fastest motion along a task's path within torque, speed and "
                                             "acceleration limits (time-optimal, TOPP-RA)")
    p.add_argument("robot", help="built-in robot name, TOML or URDF file")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--task", default=None, help="a task of the robot file or 'tour' (default: the file's first task, "
                                                 "else tour)")
    src.add_argument("--waypoints", default=None, metavar="FILE", help="TOML or CSV joint waypoint file")
    p.add_argument("--blend", action="store_true",
                   help="a C2 cubic spline through the waypoints, not stopping (default: straight segments, at rest "
                        "at each waypoint)")
    from model.retime import DEFAULT_GRID, DEFAULT_SAMPLE_STEP, DEFAULT_SMOOTH, DEFAULT_TORQUE_MARGIN

    p.add_argument("--torque-margin", type=float, default=DEFAULT_TORQUE_MARGIN, metavar="X",
                   help="share of each motor's torque limit the motion may use, (0, 1] (default 0.9: 10 %% left for "
                        "the tracking loop)")
    p.add_argument("--velocity-limit", default=None, metavar="V",
                   help="joint speed limit, rad/s or m/s: one for all or one per joint, comma-separated (default: the "
                        "robot file's velocity_limit)")
    p.add_argument("--acceleration-limit", default=None, metavar="A",
                   help="joint acceleration limit, rad/s^2 or m/s^2, as --velocity-limit (default: the robot file's)")
    p.add_argument("--velocity-scale", type=float, default=1.0, metavar="X", help="factor on the velocity limits")
    p.add_argument("--acceleration-scale", type=float, default=1.0, metavar="X",
                   help="factor on the acceleration limits")
    p.add_argument("--grid", type=bounded_int(10, 100_000, "a number of grid intervals"), default=DEFAULT_GRID,
                   metavar="N", help=f"grid intervals along the path (default {DEFAULT_GRID})")
    p.add_argument("--dt", type=float, default=DEFAULT_SAMPLE_STEP, metavar="S",
                   help=f"sampling period of trajectory.csv, s (default {DEFAULT_SAMPLE_STEP:g})")
    p.add_argument("--smooth", type=float, default=DEFAULT_SMOOTH, metavar="S",
                   help="average the time law over S s in trajectory.csv, so that a loop sampled every S s follows its "
                        "switches (default 0.001; 0: the time-optimal law with its acceleration jumps)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created if missing)")
    add_no_plots(p)
    p.set_defaults(func=run_retime)
