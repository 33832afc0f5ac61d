"""Named joint-space tasks: the ``[[tasks]]`` of a robot file, the generic tour, and waypoint files.

A :class:`Task` is a list of joint-space waypoints for one robot, visited in
order with one duration per segment; :meth:`Task.trajectory` turns it into a
sampled :class:`~model.trajectory.Trajectory` (quintic per segment, stopping at
every waypoint, by default).

Tasks are data: a robot file lists its own (:func:`robot_tasks`, validated by
the description); :func:`find_task` looks one up by name, where ``"tour"`` is
the generic ``rest -> 25 % of every joint range -> 75 % -> rest`` of any robot
(:func:`tour`). No behaviour depends on a robot's name. The SCARA file carries
the pick-and-place of the seed report 000 (:data:`PICK_AND_PLACE`):

>>> from model.tasks import pick_and_place
>>> traj = pick_and_place()          # 5 segments of 3 s, sampled every 10 ms
>>> float(traj.t[-1]), traj.n_segments
(15.0, 5)

Waypoint files (:func:`load_waypoints`) are TOML (``waypoints = [[...], ...]``,
optional ``segment_time`` in s) or CSV (one joint vector per line, optional
header line and ``#`` comments), validated against the robot's joint count and
joint limits. Units: rad for revolute joints, m for prismatic ones.
"""

from __future__ import annotations

import csv
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import numpy.typing as npt

from .description import InertiaConsistencyWarning, RobotDescription
from .errors import InputError, did_you_mean
from .limits import MAX_WAYPOINTS, check_file, load_toml, read_bounded
from .loading import load_description
from .trajectory import Trajectory, ptp_synchronised, via_points

__all__ = [
    "Task",
    "WaypointError",
    "PICK_AND_PLACE",
    "BUILTIN_TASKS",
    "TOUR",
    "finite_limits",
    "robot_tasks",
    "tour",
    "find_task",
    "pick_and_place",
    "load_waypoints",
    "check_waypoints",
]

#: Name of the generic task every robot has (:func:`tour`).
TOUR = "tour"

class WaypointError(InputError):
    """Waypoints are unreadable or invalid for the robot; the message names the source, row and joint."""


@dataclass(frozen=True, eq=False)
class Task:
    """Joint-space waypoints of one robot, visited in order.

    Attributes
    ----------
    name
        Task name.
    robot
        Built-in robot name (or TOML path) the waypoints are meant for.
    waypoints
        (K+1, n) joint vectors, rad or m, start first.
    labels
        K+1 names of the waypoints (e.g. ``"B (pick)"``).
    segment_time
        Default duration of every segment, s.
    description
        One line on what the task does and where it comes from.
    """

    name: str
    robot: str
    waypoints: npt.NDArray[np.float64]
    labels: tuple[str, ...]
    segment_time: float
    description: str = ""
    kind: str = "waypoints"
    hold_time: float = 0.0
    velocity_limits: tuple[float, ...] | None = None
    acceleration_limits: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        w = np.array(self.waypoints, dtype=float)
        w.setflags(write=False)
        object.__setattr__(self, "waypoints", w)
        if len(self.labels) != w.shape[0]:
            raise InputError(f"expected {w.shape[0]} labels, one per waypoint, got {len(self.labels)}",
                             parameter="labels")

    @property
    def n_segments(self) -> int:
        """Number of segments (waypoints - 1)."""
        return int(self.waypoints.shape[0] - 1)

    def trajectory(self, dt: float = 0.01, segment_time: float | Sequence[float] | None = None,
                   profile: str = "quintic", t0: float = 0.0) -> Trajectory:
        """Sample the task: one ``profile`` segment per pair of waypoints, stopping at each.

        Parameters
        ----------
        dt
            Sampling period, s.
        segment_time
            Segment duration(s), s; default :attr:`segment_time`.
        profile
            ``"quintic"`` or ``"trapezoidal"`` (see :func:`model.trajectory.via_points`).
        t0
            Start time, s.
        """
        if self.kind == "ptp":
            return self._ptp(dt, t0)
        times = self.segment_time if segment_time is None else segment_time
        return via_points(self.waypoints, times, dt, t0=t0, profile=profile)


    def _ptp(self, dt: float, t0: float) -> Trajectory:
        """The synchronised point-to-point motion (``kind = "ptp"``) within the joints' limits, then the hold."""
        if self.velocity_limits is None or self.acceleration_limits is None:
            raise InputError(f"task {self.name!r}: a 'ptp' task needs every joint's velocity_limit and "
                             f"acceleration_limit in the robot file", parameter="velocity_limit")
        return ptp_synchronised(self.waypoints[0], self.waypoints[-1], self.velocity_limits,
                                self.acceleration_limits, dt, t0=t0, hold=self.hold_time)


