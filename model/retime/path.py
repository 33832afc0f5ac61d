"""Geometric paths through joint-space waypoints, parameterised by a path coordinate s.

A path is ``q(s)`` with its derivatives ``q'(s)`` and ``q''(s)``, for s in
``[0, length]`` (joint-space arc length: rad for revolute joints, m for
prismatic ones, summed as one Euclidean length). It is made of one or more
*segments*, each traversed from rest to rest:

* :func:`straight_path` - the waypoints joined by straight joint-space
  segments; ``q'`` jumps at a waypoint, so the arm stops at each one.
* :func:`blended_path` - one natural cubic spline through all the waypoints
  (C2: position, velocity and acceleration continuous; zero second derivative at
  both ends), knots at the cumulative chord lengths; the arm passes the inner
  waypoints without stopping.

Each segment is a :class:`~model.trajectory.JointPath` whose "time" is s (the
quintic Hermite evaluator reproduces a straight line and a cubic exactly), so
one evaluator serves the planners, the retime and the tracking reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..trajectory import JointPath

__all__ = ["PATH_KINDS", "RetimePath", "PathLimitError", "straight_path", "blended_path", "segment_grids"]

Array = npt.NDArray[np.float64]

#: The path kinds: ``"straight"`` (stop at every waypoint) and ``"blend"`` (a C2 spline, no stop).
PATH_KINDS = ("straight", "blend")
#: Fewest grid intervals of one segment.
MIN_SEGMENT_INTERVALS = 8


class PathLimitError(InputError):
    """A path is degenerate (repeated waypoints) or leaves the joint limits; the message names the waypoint or s."""


@dataclass(frozen=True, eq=False)
class RetimePath:
    """A joint-space path as segments, each traversed from rest to rest.

    Attributes
    ----------
    kind
        ``"straight"`` or ``"blend"``.
    segments
        The segments, each a :class:`~model.trajectory.JointPath` in s from 0 to its length.
    waypoints
        (K+1, n) the waypoints the path passes through, rad or m.
    """

    kind: str
    segments: tuple[JointPath, ...]
    waypoints: Array

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.waypoints.shape[1])

    @property
    def lengths(self) -> Array:
        """(segments,) path length of each segment (joint-space arc length)."""
        return np.array([seg.t_end - seg.t_start for seg in self.segments])

    def evaluate(self, segment: int, s: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """``q(s)``, ``q'(s)``, ``q''(s)`` of one segment at the (N,) path coordinates ``s``, each (N, n)."""
        return self.segments[segment].batch(s)


def _waypoints(waypoints: npt.ArrayLike) -> Array:
    W = np.array(waypoints, dtype=float)
    if W.ndim != 2 or W.shape[0] < 2 or W.shape[1] < 1:
        raise PathLimitError(f"waypoints: expected a (K+1, n) array of at least 2 joint vectors, got shape {W.shape}")
    if not np.all(np.isfinite(W)):
        raise PathLimitError("waypoints: expected finite joint values")
    steps = np.linalg.norm(np.diff(W, axis=0), axis=1)
    if np.any(steps == 0.0):
        k = int(np.argmax(steps == 0.0))
        raise PathLimitError(f"waypoints: waypoint {k + 2} repeats waypoint {k + 1} ({W[k].tolist()}): a path "
                             "needs distinct consecutive waypoints")
    W.setflags(write=False)
    return W


def straight_path(waypoints: npt.ArrayLike) -> RetimePath:
    """The waypoints joined by straight joint-space segments, the arm at rest at every waypoint.

    Segment k is ``q(s) = w_k + s (w_{k+1} - w_k) / L_k`` for s in ``[0, L_k]``, ``L_k = |w_{k+1} - w_k|``
    (so ``|q'| = 1``, ``q'' = 0``). A straight joint-space segment between points inside the joint limits stays
    inside them.

    Raises
    ------
    PathLimitError
        Fewer than 2 waypoints, a non-finite value, or two equal consecutive waypoints.
    """
    W = _waypoints(waypoints)
    segments = []
    for a, b in zip(W[:-1], W[1:]):
        L = float(np.linalg.norm(b - a))
        direction = (b - a) / L
        zero = np.zeros((1, W.shape[1]))
        segments.append(JointPath([0.0, L], np.vstack([a, b]), np.vstack([direction, direction]), zero, zero))
    return RetimePath(kind="straight", segments=tuple(segments), waypoints=W)


