"""Drawing: each function takes result objects, draws them and returns the matplotlib Figure.

Figures are built with :class:`matplotlib.figure.Figure` directly (no pyplot
state, no GUI backend needed); save them with ``fig.savefig(path)``.
Nothing here computes a response: see :mod:`control_design.responses`. The
closed-loop figures are :mod:`closed_loop.plots`.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from .responses import BodeResponse, StepResponse

__all__ = ["bode_plot", "step_plot"]


def _margin_arrow(ax, w: float, y0: float, y1: float, color: str, text: str, right: bool) -> None:
    """A double-headed arrow at frequency ``w`` from ``y0`` to ``y1``, labelled ``text`` beside it."""
    ax.annotate("", xy=(w, y1), xytext=(w, y0), arrowprops={"arrowstyle": "<->", "color": color, "lw": 1.2,
                                                          "shrinkA": 0, "shrinkB": 0})
    ax.annotate(text, xy=(w, 0.5 * (y0 + y1)), xytext=(6 if right else -6, 0), textcoords="offset points",
                ha="left" if right else "right", va="center", fontsize=8, color=color,
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8})


def bode_plot(responses: Sequence[BodeResponse], title: str = "") -> Figure:
    """Magnitude and phase of loop transfers with their margins marked.

    Gain crossover: a vertical dotted line and, on the phase plot, an arrow from -180 deg
    to the phase labelled "PM"; phase crossover: an arrow on the magnitude plot from the
    magnitude to 0 dB labelled "GM". Discrete loops are dashed and end at the Nyquist
    frequency pi / dt (a grey dash-dot line). Every mark is in the legend below the axes.
    """
    fig = Figure(figsize=(7.5, 6.4), layout="constrained")
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
    nyquist_labelled = False
    for k, r in enumerate(responses):
        color = f"C{k % 10}"
        style = "--" if r.dt is not None else "-"
        kind = f"discrete, {1.0 / r.dt:g} Hz" if r.dt is not None else "continuous"
        m = r.margins
        label = (f"{r.label} ({kind}): PM {m.pm:.1f} deg at {m.w_gc:.3g} rad/s, "
                 + (f"GM {m.gm_db:.1f} dB at {m.w_pc:.3g} rad/s" if math.isfinite(m.gm) else "GM inf"))
        phase = r.phase_deg
        ax_m.semilogx(r.omega, r.mag_db, style, color=color, label=label)
        ax_p.semilogx(r.omega, phase, style, color=color)
        right = k % 2 == 1  # two responses at one crossover: labels either side of the arrow
        if math.isfinite(m.w_gc):
            ax_m.axvline(m.w_gc, color=color, ls=":", lw=0.8)
            ax_p.axvline(m.w_gc, color=color, ls=":", lw=0.8)
            ph = float(np.interp(math.log(m.w_gc), np.log(r.omega), phase))
            _margin_arrow(ax_p, m.w_gc, ph - m.pm, ph, color, f"PM {m.pm:.1f} deg", right)  # from -180 deg (mod 360)
        if math.isfinite(m.gm) and math.isfinite(m.w_pc):
            ax_m.axvline(m.w_pc, color=color, ls=":", lw=0.8)
            _margin_arrow(ax_m, m.w_pc, -m.gm_db, 0.0, color, f"GM {m.gm_db:.1f} dB", right)
        if r.dt is not None:
            ax_m.axvline(math.pi / r.dt, color="0.5", ls="-.", lw=0.8,
                         label=None if nyquist_labelled else "Nyquist frequency pi/dt")
            ax_p.axvline(math.pi / r.dt, color="0.5", ls="-.", lw=0.8)
            nyquist_labelled = True
    ax_m.plot([], [], ls=":", color="0.3", lw=0.8, label="gain (PM) and phase (GM) crossovers")
    ax_m.axhline(0.0, color="k", lw=0.6)
    ax_p.axhline(-180.0, color="k", lw=0.6)
    ax_m.set_ylabel("|L| [dB]")
    ax_p.set_ylabel("phase L [deg]")
    ax_p.set_xlabel("frequency [rad/s]")
    ax_m.grid(True, which="both", alpha=0.3)
    ax_p.grid(True, which="both", alpha=0.3)
    fig.legend(*ax_m.get_legend_handles_labels(), loc="outside lower center", fontsize=7, ncols=1, frameon=False)
    fig.suptitle(title or "Loop transfer L = C P with margins")
    return fig


def step_plot(responses: Sequence[StepResponse], title: str = "") -> Figure:
    """Unit-step responses: motor angle (top) and motor torque per motor rad of step (bottom)."""
    fig = Figure(figsize=(7.5, 6.0), layout="constrained")
    ax_y, ax_u = fig.subplots(2, 1, sharex=True)
    for k, r in enumerate(responses):
        color = f"C{k % 10}"
        kind = f"discrete {1.0 / r.dt:g} Hz" if r.dt is not None else "continuous"
        label = (f"{r.label} ({kind}): rise {1e3 * r.rise_time:.1f} ms, overshoot {r.overshoot:.1f} %, "
                 f"settling {1e3 * r.settling_time:.0f} ms")
        draw = ax_y.step if r.dt is not None else ax_y.plot
        kwargs = {"where": "post"} if r.dt is not None else {}
        draw(r.t, r.theta_m, color=color, ls="--" if r.dt is not None else "-", label=label, **kwargs)
        (ax_u.step if r.dt is not None else ax_u.plot)(r.t, r.tau_m, color=color, ls="--" if r.dt is not None else "-", **kwargs)
    ax_y.axhline(1.0, color="k", lw=0.6)
    ax_y.set_ylabel("theta_m [rad per rad of step]")
    ax_u.set_ylabel("tau_m [N m per rad of step]")
    ax_u.set_xlabel("t [s]")
    ax_y.grid(True, alpha=0.3)
    ax_u.grid(True, alpha=0.3)
    ax_y.legend(fontsize=7, loc="lower right")
    fig.suptitle(title or "Step responses of the motor-angle reference")
    return fig
