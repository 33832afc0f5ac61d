"""The workspace figure (the seed's Figure 14), its summary lines and its report section.

:func:`workspace_figure` draws a :class:`model.workspace.ReachableWorkspace`:
the sampled tool points in 3-D with the arm at rest, the top view (x-y) and
the side view (r-z), each with its envelope (:mod:`model.workspace`). No
pyplot: a :class:`matplotlib.figure.Figure` is returned.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.figure import Figure

    from model.robot import Robot
    from model.workspace import ReachableWorkspace, Section

    from .report import Report

__all__ = ["workspace_figure", "workspace_summary", "workspace_section", "WORKSPACE_PNG"]

#: File name of the figure in the demo's output folder.
WORKSPACE_PNG = "workspace.png"
#: Samples drawn as dots (all of them enter the envelope).
_DOTS = 6000


def _dots(points: np.ndarray, seed: int) -> np.ndarray:
    if points.shape[0] <= _DOTS:
        return points
    return points[np.random.default_rng(seed).choice(points.shape[0], _DOTS, replace=False)]


def _section(ax, sec: "Section", title: str, seed: int) -> None:
    dots = _dots(sec.points, seed)
    ax.scatter(dots[:, 0], dots[:, 1], s=1.5, color="#4c72b0", alpha=0.35, linewidths=0, label="tool point samples")
    cu, cv = sec.centres()
    ax.contour(cu, cv, sec.region.T.astype(float), levels=[0.5], colors="#c44e52", linewidths=1.6)
    ax.plot([], [], color="#c44e52", label=f"envelope (grid {sec.cell * 1000:.0f} mm)")
    ax.set_xlabel(f"{sec.axes[0]} [m]")
    ax.set_ylabel(f"{sec.axes[1]} [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper right", fontsize=7, markerscale=6)


def workspace_figure(ws: "ReachableWorkspace", robot: "Robot") -> "Figure":
    """The workspace in three panels: 3-D samples with the arm at rest, top view x-y, side view r-z."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    fig = Figure(figsize=(13.5, 4.6), layout="constrained")
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    dots = _dots(ws.points, ws.seed)
    ax3.scatter(dots[:, 0], dots[:, 1], dots[:, 2], s=2.5, c=dots[:, 2], cmap="viridis", alpha=0.6, linewidths=0)
    q0 = robot.q_rest
    origins = np.vstack([robot.fkine_all(q0)[:, :3, 3], robot.fkine(q0)[None, :3, 3]])
    ax3.plot(origins[:, 0], origins[:, 1], origins[:, 2], "-o", color="k", lw=2.5, ms=3.5, label="arm at rest")
    ax3.set_xlabel("x [m]")
    ax3.set_ylabel("y [m]", labelpad=8)
    ax3.zaxis.set_major_locator(MaxNLocator(4))  # z label left out: constrained layout would put it on the next panel
    lo, hi = ws.points.min(axis=0), ws.points.max(axis=0)
    span = float(max(hi - lo))
    if hi[2] - lo[2] < 0.05 * span:  # a planar arm: give the flat cloud a visible height, not overlapping ticks
        zc = 0.5 * (hi[2] + lo[2])
        ax3.set_zlim(zc - 0.1 * span, zc + 0.1 * span)
        lo[2], hi[2] = zc - 0.1 * span, zc + 0.1 * span
    ax3.set_box_aspect(np.maximum(hi - lo, 0.05 * span))
    ax3.set_title(f"{ws.robot}: {ws.points.shape[0]} samples of q within the limits\n(x, y, z in m)", fontsize=10)
    ax3.legend(loc="upper left", fontsize=7)
    _section(fig.add_subplot(1, 3, 2), ws.top, "top view x-y (all heights)", ws.seed)
    side = "meridian section r-z" if ws.axisymmetric else "side view r-z (projection)"
    _section(fig.add_subplot(1, 3, 3), ws.side, f"{side}, r from the base z axis", ws.seed)
    return fig


def workspace_summary(ws: "ReachableWorkspace") -> list[str]:
    """Lines of numbers: samples, the radius and height ranges, whether the top view has a hole at the base axis."""
    r_lo, r_hi = ws.radius_range
    z_lo, z_hi = ws.height_range
    hole = not ws.top.contains(ws.base[0], ws.base[1])
    return [
        f"{ws.points.shape[0]} samples of q, uniform within the joint limits (seed {ws.seed})",
        f"distance from the base z axis: {r_lo:.4g} to {r_hi:.4g} m",
        f"height z: {z_lo:.4g} to {z_hi:.4g} m",
        f"top view: {'a hole' if hole else 'no hole'} around the base axis; envelope grid {ws.top.cell * 1000:.0f} mm",
        f"side view: {'meridian section (first joint turns a full circle about z)' if ws.axisymmetric else 'r-z projection'}",
    ]


def workspace_section(report: "Report", out: Path, robot: "Robot", *, plots: bool = True,
                      samples: int = 200_000) -> list[Path]:
    """The report's "Workspace" section (numbers, and the figure written into ``out`` unless ``plots`` is False).

    The shape of every section of :mod:`workbench.sections`; returns the files it wrote.
    """
    from model.workspace import reachable_workspace

    from .outputs import save_figure

    ws = reachable_workspace(robot, samples=samples)
    report.heading("Workspace")
    report.text("Reachable workspace of the tool point: joint vectors sampled uniformly within the limits, mapped "
                "by fkine; the envelope of each view is the boundary of the sampled cells after a morphological "
                "closing (holes and concavities wider than the closing disc are kept, unlike a convex hull).")
    report.code("\n".join(workspace_summary(ws)))
    if not plots:
        return []
    path = save_figure(workspace_figure(ws, robot), out / WORKSPACE_PNG)
    report.image(path.name, f"{robot.name}: reachable workspace (3-D, top view, side view)")
    return [path]
