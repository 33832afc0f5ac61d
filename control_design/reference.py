"""Reference motions: the task a robot is designed and checked on, and the references a controller reads.

* :func:`reference_task` - the robot's reference task: the seed's pick-and-place
  for the SCARA; for any other robot a deterministic tour
  ``rest -> 25 % of every joint range -> 75 % -> rest`` (ranges without limits
  taken as [-pi, pi] rad or [-1, 1] m), quintic segments stopping at each point.
* :func:`task_trajectory` - what ``manip track`` follows: a built-in task or a waypoint file.
* :class:`Reference` - desired q, qd, qdd (joint side) at one instant, as a controller reads it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from model.robot import Robot
from model.tasks import BUILTIN_TASKS, load_waypoints, pick_and_place
from model.trajectory import Trajectory, via_points

from .errors import TrajectoryLimitError

__all__ = [
    "Reference",
    "DEFAULT_SEGMENT_TIME",
    "finite_limits",
    "reference_task",
    "reference_task_name",
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
    lim = robot.qlim.copy()
    for j, link in enumerate(robot.description.links):
        span = math.pi if link.is_revolute else 1.0
        if not math.isfinite(lim[0, j]):
            lim[0, j] = -span
        if not math.isfinite(lim[1, j]):
            lim[1, j] = span
    return lim


def reference_task_name(robot: Robot) -> str:
    """Name of :func:`reference_task` for ``robot``: 'pick_and_place' or 'tour'."""
    return "pick_and_place" if robot.name == "scara" and robot.n == 4 else "tour"


def reference_task(robot: Robot, segment_time: float = DEFAULT_SEGMENT_TIME, dt: float = 0.01) -> Trajectory:
    """The robot's reference task, sampled every ``dt`` s (see the module docstring)."""
    if reference_task_name(robot) == "pick_and_place":
        return pick_and_place(robot.description, segment_time=segment_time, dt=dt)
    lim = finite_limits(robot)
    rest = np.clip(robot.q_rest, lim[0], lim[1])
    a = lim[0] + 0.25 * (lim[1] - lim[0])
    b = lim[0] + 0.75 * (lim[1] - lim[0])
    return via_points(np.vstack([rest, a, b, rest]), segment_time, dt)


def task_trajectory(robot: Robot, task: str | None = "pick-and-place", waypoints: str | Path | None = None,
                    segment_time: float | None = None, dt: float = 0.01) -> Trajectory:
    """The trajectory ``manip track`` follows.

    Parameters
    ----------
    robot
        The robot (waypoints are checked against its joint count and limits).
    task
        'pick-and-place' (or 'pick_and_place'): the robot's reference task; ignored when ``waypoints`` is given.
    waypoints
        A TOML or CSV waypoint file (see :func:`model.tasks.load_waypoints`).
    segment_time
        Segment duration, s (default: the file's, else :data:`DEFAULT_SEGMENT_TIME`).
    dt
        Largest sampling period of the returned samples, s, shortened if needed to divide the
        segment time (the controller evaluates the path itself at its own instants).

    Raises
    ------
    model.tasks.WaypointError, FileNotFoundError, ValueError
    """
    if segment_time is not None and not (math.isfinite(segment_time) and segment_time > 0):
        raise ValueError(f"segment_time: expected a duration > 0 s, got {segment_time!r}")
    if waypoints is not None:
        t = load_waypoints(waypoints, robot.description, segment_time)
        return t.trajectory(dt=_grid_step(t.segment_time, dt))
    name = (task or "pick-and-place").replace("-", "_")
    if name != "pick_and_place" and name not in BUILTIN_TASKS:
        raise ValueError(f"task: expected 'pick-and-place' or a waypoint file, got {task!r}")
    T = DEFAULT_SEGMENT_TIME if segment_time is None else segment_time
    return reference_task(robot, T, _grid_step(T, dt))


def _grid_step(T: float, dt: float) -> float:
    """The largest step <= ``dt`` that divides the segment time ``T`` (samples must land on the segment ends)."""
    return T / math.ceil(T / dt - 1e-9)


def check_trajectory_limits(robot: Robot, traj: Trajectory, tol: float = 1e-9) -> None:
    """Raise :class:`TrajectoryLimitError` if any sample of ``traj`` leaves ``robot.qlim``.

    ``tol`` (rad or m) absorbs rounding at a waypoint that sits exactly on a limit.
    """
    if traj.n != robot.n:
        raise TrajectoryLimitError(f"trajectory: expected {robot.n} joints for robot {robot.name!r}, got {traj.n}")
    lo, hi = robot.qlim
    bad = np.argwhere((traj.q < lo - tol) | (traj.q > hi + tol))
    if bad.size:
        k, j = bad[0]
        unit = "rad" if robot.description.links[j].is_revolute else "m"
        raise TrajectoryLimitError(
            f"trajectory: joint {j + 1} reaches {traj.q[k, j]:g} {unit} at t = {traj.t[k]:g} s, "
            f"outside qlim [{lo[j]:g}, {hi[j]:g}]"
        )
