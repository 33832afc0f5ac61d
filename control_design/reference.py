"""Reference motions: the task a robot is designed and checked on, and the references a controller reads.

* :func:`reference_task` - the motion a design is made on: the first ``[[tasks]]``
  entry of the robot file (the SCARA's is the seed's pick-and-place); a robot
  without tasks is designed on the generic tour (:func:`model.tasks.tour`).
* :func:`task_trajectory` - what ``manip track`` follows: a task of the robot file,
  ``"tour"``, or a waypoint file.
* :class:`Reference` - desired q, qd, qdd (joint side) at one instant, as a controller reads it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from model.limits import MAX_SAMPLES
from model.robot import Robot
from model import tasks as _tasks
from model.tasks import find_task, load_waypoints
from model.trajectory import SampleLimitError, Trajectory
from model.errors import InputError

from .errors import TrajectoryLimitError

__all__ = [
    "Reference",
    "DEFAULT_SEGMENT_TIME",
    "finite_limits",
    "reference_task",
    "reference_task_name",
    "reference_task_rule",
    "task_trajectory",
    "check_trajectory_limits",
]

#: Segment duration of the reference tasks, s (the seed's pick-and-place).
DEFAULT_SEGMENT_TIME = 3.0


class Reference(NamedTuple):
    """Desired joint motion at one instant: q (rad or m), qd (/s), qdd (/s^2), each (n,)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


def finite_limits(robot: Robot) -> np.ndarray:
    """(2, n) joint limits with unlimited joints bounded to [-pi, pi] rad or [-1, 1] m."""
    return _tasks.finite_limits(robot.description)


def reference_task_name(robot: Robot) -> str:
    """Name of :func:`reference_task` for ``robot``: its file's first task, else ``"tour"``."""
    tasks = robot.description.tasks
    return tasks[0]["name"] if tasks else _tasks.TOUR


def reference_task_rule(robot: Robot) -> str:
    """Why :func:`reference_task_name` chose its task, for a note to the user (the rule, in words)."""
    if robot.description.tasks:
        return "the first [[tasks]] entry of the robot file"
    return "the robot file has no [[tasks]]: the generic tour of every joint's range"


def reference_task(robot: Robot, segment_time: float = DEFAULT_SEGMENT_TIME, dt: float = 0.01) -> Trajectory:
    """The robot's reference task, sampled every ``dt`` s (see the module docstring)."""
    task = find_task(robot.description, reference_task_name(robot))
    return task.trajectory(dt=dt, segment_time=segment_time)


def task_trajectory(robot: Robot, task: str | None = None, waypoints: str | Path | None = None,
                    segment_time: float | None = None, dt: float = 0.01) -> Trajectory:
    """The trajectory ``manip track`` follows.

    Parameters
    ----------
    robot
        The robot (waypoints are checked against its joint count and limits).
    task
        A task of the robot file (``-`` and ``_`` alike, e.g. 'pick-and-place') or 'tour'
        (:func:`model.tasks.tour`); None: the robot's reference task. Ignored when ``waypoints`` is given.
    waypoints
        A TOML or CSV waypoint file (see :func:`model.tasks.load_waypoints`).
    segment_time
        Segment duration, s (default: the task's or the waypoint file's, else 3 s).
    dt
        Largest sampling period of the returned samples, s, shortened if needed to divide the
        segment time (the controller evaluates the path itself at its own instants).

    Raises
    ------
    model.tasks.WaypointError, FileNotFoundError, ValueError
    """
    if segment_time is not None and not (math.isfinite(segment_time) and segment_time > 0):
        raise InputError(f"expected a duration > 0 s, got {segment_time!r}", parameter="segment_time")
    if waypoints is not None:
        chosen = load_waypoints(waypoints, robot.description, segment_time)
        T = chosen.segment_time
    else:
        chosen = find_task(robot.description, reference_task_name(robot) if task is None else task)
        T = chosen.segment_time if segment_time is None else segment_time
    try:
        samples = chosen.n_segments * T / dt + 1  # checked first: an overflowing duration is no traceback
        if not samples <= MAX_SAMPLES:
            raise SampleLimitError(f"sampled every {dt:g} s: {samples:.4g} samples, more than the sample limit of "
                                   f"{MAX_SAMPLES}")
        return chosen.trajectory(dt=_grid_step(T, dt), segment_time=T)
    except SampleLimitError as exc:
        if segment_time is not None:
            raise SampleLimitError(f"{T:g} s per segment, {chosen.n_segments} segments: {exc}",
                                   parameter="segment_time") from None
        raise SampleLimitError(f"task {chosen.name!r}: segment_time: {T:g} s per segment, {chosen.n_segments} segments: "
                               f"{exc}") from None


def _grid_step(T: float, dt: float) -> float:
    """The largest step <= ``dt`` that divides the segment time ``T`` (samples must land on the segment ends)."""
    return T / math.ceil(T / dt - 1e-9)


def reference_trajectory(robot: Robot, task: str | None, waypoints: str | Path | None = None,
                         trajectory: str | Path | None = None, segment_time: float | None = None) -> Trajectory:
    """The reference a user names for a closed loop (``manip track``, ``manip export-ssp``), limits checked.

    A ``trajectory`` file (``manip retime``, ``manip excite``) is taken with its own samples; otherwise the
    ``task`` or ``waypoints`` through :func:`task_trajectory`. Then :func:`check_trajectory_limits`.

    Raises
    ------
    control_design.errors.DesignSpecError
        A trajectory file with a segment time.
    model.tasks.WaypointError, model.trajectory_file.TrajectoryFileError
        A bad file (naming it, the line and the joint).
    """
    if trajectory is not None:
        from control_design.errors import DesignSpecError
        from model.trajectory_file import read_trajectory

        if segment_time is not None:
            raise DesignSpecError("a --trajectory file carries its own times; give one or the other",
                                  parameter="segment_time")
        traj = read_trajectory(trajectory, robot.description)
    else:
        traj = task_trajectory(robot, task, waypoints, segment_time)
    check_trajectory_limits(robot, traj)
    return traj


def check_trajectory_limits(robot: Robot, traj: Trajectory, tol: float = 1e-9) -> None:
    """Raise :class:`TrajectoryLimitError` if any sample of ``traj`` leaves ``robot.qlim``.

    ``tol`` (rad or m) absorbs rounding at a waypoint that sits exactly on a limit.
    """
    if traj.n != robot.n:
        raise TrajectoryLimitError(f"expected {robot.n} joints for robot {robot.name!r}, got {traj.n}",
                                   parameter="trajectory")
    lo, hi = robot.qlim
    bad = np.argwhere((traj.q < lo - tol) | (traj.q > hi + tol))
    if bad.size:
        k, j = bad[0]
        unit = "rad" if robot.description.links[j].is_revolute else "m"
        raise TrajectoryLimitError(
            f"joint {j + 1} reaches {traj.q[k, j]:g} {unit} at t = {traj.t[k]:g} s, "
            f"outside qlim [{lo[j]:g}, {hi[j]:g}]",
        parameter="trajectory")
