"""Trajectory files: a joint trajectory as a joint-table CSV (``time, q_<joint>.., qd_<joint>.., qdd_<joint>..``).

``manip retime`` writes one, ``manip excite`` writes one, ``manip track ROBOT --trajectory FILE`` follows any.
The file's samples become a :class:`~model.trajectory.Trajectory` whose path is the piecewise quintic Hermite
through them (:func:`sampled_trajectory`): it reproduces each sample's q, qd and qdd exactly, and a closed loop
evaluates it at its own control instants.

A file is refused, in one line naming it, the line and the joint (:class:`TrajectoryFileError`), when

* it is not a joint table of the robot's joints with groups q, qd and qdd (:func:`model.joint_table.read_joint_table`);
* its q, qd and qdd do not belong together: over each interval ``h`` between two samples, the velocities
  must integrate to the change of position and the accelerations to the change of velocity, both to
  :data:`CONSISTENCY_TOL` (1 %) of the joint's peak speed (the rules, exact for cubic and quadratic motion, are
  in :func:`check_consistency`). A file in the wrong units (deg, deg/s), qd that is not the derivative of q, or
  samples too far apart to follow the motion between them fail it;
* a sample leaves the joint limits, or the start or any sample is faster than a joint's ``velocity_limit``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from .joint_table import JointTableError, read_joint_table, write_joint_table
from .trajectory import JointPath, Trajectory

if TYPE_CHECKING:  # pragma: no cover
    from .description import RobotDescription

__all__ = ["CONSISTENCY_TOL", "GROUPS", "VELOCITY_RTOL", "TrajectoryFileError", "check_consistency", "read_trajectory",
           "sampled_trajectory", "write_trajectory"]

Array = npt.NDArray[np.float64]

#: The groups of a trajectory file, in order: positions, velocities, accelerations (SI, joint side).
GROUPS = ("q", "qd", "qdd")
#: Largest mismatch between a file's q, qd and qdd over one interval, as a share of the joint's peak speed.
CONSISTENCY_TOL = 0.01
#: Peak speeds below this share of the fastest joint's count as that share (a joint at rest is held to it).
_SPEED_FLOOR = 1e-3
#: Relative slack of the joint-limit check (a sample exactly on a limit, rounded).
_LIMIT_RTOL = 1e-9
#: Relative slack of the velocity-limit check (a sample exactly on its limit, rounded: a time-optimal
#: motion runs along its speed limit).
VELOCITY_RTOL = 1e-9


class TrajectoryFileError(JointTableError):
    """A trajectory file is malformed or does not suit the robot; the message names the file, line and joint."""


def sampled_trajectory(t: npt.ArrayLike, q: npt.ArrayLike, qd: npt.ArrayLike, qdd: npt.ArrayLike, *,
                       name: str = "trajectory file", t_via: npt.ArrayLike | None = None,
                       q_via: npt.ArrayLike | None = None) -> Trajectory:
    """A :class:`~model.trajectory.Trajectory` of samples, its path the quintic Hermite through all of them.

    Parameters
    ----------
    t
        (N,) strictly increasing times, s.
    q, qd, qdd
        (N, n) positions, velocities and accelerations at them (rad or m, per s, per s^2).
    name
        The trajectory's name.
    t_via, q_via
        Segment boundaries and the positions there (default: the first and the last sample).
    """
    tt = np.asarray(t, dtype=float)
    Q, QD, QDD = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
    path = JointPath(tt, Q, QD, QDD[:-1], QDD[1:])
    steps = np.diff(tt)
    uniform = bool(np.all(np.abs(steps - steps.mean()) <= 1e-9 * steps.mean()))
    tv = np.array([tt[0], tt[-1]]) if t_via is None else np.asarray(t_via, dtype=float)
    qv = np.vstack([Q[0], Q[-1]]) if q_via is None else np.asarray(q_via, dtype=float)
    return Trajectory(t=tt, q=Q, qd=QD, qdd=QDD, path=path, t_via=tv, q_via=qv,
                      dt=float(steps.mean()) if uniform else None, name=name)


def check_consistency(t: Array, q: Array, qd: Array, qdd: Array, where: str,
                      tol: float = CONSISTENCY_TOL) -> None:
    """Refuse samples whose q, qd and qdd do not belong together (see the module docstring).

    On the interval ``[t_k, t_k+1]`` of length h, per joint:

    * position: ``(q_k+1 - q_k) / h`` against ``(qd_k + qd_k+1) / 2 + h (qdd_k - qdd_k+1) / 12``
      (exact for a cubic, so O(h^4) for smooth motion);
    * velocity: ``qd_k+1 - qd_k`` against ``h (qdd_k + qdd_k+1) / 2`` (exact for a quadratic: O(h^3);
      a jump of qdd inside the interval costs at most ``h |jump| / 2``).

    Each mismatch must be within ``tol`` times the joint's peak speed (at least ``1e-3`` times the fastest
    joint's). Raises :class:`TrajectoryFileError` naming ``where``, the data line (header = line 1) and the joint.
    """
    h = np.diff(t)[:, None]
    pos = np.abs((q[1:] - q[:-1]) / h - 0.5 * (qd[:-1] + qd[1:]) - h * (qdd[:-1] - qdd[1:]) / 12.0)
    vel = np.abs((qd[1:] - qd[:-1]) - 0.5 * h * (qdd[:-1] + qdd[1:]))
    peak = np.max(np.abs(qd), axis=0)
    fastest = float(peak.max())
    scale = np.maximum(peak, _SPEED_FLOOR * fastest) if fastest > 0.0 else np.full(peak.shape, np.inf)
    for what, err, rule in (("position", pos, "the mean of qd (with its qdd correction) over the interval"),
                            ("velocity", vel, "the integral of qdd over the interval")):
        ratio = err / (tol * scale)
        if np.any(ratio > 1.0):
            k, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
            raise TrajectoryFileError(
                f"{where} lines {k + 2}-{k + 3}: joint {j + 1}'s {what} change disagrees with {rule} by "
                f"{float(err[k, j]):.3g} ({100 * float(ratio[k, j]) * tol:.3g} % of its peak speed "
                f"{float(scale[j]):.4g}, tolerance {100 * tol:g} %): q, qd and qdd must be SI values of one motion, "
                "sampled finely enough to follow it")


def read_trajectory(path: str | Path, description: "RobotDescription") -> Trajectory:
    """Read a trajectory file for a robot and check it (see the module docstring).

    Raises
    ------
    TrajectoryFileError, model.joint_table.JointTableError
        Naming the file, the line or column, and the joint.
    """
    table = read_joint_table(path, description.joint_names, GROUPS, what="trajectory file")
    t, q, qd, qdd = table.t, table["q"], table["qd"], table["qdd"]
    where = str(path)
    lo, hi = description.qlim
    slack = _LIMIT_RTOL * np.maximum(1.0, np.abs(np.where(np.isfinite(lo), lo, 0.0)))
    out = (q < lo - slack) | (q > hi + slack)
    if np.any(out):
        k, j = np.argwhere(out)[0]
        raise TrajectoryFileError(f"{where} line {k + 2}: q_{description.joint_names[j]} = {float(q[k, j])!r} outside "
                                  f"qlim [{lo[j]:g}, {hi[j]:g}] of joint {j + 1}")
    vmax = np.array([math.inf if lk.velocity_limit is None else lk.velocity_limit for lk in description.links])
    fast = np.abs(qd) > vmax * (1.0 + VELOCITY_RTOL)
    if np.any(fast):
        k, j = np.argwhere(fast)[0]
        state = "the start" if k == 0 else "a sample"
        raise TrajectoryFileError(f"{where} line {k + 2}: {state} is too fast: qd_{description.joint_names[j]} = "
                                  f"{float(qd[k, j])!r} above velocity_limit {vmax[j]:g} of joint {j + 1}")
    check_consistency(t, q, qd, qdd, where)
    return sampled_trajectory(t, q, qd, qdd, name=f"trajectory file {Path(path).name}")


def write_trajectory(path: str | Path, traj: Trajectory, joint_names: tuple[str, ...]) -> Path:
    """Write ``traj``'s samples as a trajectory file (atomically: complete or not at all); returns the path."""
    return write_joint_table(path, traj.t, {"q": traj.q, "qd": traj.qd, "qdd": traj.qdd}, joint_names)