def _limits(desc: RobotDescription, key: str) -> tuple[float, ...] | None:
    values = [getattr(lk, key) for lk in desc.links]
    return None if any(v is None for v in values) else tuple(float(v) for v in values)


def _description(robot: str | Path | RobotDescription) -> RobotDescription:
    return robot if isinstance(robot, RobotDescription) else load_description(robot)


def robot_tasks(robot: str | Path | RobotDescription) -> dict[str, Task]:
    """The ``[[tasks]]`` of a robot file by name, in file order (validated with the description)."""
    desc = _description(robot)
    return {
        t["name"]: Task(name=t["name"], robot=desc.name, waypoints=np.array(t["waypoints"], dtype=float),
                        labels=tuple(t["labels"]), segment_time=float(t["segment_time"]), description=t["description"],
                        kind=t.get("kind", "waypoints"), hold_time=float(t.get("hold_time", 0.0)),
                        velocity_limits=_limits(desc, "velocity_limit"),
                        acceleration_limits=_limits(desc, "acceleration_limit"))
        for t in desc.tasks
    }


def finite_limits(desc: RobotDescription) -> npt.NDArray[np.float64]:
    """(2, n) joint limits with unlimited joints bounded to [-pi, pi] rad or [-1, 1] m."""
    lim = desc.qlim.copy()
    for j, link in enumerate(desc.links):
        span = math.pi if link.is_revolute else 1.0
        if not math.isfinite(lim[0, j]):
            lim[0, j] = -span
        if not math.isfinite(lim[1, j]):
            lim[1, j] = span
    return lim


def tour(robot: str | Path | RobotDescription, segment_time: float = 3.0) -> Task:
    """The generic task of any robot: rest -> 25 % of every joint range -> 75 % -> rest.

    Ranges without limits are taken as [-pi, pi] rad or [-1, 1] m (:func:`finite_limits`);
    the rest position is the description's (:attr:`~model.description.RobotDescription.q_rest`, within the limits).
    """
    desc = _description(robot)
    lim = finite_limits(desc)
    rest = desc.q_rest
    a = lim[0] + 0.25 * (lim[1] - lim[0])
    b = lim[0] + 0.75 * (lim[1] - lim[0])
    return Task(name=TOUR, robot=desc.name, waypoints=np.vstack([rest, a, b, rest]),
                labels=("rest", "25 %", "75 %", "rest"), segment_time=float(segment_time),
                description="generic tour: rest, 25 % and 75 % of every joint range, rest")


def find_task(robot: str | Path | RobotDescription, name: str) -> Task:
    """The task ``name`` of a robot: one of its ``[[tasks]]`` or ``"tour"``; ``-`` and ``_`` are the same.

    Raises
    ------
    WaypointError
        Naming the robot, the task and the tasks it has.
    """
    desc = _description(robot)
    tasks = robot_tasks(desc)
    key = name.replace("-", "_")
    for task_name, task in tasks.items():
        if task_name.replace("-", "_") == key:
            return task
    if key == TOUR:
        return tour(desc)
    known = ", ".join(repr(t) for t in (*tasks, TOUR))
    raise WaypointError(f"task {name!r}: robot {desc.name!r} has no such task; expected one of {known} or a waypoint file")


def _scara_tasks() -> dict[str, Task]:
    with warnings.catch_warnings():  # the seed's SCARA link 2 inertia breaks the triangle inequality, knowingly
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return robot_tasks("scara")


#: The seed's SCARA pick-and-place in joint space (theta1, theta2, d3, theta4), read from
#: ``model/robots/scara.toml``. qC and qD have theta2 = 0: the arm is stretched (a kinematic
#: singularity), harmless in joint space.
PICK_AND_PLACE: Task = _scara_tasks()["pick_and_place"]

#: The built-in robots' file tasks by name (kept for existing callers; see :func:`robot_tasks`).
BUILTIN_TASKS: dict[str, Task] = {PICK_AND_PLACE.name: PICK_AND_PLACE}


