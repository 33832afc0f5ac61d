"""Draw the arm as a stick figure and animate it along a joint trajectory (GIF).

The figure shows every link frame origin from ``Robot.fkine_all``, the joint
axes z_{i-1} as short segments, and the tool path traced so far.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from model.files import atomic_path
from model.robot import Robot
from model.errors import InputError

__all__ = ["plot_arm", "animate_arm"]


def _frames(robot: Robot, Q: np.ndarray) -> np.ndarray:
    """(N, n+1, 4, 4) link frames of every configuration in Q (N, n)."""
    return np.stack([robot.fkine_all(q) for q in Q])


def _limits(points: np.ndarray) -> tuple[np.ndarray, float]:
    centre = 0.5 * (points.max(axis=0) + points.min(axis=0))
    half = 0.55 * float(np.max(points.max(axis=0) - points.min(axis=0)))
    return centre, max(half, 0.1)


def _setup_axes(ax, centre: np.ndarray, half: float, title: str) -> None:
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    for axis, name in ((ax.xaxis, "x"), (ax.yaxis, "y"), (ax.zaxis, "z")):
        axis.set_major_locator(MaxNLocator(nbins=4))  # few ticks: the 3-D projection crowds them
        axis.set_tick_params(labelsize=8, pad=1)
        axis.set_label_text(f"{name} [m]", fontsize=9)
        axis.labelpad = 2
    ax.set_title(title)


def _draw_base(ax, z_floor: float) -> None:
    """A grey pedestal from the floor of the scene up to the base origin, and the base marked."""
    ax.plot([0.0, 0.0], [0.0, 0.0], [min(z_floor, 0.0), 0.0], "-", lw=6, color="0.6", solid_capstyle="butt")
    ax.plot([0.0], [0.0], [0.0], "ks", ms=7)


def _figure(size: float) -> Figure:
    """A Figure drawn by the Agg canvas: no pyplot state, no GUI backend."""
    fig = Figure(figsize=(size, size))
    FigureCanvasAgg(fig)
    return fig


def plot_arm(robot: Robot, q: np.ndarray, ax=None) -> Figure:
    """Draw the arm at configuration ``q`` (rad / m) in 3-D; returns the figure."""
    frames = robot.fkine_all(q)
    fig = ax.figure if ax is not None else _figure(5.0)
    ax = ax if ax is not None else fig.add_subplot(projection="3d")
    p = frames[:, 0:3, 3]
    centre, half = _limits(np.vstack([p, np.zeros((1, 3))]))
    _setup_axes(ax, centre, half, f"{robot.name} at q = {np.round(q, 3).tolist()}")
    _draw_base(ax, centre[2] - half)
    ax.plot(p[:, 0], p[:, 1], p[:, 2], "o-", lw=3, color="tab:blue")
    ax.plot(*p[-1], "s", color="tab:red")
    return fig


def animate_arm(
    robot: Robot,
    t: np.ndarray,
    Q: np.ndarray,
    path: str | Path,
    *,
    fps: int = 15,
    max_frames: int = 150,
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Write a GIF of the arm following the joint trajectory ``Q`` (N, n) sampled at times ``t`` (s).

    At most ``max_frames`` evenly spaced samples are drawn; ``progress(k, total)`` is called per frame.
    """
    Q = np.asarray(Q, dtype=float)
    t = np.asarray(t, dtype=float)
    if Q.ndim != 2 or Q.shape[1] != robot.n or t.shape != (Q.shape[0],):
        raise InputError(f"Q, t: expected shapes (N, {robot.n}) and (N,), got {Q.shape} and {t.shape}")
    idx = np.unique(np.linspace(0, len(t) - 1, min(max_frames, len(t))).round().astype(int))
    frames = _frames(robot, Q[idx])
    origins = frames[:, :, 0:3, 3]
    tool = origins[:, -1, :]
    centre, half = _limits(np.vstack([origins.reshape(-1, 3), np.zeros((1, 3))]))

    fig = _figure(5.5)
    ax = fig.add_subplot(projection="3d")
    fig.subplots_adjust(left=0.02, right=0.93, bottom=0.04, top=0.9)  # the 3-D box fills the frame
    _setup_axes(ax, centre, half, robot.name)
    _draw_base(ax, centre[2] - half)
    ax.view_init(elev=25, azim=-60)
    (arm_line,) = ax.plot([], [], [], "o-", lw=3, color="tab:blue")
    (trace,) = ax.plot([], [], [], "-", lw=1, color="tab:red")
    label = ax.text2D(0.02, 0.95, "", transform=ax.transAxes)

    def draw(k: int):
        p = origins[k]
        arm_line.set_data_3d(p[:, 0], p[:, 1], p[:, 2])
        trace.set_data_3d(tool[: k + 1, 0], tool[: k + 1, 1], tool[: k + 1, 2])
        label.set_text(f"t = {t[idx[k]]:5.2f} s")
        if progress is not None:
            progress(k + 1, len(idx))
        return arm_line, trace, label

    anim = FuncAnimation(fig, draw, frames=len(idx), blit=False)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        anim.save(tmp, writer=PillowWriter(fps=fps))
    return path
