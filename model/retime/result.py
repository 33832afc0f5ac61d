"""The result of a retime: the time law on every segment, evaluable at any time, and its checks.

On stage i of a segment (grid points ``s_i`` to ``s_{i+1}``) the path acceleration ``sdd_i`` is constant,
so the stage lasts ``h_i = 2 (s_{i+1} - s_i) / (sd_i + sd_{i+1})`` and, ``tau`` seconds into it,
``s = s_i + sd_i tau + sdd_i tau^2 / 2``, ``sd = sd_i + sdd_i tau``; then ``qd = q'(s) sd`` and
``qdd = q'(s) sdd + q''(s) sd^2`` exactly. Segments follow each other, the arm at rest between them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputError
from ..trajectory import Trajectory, _readonly
from .limits import RetimeLimits
from .path import RetimePath
from .solver import PathConstraints, SegmentSolution

__all__ = ["Retiming", "GridCheck", "DEFAULT_SAMPLE_STEP", "DEFAULT_SMOOTH", "JUMP_STEP"]

Array = npt.NDArray[np.float64]

#: Default sampling period of a retimed trajectory (its CSV and its tracking reference), s.
DEFAULT_SAMPLE_STEP = 1e-3
#: Time between a segment boundary's sample and the next one, s: the acceleration jumps in between. Far below
#: any control period (a closed loop reads the reference at most every 0.1 ms here), far above the rounding
#: of a time of hours (1e-12 s).
JUMP_STEP = 1e-6
#: Default width of the window a sampled retimed motion is averaged over, s: one period of the default 1 kHz
#: control rate, so that a bang-bang switch of the time-optimal law becomes a ramp the sampled loop can follow.
DEFAULT_SMOOTH = 1e-3


def _law(sol: SegmentSolution, tau: Array) -> tuple[Array, Array, Array, Array]:
    """One segment's time law at the times ``tau`` (s from its start; at rest before and after): s, sd, sdd and the
    integral of s from 0 to tau (constant sdd per stage: s, sd, sdd exact; the integral exact too)."""
    h = sol.stage_times
    t0 = np.concatenate([[0.0], np.cumsum(h)])
    s0, y0, u = sol.s[:-1], sol.sd[:-1], sol.sdd
    # integral of s over each whole stage: s0 h + y0 h^2 / 2 + u h^3 / 6
    whole = np.concatenate([[0.0], np.cumsum(s0 * h + 0.5 * y0 * h * h + u * h ** 3 / 6.0)])
    T = float(t0[-1])
    tt = np.clip(tau, 0.0, T)
    i = np.clip(np.searchsorted(t0, tt, side="right") - 1, 0, h.size - 1)
    d = np.clip(tt - t0[i], 0.0, h[i])
    s = s0[i] + y0[i] * d + 0.5 * u[i] * d * d
    sd = y0[i] + u[i] * d
    sdd = u[i].copy()
    integral = whole[i] + s0[i] * d + 0.5 * y0[i] * d * d + u[i] * d ** 3 / 6.0
    before, after = tau < 0.0, tau > T
    s[before], s[after] = sol.s[0], sol.s[-1]
    sd[before | after] = 0.0
    sdd[before | after] = 0.0
    integral[before] = sol.s[0] * tau[before]
    integral[after] = whole[-1] + sol.s[-1] * (tau[after] - T)
    return s, sd, sdd, integral


def _smoothed_law(sol: SegmentSolution, tau: Array, w: float) -> tuple[Array, Array, Array]:
    """The time law averaged over ``[tau - w/2, tau + w/2]``: s, sd and sdd of the averaged motion, each the exact
    derivative of the one before (differences of the law's integral, position and speed across the window)."""
    a = _law(sol, tau + 0.5 * w)
    b = _law(sol, tau - 0.5 * w)
    return (a[3] - b[3]) / w, (a[0] - b[0]) / w, (a[1] - b[1]) / w


@dataclass(frozen=True)
class GridCheck:
    """The worst use of each limit over the grid points (collocation states ``(sd_i, sdd_i)``), as a ratio.

    ``torque`` is ``max |tau_j| / tau_max_j`` (the margin-reduced joint-side bound), ``velocity`` and
    ``acceleration`` likewise (0 where no joint has one); 1 means at the limit. ``joint`` names the joint
    (0-based) of the torque maximum and ``s`` where it is.
    """

    torque: float
    velocity: float
    acceleration: float
    torque_joint: int
    torque_s: float

    def to_dict(self) -> dict[str, Any]:
        return {"torque": self.torque, "velocity": self.velocity, "acceleration": self.acceleration,
                "torque_joint": self.torque_joint + 1, "torque_s": self.torque_s}


@dataclass(frozen=True, eq=False)
class Retiming:
    """A time-optimal motion along a path within limits (from :func:`model.retime.retime`).

    Attributes
    ----------
    robot
        Name of the robot.
    path
        The geometric path.
    limits
        The limits kept.
    segments
        One :class:`~model.retime.solver.SegmentSolution` per path segment.
    constraints
        The constraints of each segment on its grid.
    solve_time
        Wall time of the solver (constraints and both passes), s.
    """

    robot: str
    path: RetimePath
    limits: RetimeLimits
    segments: tuple[SegmentSolution, ...]
    constraints: tuple[PathConstraints, ...]
    solve_time: float

    def __post_init__(self) -> None:
        starts, s0, y0, u, h, seg = [], [], [], [], [], []
        t = 0.0
        bounds = [0.0]
        for k, sol in enumerate(self.segments):
            times = sol.stage_times
            offsets = t + np.concatenate([[0.0], np.cumsum(times)])
            starts.append(offsets[:-1])
            s0.append(sol.s[:-1])
            y0.append(sol.sd[:-1])
            u.append(sol.sdd)
            h.append(times)
            seg.append(np.full(times.size, k))
            t = float(offsets[-1])
            bounds.append(t)
        object.__setattr__(self, "_stage", tuple(_readonly(np.concatenate(a)) for a in (starts, s0, y0, u, h)))
        object.__setattr__(self, "_segment_of", np.concatenate(seg))
        object.__setattr__(self, "_bounds", _readonly(np.array(bounds)))

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.path.n

    @property
    def duration(self) -> float:
        """Duration of the whole motion, s."""
        return float(self._bounds[-1])  # type: ignore[attr-defined]

    @property
    def segment_times(self) -> Array:
        """(segments + 1,) times at which each segment starts, and the end, s."""
        return self._bounds  # type: ignore[attr-defined]

    @property
    def grid_times(self) -> list[Array]:
        """Per segment, the (N+1,) times at its grid points, s."""
        out = []
        for k, sol in enumerate(self.segments):
            out.append(self._bounds[k] + np.concatenate([[0.0], np.cumsum(sol.stage_times)]))  # type: ignore[attr-defined]
        return out

    def batch(self, t: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """Joint positions, velocities and accelerations at the (T,) times ``t`` (s), each (T, n).

        Before the start and after the end the arm rests at the first and last waypoint.
        """
        tt = np.asarray(t, dtype=float)
        start, s0, y0, u, h = self._stage  # type: ignore[attr-defined]
        idx = np.clip(np.searchsorted(start, tt, side="right") - 1, 0, start.size - 1)
        tau = np.clip(tt - start[idx], 0.0, h[idx])
        s = s0[idx] + y0[idx] * tau + 0.5 * u[idx] * tau * tau
        sd = y0[idx] + u[idx] * tau
        sdd = u[idx].copy()
        outside = (tt < 0.0) | (tt > self.duration)
        sd[outside] = 0.0
        sdd[outside] = 0.0
        seg = self._segment_of[idx]  # type: ignore[attr-defined]
        Q = np.empty((tt.size, self.n))
        QD = np.empty_like(Q)
        QDD = np.empty_like(Q)
        for k in np.unique(seg):
            m = seg == k
            path = self.path.segments[int(k)]
            sk = np.clip(s[m], path.t_start, path.t_end)
            q, dq, ddq = path.batch(sk)
            Q[m] = q
            QD[m] = dq * sd[m, None]
            QDD[m] = dq * sdd[m, None] + ddq * (sd[m] ** 2)[:, None]
        return Q, QD, QDD

    def sample_times(self, dt: float = DEFAULT_SAMPLE_STEP) -> Array:
        """Sample times: each segment on its own uniform grid of step at most ``dt`` (s), its start and end included.

        The arm is at rest at a segment boundary and its acceleration jumps there (from braking along one
        segment to accelerating along the next): the boundary is a sample, and so is the instant
        :data:`JUMP_STEP` after it, so that the jump falls between two samples that far apart (one acceleration
        per sample cannot hold both sides of it).
        """
        b = self.segment_times
        parts = [np.array([b[0]])]
        for k in range(b.size - 1):
            T = float(b[k + 1] - b[k])
            m = max(1, math.ceil(T / dt - 1e-9))
            t = b[k] + np.arange(1, m + 1) * (T / m)
            t[-1] = b[k + 1]
            if k:
                parts.append(np.array([b[k] + JUMP_STEP]))
            parts.append(t)
        return np.concatenate(parts)

    def trajectory(self, dt: float = DEFAULT_SAMPLE_STEP, smooth: float = DEFAULT_SMOOTH) -> Trajectory:
        """The motion sampled every ``dt`` at most (s), as a Trajectory (what ``manip retime`` writes and tracks).

        Its ``path`` is the quintic Hermite through the samples (:func:`model.trajectory_file.sampled_trajectory`),
        the same that ``manip track --trajectory`` builds from the CSV of these samples.

        ``smooth`` (s, default :data:`DEFAULT_SMOOTH`): the time law of each segment averaged over a window of that
        width (:meth:`smoothed`): still exactly on the path, its acceleration ramps over ``smooth`` where the
        time-optimal one jumps (a bang-bang switch, the start and stop at a waypoint), so that a loop sampled at
        that period can follow it; each segment lasts ``smooth`` longer. The torques are then averages of admissible
        ones over the window, within the bounds up to the change of the path's coefficients across it
        (``docs/retime.md`` gives the measured excess). ``smooth = 0``: the time-optimal law itself, its
        jumps between two samples :data:`JUMP_STEP` apart at segment boundaries.
        """
        from ..trajectory_file import sampled_trajectory

        if smooth < 0.0 or not math.isfinite(smooth):
            raise InputError(f"expected a window >= 0 s, got {smooth!r}", parameter="smooth")
        if smooth == 0.0:
            t = self.sample_times(dt)
            q, qd, qdd = self.batch(t)
            for k in range(1, len(self.segments)):
                i = int(np.searchsorted(t, self.segment_times[k]))
                qd[i] = 0.0
                qdd[i] = self.constraints[k - 1].dq[-1] * self.segments[k - 1].sdd[-1]
            bounds = self.segment_times
        else:
            parts, start, bounds = [], 0.0, [0.0]
            for k, sol in enumerate(self.segments):
                T = sol.duration + smooth
                m = max(1, math.ceil(T / dt - 1e-9))
                tau = np.arange(0 if k == 0 else 1, m + 1) * (T / m)
                tau[-1] = T
                s, sd, sdd = _smoothed_law(sol, tau - 0.5 * smooth, smooth)
                path = self.path.segments[k]
                qk, dq, ddq = path.batch(np.clip(s, path.t_start, path.t_end))
                qd_k, qdd_k = dq * sd[:, None], dq * sdd[:, None] + ddq * (sd * sd)[:, None]
                # Where the speed limit curve bends within the window the average crosses it (by 1e-5 of the
                # limit on the panda's tour): the segment is slowed uniformly by that share, t -> r t, which
                # keeps it on the path and consistent, and every joint within its velocity_limit.
                r = max(1.0, float(np.max(np.abs(qd_k) / self.limits.velocity)))
                tau, qd_k, qdd_k, T = tau * r, qd_k / r, qdd_k / (r * r), T * r
                parts.append((start + tau, qk, qd_k, qdd_k))
                start += T
                bounds.append(start)
            t, q, qd, qdd = (np.concatenate([p[i] for p in parts]) for i in range(4))
            t[-1] = start
            bounds = np.array(bounds)
        return sampled_trajectory(t, q, qd, qdd, name="retime", t_via=bounds,
                                  q_via=self.path.waypoints if self.path.kind == "straight"
                                  else self.path.waypoints[[0, -1]])

    def grid_states(self, k: int, end: bool = False) -> tuple[Array, Array, Array, Array]:
        """Segment k's states at its grid points, each stage's acceleration held: (N, n) q, qd, qdd and (N,) s.

        ``end=False``: the state where each stage starts, ``(sd_i, sdd_i)`` at ``s_i`` (i = 0..N-1);
        ``end=True``: where it ends, ``(sd_{i+1}, sdd_i)`` at ``s_{i+1}``. The retime keeps both within the limits.
        """
        pc, sol = self.constraints[k], self.segments[k]
        at = slice(1, None) if end else slice(0, -1)
        y, u = sol.sd[at], sol.sdd
        return pc.q[at], pc.dq[at] * y[:, None], pc.dq[at] * u[:, None] + pc.ddq[at] * (y * y)[:, None], pc.s[at]

    def check(self) -> GridCheck:
        """The worst use of each limit over every grid point, both one-sided accelerations (see :class:`GridCheck`)."""
        torque, joint, where, acc, vel = 0.0, 0, 0.0, 0.0, 0.0
        for pc, sol in zip(self.constraints, self.segments):
            for at in (slice(0, -1), slice(1, None)):
                y, u = sol.sd[at], sol.sdd
                vals = (pc.alpha[at] * u[:, None] + pc.beta[at] * (y * y)[:, None] + pc.gamma[at] * y[:, None]
                        + pc.delta[at])
                ratio = np.abs(vals) / pc.hi[at]
                for r, (kind, j) in enumerate(pc.rows):
                    i = int(np.argmax(ratio[:, r]))
                    if kind == "torque" and ratio[i, r] > torque:
                        torque, joint, where = float(ratio[i, r]), j, float(pc.s[at][i])
                    elif kind == "acceleration":
                        acc = max(acc, float(ratio[i, r]))
            vel = max(vel, float(np.max(np.abs(pc.dq * sol.sd[:, None]) / self.limits.velocity)))
        return GridCheck(torque=torque, velocity=vel, acceleration=acc, torque_joint=joint, torque_s=where)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: duration, path, grid, limits and the worst use of each."""
        return {"robot": self.robot, "duration_s": self.duration, "path": self.path.kind,
                "waypoints": self.path.waypoints.tolist(), "segment_times_s": self.segment_times.tolist(),
                "grid_points": int(sum(sol.s.size for sol in self.segments)), "solve_time_s": self.solve_time,
                "limits": self.limits.to_dict(), "grid_check": self.check().to_dict()}
