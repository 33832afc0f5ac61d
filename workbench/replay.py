"""Joint motions to play back on the teach page: a task's trajectory or a saved tracking run.

``manip track`` saves its run as ``tracking.npz`` (:func:`save_replay`: the
control instants, the plant's ``q`` and the reference ``q_ref``), and
``manip teach ROBOT --result DIR`` reads it back (:func:`load_replay`). The
file is a plain NumPy archive, read without pickles; its size, its members
and their shapes are checked before anything is used.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from model.errors import InputError
from model.files import atomic_path
from model.limits import MAX_FILE_BYTES, MAX_WAYPOINTS

if TYPE_CHECKING:  # pragma: no cover
    from closed_loop.result import TrackingResult
    from model.tasks import Task

__all__ = ["REPLAY_FILE", "Replay", "ReplayError", "save_replay", "load_replay", "task_replay"]

#: Name of the file ``manip track`` writes into its ``--out`` folder for the teach page.
REPLAY_FILE = "tracking.npz"
#: Largest uncompressed archive read, bytes: 8 times a robot file's limit (80 MiB; a 60 s run of a
#: 7-joint arm at 1 kHz is 6.7 MB).
_MAX_REPLAY_BYTES = 8 * MAX_FILE_BYTES
#: Most samples of a replay (a 10 min run at 1 kHz).
_MAX_SAMPLES = 6 * MAX_WAYPOINTS


class ReplayError(InputError):
    """A replay file is missing, unreadable or does not fit the robot; the message names the file."""


@dataclass(frozen=True, eq=False)
class Replay:
    """A joint motion sampled in time.

    Attributes
    ----------
    name
        What it is, for the page (``"task pick_and_place"``, ``"tracking result (ct)"``).
    t
        (N,) strictly increasing times, s.
    q
        (N, n) joint values, rad or m.
    """

    name: str
    t: np.ndarray
    q: np.ndarray

    @property
    def duration(self) -> float:
        """Length of the motion, s."""
        return float(self.t[-1] - self.t[0])

    def at(self, time: float) -> np.ndarray:
        """(n,) joint values at ``time`` s after the start, linearly interpolated, clamped at the ends."""
        t = self.t[0] + min(max(time, 0.0), self.duration)
        return np.array([np.interp(t, self.t, self.q[:, j]) for j in range(self.q.shape[1])])


def task_replay(task: "Task", dt: float = 0.01) -> Replay:
    """The sampled trajectory of a task (quintic segments, its own segment time), as a :class:`Replay`."""
    traj = task.trajectory(dt=dt)
    return Replay(name=f"task {task.name}", t=np.asarray(traj.t, dtype=float), q=np.asarray(traj.q, dtype=float))


def save_replay(result: "TrackingResult", path: str | Path) -> Path:
    """Write ``t``, ``q`` and ``q_ref`` of a tracking run (and its robot and controller) to ``path``, atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, t=result.t, q=result.q, q_ref=result.q_ref, robot=np.array(result.robot),
                     controller=np.array(result.controller))
    return path


def _fail(path: Path, what: str) -> ReplayError:
    return ReplayError(f"--result: {str(path)!r}: {what}")


def load_replay(folder_or_file: str | Path, robot_name: str, n: int) -> Replay:
    """The tracking run saved by ``manip track`` in a folder (or the ``.npz`` itself), checked against the robot.

    Raises
    ------
    ReplayError
        Missing file; not a NumPy archive; larger than 80 MiB uncompressed; a member
        missing, of the wrong shape or not finite; saved for another robot or
        another number of joints.
    """
    path = Path(folder_or_file)
    if path.is_dir():
        path = path / REPLAY_FILE
    if not path.is_file():
        raise _fail(path, f"no such file (run `manip track ... --out DIR` first; it writes DIR/{REPLAY_FILE})")
    try:
        with zipfile.ZipFile(path) as zf:
            total = sum(info.file_size for info in zf.infolist())
    except (zipfile.BadZipFile, OSError) as exc:
        raise _fail(path, f"not a NumPy .npz archive ({exc})") from None
    if total > _MAX_REPLAY_BYTES:
        raise _fail(path, f"{total} bytes uncompressed, more than the limit of {_MAX_REPLAY_BYTES}")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {key: data[key] for key in ("t", "q", "robot", "controller") if key in data.files}
    except (ValueError, OSError, zipfile.BadZipFile) as exc:
        raise _fail(path, f"unreadable ({exc})") from None
    for key in ("t", "q", "robot", "controller"):
        if key not in arrays:
            raise _fail(path, f"member {key!r} missing")
    t, q = arrays["t"], arrays["q"]
    if t.dtype.kind != "f" or t.ndim != 1 or not 2 <= t.size <= _MAX_SAMPLES:
        raise _fail(path, f"'t': expected 2 to {_MAX_SAMPLES} float times, got dtype {t.dtype} shape {t.shape}")
    if q.dtype.kind != "f" or q.shape != (t.size, n):
        raise _fail(path, f"'q': expected float shape ({t.size}, {n}) for {robot_name!r}, got dtype {q.dtype} shape {q.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q)) and np.all(np.diff(t) > 0)):
        raise _fail(path, "'t' and 'q' must be finite and 't' strictly increasing")
    saved_robot = str(arrays["robot"])
    if saved_robot != robot_name:
        raise _fail(path, f"saved for robot {saved_robot!r}, not {robot_name!r}")
    return Replay(name=f"tracking result ({arrays['controller']})", t=t.astype(float), q=q.astype(float))