def check_waypoints(waypoints: npt.ArrayLike, robot: str | Path | RobotDescription, where: str) -> npt.NDArray[np.float64]:
    """Check waypoints against a robot: at least 2 rows, n finite values each, inside qlim.

    Parameters
    ----------
    waypoints
        (K+1, n) joint vectors, rad or m.
    robot
        Built-in robot name, TOML path or description.
    where
        Source named in error messages (file path or task name).

    Returns
    -------
    (K+1, n) float array.

    Raises
    ------
    WaypointError
        Naming ``where``, the row and joint (1-based), the value and the limit.
    """
    desc = _description(robot)
    rows = waypoints.tolist() if isinstance(waypoints, np.ndarray) else list(waypoints)  # type: ignore[arg-type]
    if len(rows) < 2:
        raise WaypointError(f"{where}: expected at least 2 waypoints, got {len(rows)}")
    if len(rows) > MAX_WAYPOINTS:
        raise WaypointError(f"{where}: {len(rows)} waypoints: more than the waypoint limit of {MAX_WAYPOINTS}")
    qlim = desc.qlim
    for r, row in enumerate(rows, 1):
        if not isinstance(row, (list, tuple)):
            raise WaypointError(f"{where} row {r}: expected a list of {desc.n} joint values, got {row!r}")
        if len(row) != desc.n:
            raise WaypointError(f"{where} row {r}: expected {desc.n} joint values for robot {desc.name!r}, got {len(row)}")
        for j, value in enumerate(row):
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
                raise WaypointError(f"{where} row {r}, joint {j + 1}: expected a number, got {value!r}")
            x = float(value)
            unit = "rad" if desc.links[j].is_revolute else "m"
            if not math.isfinite(x):
                raise WaypointError(f"{where} row {r}, joint {j + 1}: expected a finite value, got {x!r}")
            lo, hi = qlim[0, j], qlim[1, j]
            if not lo <= x <= hi:
                raise WaypointError(f"{where} row {r}, joint {j + 1}: {x:g} {unit} outside qlim [{lo:g}, {hi:g}]")
    return np.array(rows, dtype=float)


def pick_and_place(robot: str | Path | RobotDescription = "scara", segment_time: float = 3.0,
                   dt: float = 0.01, profile: str = "quintic") -> Trajectory:
    """The seed's SCARA pick-and-place as a sampled joint trajectory.

    rest [0 0 1 0] -> qA [pi/2 pi/2 1 0] -> qB [pi/2 pi/2 3 0] (pick) -> qA ->
    qC [pi/2 0 1 0] -> qD [pi/2 0 3 0] (place), in (theta1 rad, theta2 rad, d3 m,
    theta4 rad); each segment a quintic of ``segment_time`` s, stopping at each waypoint.

    Parameters
    ----------
    robot
        A SCARA-like 4-joint robot (name, TOML path or description) whose limits the
        waypoints are checked against; default the built-in ``"scara"``.
    segment_time
        Duration of each of the 5 segments, s.
    dt
        Sampling period, s.
    profile
        ``"quintic"`` (the seed's) or ``"trapezoidal"``.

    Raises
    ------
    WaypointError
        The robot does not have 4 joints or a waypoint is outside its limits.
    """
    task = PICK_AND_PLACE
    desc = _description(robot)  # another robot's limits may refuse the SCARA's waypoints
    check_waypoints(task.waypoints, desc, f"{task.name} (robot {desc.name!r})")
    return task.trajectory(dt=dt, segment_time=segment_time, profile=profile)


_TOML_KEYS = ("waypoints", "segment_time", "description", "labels")


def _read_toml(path: Path) -> dict[str, Any]:
    data = load_toml(path, "waypoint file", WaypointError)
    for key in data:  # an unknown key first: it is often the misspelt 'waypoints'
        if key not in _TOML_KEYS:
            hint = did_you_mean(key, [k for k in _TOML_KEYS if k not in data])
            raise WaypointError(f"{path}: unknown key {key!r}; expected one of {', '.join(_TOML_KEYS)}{hint}")
    if "waypoints" not in data:
        raise WaypointError(f"{path}: missing key 'waypoints' (a list of joint vectors)")
    rows = data["waypoints"]
    if not isinstance(rows, list) or not all(isinstance(r, list) for r in rows):
        raise WaypointError(f"{path}: 'waypoints' = {rows!r}: expected a list of joint vectors [[...], ...]")
    return data


