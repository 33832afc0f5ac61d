"""Drawing closed-loop runs: each function takes a :class:`~closed_loop.result.TrackingResult` and returns a Figure.

Figures are built with :class:`matplotlib.figure.Figure` directly (no pyplot
state, no GUI backend needed); save them with ``fig.savefig(path)``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from .result import SATURATION_MARGIN, TrackingResult

__all__ = ["MIN_SPAN", "tracking_error_plot", "torque_plot", "joint_plot"]


def _per_joint_axes(result: TrackingResult, title: str) -> tuple[Figure, np.ndarray]:
    n = result.q.shape[1]
    fig = Figure(figsize=(8.0, 1.9 * n + 1.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True))
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return fig, axes


#: Smallest y span of a joint-position axis (rad or m): a joint that stays put draws as a flat line,
#: not as its 1e-9 rad numerical noise blown up to the full axis.
MIN_SPAN = {"rad": 0.1, "m": 0.01}


def _min_span(ax, span: float) -> None:
    lo, hi = ax.get_ylim()
    if hi - lo < span:
        mid = 0.5 * (lo + hi)
        ax.set_ylim(mid - 0.5 * span, mid + 0.5 * span)


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


def torque_plot(result: TrackingResult, title: str = "", limit_sources: Sequence[str] | None = None) -> Figure:
    """Motor torque per joint (zero-order hold), its limits dashed and the periods at the limit shaded.

    ``limit_sources``: per motor, where the limit comes from (e.g. "default rule"), shown in the legend.
    """
    fig, axes = _per_joint_axes(result, title or f"{result.robot}: motor torques ({result.controller})")
    met = result.metrics()
    for j, ax in enumerate(axes):
        ax.step(result.t, result.tau_m[:, j], where="post", lw=0.9, label="tau_m")
        if result.tau_m_max is not None:
            limit = result.tau_m_max[j]
            source = f" ({limit_sources[j]})" if limit_sources is not None else ""
            ax.axhline(limit, color="r", ls="--", lw=0.8, label=f"limit ±{limit:.4g} N m{source}")
            ax.axhline(-limit, color="r", ls="--", lw=0.8)
            if met.saturated_fraction[j] > 0:
                at_limit = np.abs(result.tau_m[:, j]) >= limit * SATURATION_MARGIN
                ax.fill_between(result.t, -limit, limit, where=at_limit, step="post", color="r", alpha=0.12, lw=0,
                                label=f"at the limit {100 * met.saturated_fraction[j]:.1f} % of the time")
        ax.set_ylabel(f"{result.joints[j]}\ntau_m [N m]")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)  # clear of the limit lines
    return fig


def joint_plot(result: TrackingResult, title: str = "") -> Figure:
    """Joint positions: reference (dashed) and plant (solid)."""
    fig, axes = _per_joint_axes(result, title or f"{result.robot}: joint positions ({result.controller})")
    for j, ax in enumerate(axes):
        ax.plot(result.t, result.q_ref[:, j], "k--", lw=1.0, label="reference")
        ax.plot(result.t, result.q[:, j], lw=1.0, label="plant")
        _min_span(ax, MIN_SPAN[result.units[j]])
        ax.set_ylabel(f"{result.joints[j]} [{result.units[j]}]")
        ax.legend(fontsize=7, loc="upper right")
    return fig
