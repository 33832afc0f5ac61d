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


def bode_plot(responses: Sequence[BodeResponse], title: str = "") -> Figure:
    """Magnitude and phase of loop transfers with their margins marked.

    Gain crossover: a vertical dotted line and, on the phase plot, a bar from -180 deg
    to the phase (the phase margin). Phase crossover: a bar on the magnitude plot from
    the magnitude to 0 dB (the gain margin). Discrete loops are dashed and end at pi / dt.
    """
    fig = Figure(figsize=(7.5, 6.0), layout="constrained")
    ax_m, ax_p = fig.subplots(2, 1, sharex=True)
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
        if math.isfinite(m.w_gc):
            ax_m.axvline(m.w_gc, color=color, ls=":", lw=0.8)
            ax_p.axvline(m.w_gc, color=color, ls=":", lw=0.8)
            ph = float(np.interp(math.log(m.w_gc), np.log(r.omega), phase))
            ax_p.plot([m.w_gc, m.w_gc], [ph - m.pm, ph], color=color, lw=2.5)  # from the -180 deg line (mod 360)
        if math.isfinite(m.gm) and math.isfinite(m.w_pc):
            ax_m.plot([m.w_pc, m.w_pc], [-m.gm_db, 0.0], color=color, lw=2.5)
            ax_m.axvline(m.w_pc, color=color, ls=":", lw=0.8)
        if r.dt is not None:
            ax_m.axvline(math.pi / r.dt, color="0.5", ls="-.", lw=0.8)
    ax_m.axhline(0.0, color="k", lw=0.6)
    ax_p.axhline(-180.0, color="k", lw=0.6)
    ax_m.set_ylabel("|L| [dB]")
    ax_p.set_ylabel("phase L [deg]")
    ax_p.set_xlabel("frequency [rad/s]")
    ax_m.grid(True, which="both", alpha=0.3)
    ax_p.grid(True, which="both", alpha=0.3)
    ax_m.legend(fontsize=7, loc="lower left")
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