def _read_csv(path: Path) -> list[list[Any]]:
    rows: list[list[Any]] = []
    try:
        text = read_bounded(path, "waypoint file", WaypointError).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise WaypointError(f"{path}: not UTF-8 text (byte {exc.start}): expected a CSV file of numbers") from None
    numbered = [(k, ln) for k, ln in enumerate(text.splitlines(), 1) if ln.strip() and not ln.lstrip().startswith("#")]
    if len(numbered) > MAX_WAYPOINTS + 1:  # + 1: a header line; counted before any row is parsed
        raise WaypointError(f"{path}: {len(numbered)} lines: more than the waypoint limit of {MAX_WAYPOINTS}")
    for lineno, line in numbered:
        _check_delimiter(path, lineno, line)
    lines = [ln for _, ln in numbered]
    for i, fields in enumerate(csv.reader(lines)):
        cells = [c.strip() for c in fields]
        parsed: list[Any] = []
        for c in cells:
            try:
                parsed.append(float(c))
            except ValueError:
                parsed.append(c)
        if i == 0 and all(isinstance(c, str) and _HEADER_CELL.match(c) for c in parsed):
            continue  # header line of joint names
        rows.append(parsed)
    return rows


#: A header cell of a waypoint CSV: a joint name, starting with a letter or ``_`` (``q1``, ``shoulder``).
_HEADER_CELL = re.compile(r"[A-Za-z_]")


def _check_delimiter(path: Path, lineno: int, line: str) -> None:
    """Refuse a line whose values are separated by ``;``, tabs or spaces: a waypoint CSV is comma-separated.

    Such a file (a spreadsheet's export in a locale with decimal commas) is refused rather than
    guessed at: ``0,5;1,2`` could be two numbers or four, and reading it either way unasked
    would move the robot somewhere its author did not write.
    """
    for sep, name in ((";", "';' (semicolons)"), ("\t", "tabs")):
        if sep in line and (sep == ";" or "," not in line):
            break
    else:
        words = line.split()
        if "," in line or len(words) < 2 or not all(_is_number(word) for word in words):
            return
        name = "spaces"
    raise WaypointError(f"{path} line {lineno}: values separated by {name}: expected comma-separated values "
                        "(',' between values, '.' as the decimal point), e.g. 0.0, 0.5, -1.2")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def load_waypoints(path: str | Path, robot: str | Path | RobotDescription = "scara",
                   segment_time: float | None = None) -> Task:
    """Read joint-space waypoints from a TOML or CSV file and check them against a robot.

    Parameters
    ----------
    path
        ``*.toml`` with ``waypoints = [[q1, ..., qn], ...]`` and optional
        ``segment_time`` (s), ``description``, ``labels``; or ``*.csv`` with one joint
        vector per line (optional header of joint names, ``#`` comments).
        Rows are numbered from 1, header and comments not counted.
    robot
        Built-in robot name, TOML path or description.
    segment_time
        Segment duration, s; overrides the file's; default 3 s if neither gives one.

    Returns
    -------
    Task

    Raises
    ------
    WaypointError
        Naming the file, the row and the joint: wrong joint count, not a number,
        NaN/inf, outside qlim; bad TOML; an unknown file type; a file above
        :data:`model.limits.MAX_FILE_BYTES` or with more than :data:`model.limits.MAX_WAYPOINTS` rows.
        Also when ``path`` does not exist or is a directory.
    """
    p = check_file(path, "waypoint file", WaypointError)
    suffix = p.suffix.lower()
    file_time: Any = None
    description = f"waypoints from {p.name}"
    labels: Any = None
    if suffix == ".toml":
        data = _read_toml(p)
        rows: Any = data["waypoints"]
        file_time = data.get("segment_time")
        description = data.get("description", description)
        labels = data.get("labels")
    elif suffix == ".csv":
        rows = _read_csv(p)
    else:
        raise WaypointError(f"{p}: expected a .toml or .csv waypoint file, got suffix {p.suffix!r}")
    desc = _description(robot)
    W = check_waypoints(rows, desc, str(p))
    T = segment_time if segment_time is not None else file_time if file_time is not None else 3.0
    if isinstance(T, bool) or not isinstance(T, (int, float)) or not math.isfinite(T) or T <= 0:
        raise WaypointError(f"{p}: 'segment_time' = {T!r}: expected a duration > 0 s")
    if labels is None:
        labels = tuple(f"w{k}" for k in range(W.shape[0]))
    elif not isinstance(labels, list) or len(labels) != W.shape[0] or not all(isinstance(s, str) for s in labels):
        raise WaypointError(f"{p}: 'labels' = {labels!r}: expected {W.shape[0]} strings, one per waypoint")
    if not isinstance(description, str):
        raise WaypointError(f"{p}: 'description' = {description!r}: expected a string")
    return Task(name=p.stem, robot=desc.name, waypoints=W, labels=tuple(labels),
                segment_time=float(T), description=description)