def blended_path(waypoints: npt.ArrayLike, qlim: npt.ArrayLike | None = None) -> RetimePath:
    """One natural cubic spline through the waypoints (C2, not stopping at the inner ones).

    The knots are the cumulative chord lengths ``s_k = sum |w_{j+1} - w_j|`` (less overshoot than uniform knots
    where the waypoints are unevenly spaced); the end conditions are ``q''(0) = q''(S) = 0`` (natural). The spline's knot values,
    slopes and curvatures are those of :class:`scipy.interpolate.CubicSpline`; between the knots it is evaluated as
    the quintic Hermite piece with those end values, which is the same cubic.

    Parameters
    ----------
    waypoints
        (K+1, n) joint vectors, rad or m.
    qlim
        (2, n) joint limits; the spline is sampled (64 points per piece, its extremes solved exactly per piece)
        and refused if it leaves them.

    Raises
    ------
    PathLimitError
        As :func:`straight_path`; or the spline leaves ``qlim`` (naming the joint, the waypoints around it and
        the value): use the straight path there, or add a waypoint.
    """
    from scipy.interpolate import CubicSpline  # scipy is imported by the functions that use it

    W = _waypoints(waypoints)
    knots = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(W, axis=0), axis=1))])
    spline = CubicSpline(knots, W, bc_type="natural", axis=0)
    d1, d2 = spline(knots, 1), spline(knots, 2)
    d2[0] = 0.0  # natural ends, exactly
    d2[-1] = 0.0
    path = JointPath(knots, W, d1, d2[:-1], d2[1:])
    if qlim is not None:
        _check_spline_limits(spline, knots, np.asarray(qlim, dtype=float))
    return RetimePath(kind="blend", segments=(path,), waypoints=W)


def _check_spline_limits(spline: object, knots: Array, qlim: Array) -> None:
    """Refuse a spline whose extremes (per piece: the roots of q'(s) and the knots) leave ``qlim``."""
    lo, hi = qlim
    c = spline.c  # type: ignore[attr-defined]  # (4, pieces, n): c0 (s-s_k)^3 + c1 (s-s_k)^2 + c2 (s-s_k) + c3
    for k in range(knots.size - 1):
        h = knots[k + 1] - knots[k]
        for j in range(lo.size):
            a3, a2, a1, a0 = c[:, k, j]
            cand = [0.0, h]
            disc = a2 * a2 - 3.0 * a3 * a1  # roots of 3 a3 x^2 + 2 a2 x + a1
            if a3 != 0.0 and disc >= 0.0:
                cand += [(-a2 + sgn * math.sqrt(disc)) / (3.0 * a3) for sgn in (-1.0, 1.0)]
            elif a3 == 0.0 and a2 != 0.0:
                cand.append(-a1 / (2.0 * a2))
            for x in cand:
                if 0.0 <= x <= h:
                    v = ((a3 * x + a2) * x + a1) * x + a0
                    if v < lo[j] - 1e-12 * max(1.0, abs(lo[j])) or v > hi[j] + 1e-12 * max(1.0, abs(hi[j])):
                        raise PathLimitError(
                            f"blended path: joint {j + 1} reaches {v:.6g} between waypoints {k + 1} and {k + 2}, "
                            f"outside qlim [{lo[j]:g}, {hi[j]:g}]: the spline overshoots there; retime the straight "
                            "path (no --blend) or add a waypoint")


def segment_grids(path: RetimePath, intervals: int) -> list[Array]:
    """Grids in s for each segment: about ``intervals`` equal-length intervals over the whole path.

    Each segment gets a share proportional to its length (at least :data:`MIN_SEGMENT_INTERVALS`), spaced
    uniformly, both ends included.
    """
    if isinstance(intervals, bool) or not isinstance(intervals, (int, np.integer)) or intervals < 2:
        raise InputError(f"grid: expected a whole number of grid intervals >= 2, got {intervals!r}")
    L = path.lengths
    total = float(L.sum())
    grids = []
    for seg, length in zip(path.segments, L.tolist()):
        m = max(MIN_SEGMENT_INTERVALS, int(round(intervals * length / total)))
        grids.append(seg.t_start + np.arange(m + 1) * (length / m))
    for g, seg in zip(grids, path.segments):
        g[-1] = seg.t_end  # the end exactly
    return grids
