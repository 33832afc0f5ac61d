"""Drawing closed-loop runs: each function takes a :class:`~closed_loop.result.TrackingResult` and returns a Figure.

Figures are built with :class:`matplotlib.figure.Figure` directly (no pyplot
state, no GUI backend needed); save them with ``fig.savefig(path)``.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from .result import TrackingResult

__all__ = ["tracking_error_plot", "torque_plot", "joint_plot"]


def _per_joint_axes(result: TrackingResult, title: str) -> tuple[Figure, np.ndarray]:
    n = result.q.shape[1]
    fig = Figure(figsize=(8.0, 1.9 * n + 1.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True))
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return fig, axes


def tracking_error_plot(result: TrackingResult, title: str = "") -> Figure:
    """Tracking error ``q_ref - q`` per joint, with its RMS and max in the legend."""
    met = result.metrics()
    fig, axes = _per_joint_axes(result, title or f"{result.robot}: tracking error ({result.controller}, {result.rate_hz:g} Hz)")
    for j, ax in enumerate(axes):
        ax.plot(result.t, result.error[:, j], lw=0.9,
                label=f"RMS {met.rms_error[j]:.3g}, max {met.max_error[j]:.3g} {result.units[j]}")
        ax.set_ylabel(f"{result.joints[j]} [{result.units[j]}]")
        ax.legend(fontsize=7, loc="upper right")
    return fig


def torque_plot(result: TrackingResult, title: str = "") -> Figure:
    """Motor torque per joint (zero-order hold), with the torque limits dashed."""
    fig, axes = _per_joint_axes(result, title or f"{result.robot}: motor torques ({result.controller})")
    for j, ax in enumerate(axes):
        ax.step(result.t, result.tau_m[:, j], where="post", lw=0.9)
        if result.tau_m_max is not None:
            for s in (-1.0, 1.0):
                ax.axhline(s * result.tau_m_max[j], color="r", ls="--", lw=0.8)
        ax.set_ylabel(f"{result.joints[j]} tau_m [N m]")
    return fig


def joint_plot(result: TrackingResult, title: str = "") -> Figure:
    """Joint positions: reference (dashed) and plant (solid)."""
    fig, axes = _per_joint_axes(result, title or f"{result.robot}: joint positions ({result.controller})")
    for j, ax in enumerate(axes):
        ax.plot(result.t, result.q_ref[:, j], "k--", lw=1.0, label="reference")
        ax.plot(result.t, result.q[:, j], lw=1.0, label="plant")
        ax.set_ylabel(f"{result.joints[j]} [{result.units[j]}]")
        ax.legend(fontsize=7, loc="upper right")
    return fig
