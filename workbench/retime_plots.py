"""The figure of a retime: the path speed against its limit curve, and each motor's torque against its limit.

:func:`retime_figure` draws a :class:`~model.retime.Retiming` (built with :class:`matplotlib.figure.Figure`,
no pyplot state): on top the path speed ``sd(s)`` along the whole path (segments one after the other), the
maximal velocity curve (the largest speed each point admits on its own) and the top of the controllable set
(the largest speed from which the arm can still stop in time); below, one panel per motor with its torque
along the motion (from the inverse dynamics, sampled every millisecond, not only at the grid points), the
motor limit and the share the retime was allowed to use (``--torque-margin``); joint speeds and
accelerations against their limits where the robot or the flags give any.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:  # pragma: no cover
    from model.retime import Retiming
    from model.robot import Robot

__all__ = ["RetimeSamples", "retime_samples", "retime_figure"]


class RetimeSamples:
    """A retimed motion sampled in time, with its motor torques: what the figure and the report show.

    Attributes ``t`` (T,) s; ``q``, ``qd``, ``qdd`` (T, n); ``tau_m`` (T, n) motor torques, N m (inverse dynamics
    with motors and friction, divided by the gear ratios).
    """

    def __init__(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, tau_m: np.ndarray) -> None:
        self.t, self.q, self.qd, self.qdd, self.tau_m = t, q, qd, qdd, tau_m


def retime_samples(robot: "Robot", motion: "Retiming", dt: float = 1e-3) -> RetimeSamples:
    """The motion at ``t = k dt`` (and its end) with its motor torques ``rne(q, qd, qdd) / G``."""
    T = motion.duration
    t = np.append(np.arange(0.0, T, dt), T)
    q, qd, qdd = motion.batch(t)
    tau_m = robot.rne_batch(q, qd, qdd) / robot.gear_ratio
    return RetimeSamples(t, q, qd, qdd, tau_m)


def retime_figure(robot: "Robot", motion: "Retiming", samples: RetimeSamples | None = None,
                  title: str = "") -> Figure:
    """Path speed against its limit curve (top) and motor torques against their limits (one panel per motor)."""
    smp = retime_samples(robot, motion) if samples is None else samples
    n = robot.n
    lim = motion.limits
    extra = [k for k, v in (("velocity", lim.velocity), ("acceleration", lim.acceleration)) if np.isfinite(v).any()]
    rows = 1 + (n + 1) // 2 + (1 if extra else 0)
    fig = Figure(figsize=(11.0, 2.3 * rows + 0.8), layout="constrained")
    grid = fig.add_gridspec(rows, 2)
    ax = fig.add_subplot(grid[0, :])
    offset = 0.0
    peak = 0.0
    for k, (seg, pc) in enumerate(zip(motion.segments, motion.constraints)):
        s = offset + seg.s - seg.s[0]
        top = np.sqrt(seg.K[:, 1])
        peak = max(peak, float(seg.sd.max()), float(top.max()))
        ax.plot(s, seg.y_limit, color="0.55", lw=1.0, label="maximal velocity curve (each point on its own)" if k == 0 else None)
        ax.plot(s, top, color="tab:orange", lw=1.0, ls="--", label="controllable: can still stop in time" if k == 0 else None)
        ax.plot(s, seg.sd, color="tab:blue", lw=1.4, label="retimed sd(s)" if k == 0 else None)
        if k:
            ax.axvline(offset, color="0.8", lw=0.8)
        offset = float(s[-1])
    ax.set_ylim(0.0, 1.15 * peak if peak > 0 else 1.0)  # an unbounded curve (no speed limit there) runs off the top
    ax.set_xlim(0.0, offset)
    ax.set_xlabel("path coordinate s (joint-space arc length)")
    ax.set_ylabel("path speed sd [1/s]")
    kind = "straight segments, at rest at each waypoint" if motion.path.kind == "straight" else "C2 spline through the waypoints"
    ax.set_title(f"{motion.duration:.3f} s along {kind}", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(True, alpha=0.3)
    names = robot.description.joint_names
    for j in range(n):
        axj = fig.add_subplot(grid[1 + j // 2, j % 2])
        axj.plot(smp.t, smp.tau_m[:, j], lw=0.9, label="tau_m (inverse dynamics)")
        full, used = lim.tau_m_max[j], lim.tau_m_max[j] * lim.torque_margin
        axj.axhline(full, color="r", ls="--", lw=0.8, label=f"motor limit ±{full:.4g} N m")
        axj.axhline(-full, color="r", ls="--", lw=0.8)
        if lim.torque_margin < 1.0:
            axj.axhline(used, color="tab:orange", ls=":", lw=0.9, label=f"{100 * lim.torque_margin:g} % of it (retimed within)")
            axj.axhline(-used, color="tab:orange", ls=":", lw=0.9)
        axj.set_ylabel(f"{names[j]}\ntau_m [N m]")
        axj.set_xlim(0.0, smp.t[-1])
        axj.grid(True, alpha=0.3)
        axj.legend(fontsize=6, loc="upper right")
        if j >= n - 2:
            axj.set_xlabel("t [s]")
    for c, what in enumerate(extra):
        axe = fig.add_subplot(grid[rows - 1, c])
        bound = lim.velocity if what == "velocity" else lim.acceleration
        values = smp.qd if what == "velocity" else smp.qdd
        for j in np.flatnonzero(np.isfinite(bound)):
            axe.plot(smp.t, np.abs(values[:, j]) / bound[j], lw=0.9, label=names[j])
        axe.axhline(1.0, color="r", ls="--", lw=0.8)
        axe.set_ylim(0.0, 1.1)
        axe.set_ylabel(f"|{'qd' if what == 'velocity' else 'qdd'}| / {what} limit")
        axe.set_xlabel("t [s]")
        axe.grid(True, alpha=0.3)
        axe.legend(fontsize=6, loc="upper right", ncol=2)
    fig.suptitle(title or f"{robot.name}: time-optimal along the path, within the limits")
    return fig
