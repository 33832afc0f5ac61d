"""One call from waypoints and limits to the time-optimal motion: :func:`retime`."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from .limits import RetimeLimits
from .path import PATH_KINDS, RetimePath, blended_path, segment_grids, straight_path
from .result import Retiming
from .solver import path_constraints, solve_segment

if TYPE_CHECKING:  # pragma: no cover
    from ..robot import Robot

__all__ = ["DEFAULT_GRID", "retime", "retime_path"]

#: Default number of grid intervals along the whole path.
DEFAULT_GRID = 1000


def retime_path(robot: "Robot", path: RetimePath, limits: RetimeLimits, grid: int = DEFAULT_GRID) -> Retiming:
    """The time-optimal motion of ``robot`` along ``path`` within ``limits``, on about ``grid`` grid intervals.

    Raises
    ------
    model.retime.RetimeInfeasibleError
        No motion along the path stays within the limits (the message names s and the joint).
    InputError
        A path of another joint count than the robot's, a bad grid.
    """
    if path.n != robot.n:
        raise InputError(f"waypoints: expected {robot.n} joint values per waypoint for robot {robot.name!r}, got {path.n}")
    start = time.perf_counter()
    grids = segment_grids(path, grid)
    constraints = tuple(path_constraints(robot, seg, g, limits) for seg, g in zip(path.segments, grids))
    solutions = tuple(solve_segment(pc) for pc in constraints)
    return Retiming(robot=robot.name, path=path, limits=limits, segments=solutions, constraints=constraints,
                    solve_time=time.perf_counter() - start)


def retime(robot: "Robot", waypoints: npt.ArrayLike, limits: RetimeLimits, *, blend: bool = False,
           grid: int = DEFAULT_GRID) -> Retiming:
    """Time-optimal motion through joint-space ``waypoints`` (K+1, n) within ``limits``.

    Parameters
    ----------
    robot
        The arm (its inverse dynamics with motors, gears and friction).
    waypoints
        (K+1, n) joint vectors, rad or m, each within the joint limits.
    limits
        From :func:`model.retime.retime_limits`.
    blend
        False: straight joint-space segments, at rest at every waypoint (:func:`~model.retime.straight_path`);
        True: one C2 natural cubic spline through them, not stopping (:func:`~model.retime.blended_path`;
        refused if it leaves the joint limits).
    grid
        Grid intervals along the whole path.
    """
    W = np.asarray(waypoints, dtype=float)
    lo, hi = robot.qlim
    if W.ndim == 2 and W.shape[1] == robot.n:
        bad = np.argwhere((W < lo) | (W > hi))
        if bad.size:
            r, j = bad[0]
            raise InputError(f"waypoints: row {r + 1}, joint {j + 1}: {W[r, j]:g} outside qlim [{lo[j]:g}, {hi[j]:g}]")
    path = blended_path(W, robot.qlim) if blend else straight_path(W)
    assert path.kind in PATH_KINDS
    return retime_path(robot, path, limits, grid)
