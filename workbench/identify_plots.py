"""Drawing an identification: measured against predicted torques on the held-out data, the residual spectrum,
and an excitation trajectory against its limits.

Each function returns a :class:`matplotlib.figure.Figure` (no pyplot state); save it with
:func:`workbench.outputs.save_figure`.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.signal
from matplotlib.figure import Figure

from model.identification import ExcitationResult, Identification

__all__ = ["excitation_plot", "holdout_torque_plot", "residual_spectrum_plot"]


def _axes(n: int, title: str, width: float = 9.0) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=(width, 1.7 * n + 1.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True))
    fig.suptitle(title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    return fig, axes


def _unit(revolute: bool) -> str:
    return "N m" if revolute else "N"


def holdout_torque_plot(result: Identification, joints: Sequence[str], revolute: Sequence[bool], title: str = "") -> Figure:
    """Per joint, the held-out torque (filtered, as fitted) against the torque the chosen fit and WLS predict;
    the samples at rest (left out of the errors) are shaded."""
    part = result.holdout if len(result.holdout) else result.fit
    name = "holdout" if len(result.holdout) else "fit"
    pred = result.predicted(name)
    wls = result.predicted(name, "wls")
    rest = ~result.regressions[name].moving.reshape(-1, len(joints))
    err = result.errors[result.chosen]
    rms = err.rms_holdout if name == "holdout" else err.rms_fit
    fig, axes = _axes(len(joints), title or f"measured and predicted torque on the {'held-out' if name == 'holdout' else 'fit'} data")
    for j, ax in enumerate(axes):
        ax.plot(part.t, part.tau[:, j], color="k", lw=1.2, label="measured (filtered)")
        ax.plot(part.t, pred[:, j], color="C1", lw=0.9, label=f"{result.chosen} fit: RMS error {rms[j]:.3g} {_unit(revolute[j])}")
        if result.chosen != "wls":
            ax.plot(part.t, wls[:, j], color="C0", lw=0.8, ls="--", label="WLS")
        if rest[:, j].any():
            lo, hi = ax.get_ylim()
            ax.fill_between(part.t, lo, hi, where=rest[:, j], color="0.5", alpha=0.15, lw=0, label="at rest (left out)")
            ax.set_ylim(lo, hi)
        ax.set_ylabel(f"{joints[j]}\n[{_unit(revolute[j])}]")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    axes[-1].set_xlabel("t [s]")
    return fig


def residual_spectrum_plot(result: Identification, joints: Sequence[str], revolute: Sequence[bool], title: str = "") -> Figure:
    """Per joint, the power spectrum of the chosen fit's torque residual over every sample (fit and held out),
    with the filter's cut-off: a flat spectrum is noise, peaks are dynamics the model lacks."""
    parts = [p for p in ("fit", "holdout") if len(getattr(result, p))]
    t = np.concatenate([getattr(result, p).t for p in parts])
    tau = np.concatenate([getattr(result, p).tau for p in parts])
    pred = np.concatenate([result.predicted(p) for p in parts])
    rate = 1.0 / float(np.median(np.diff(t)))
    fig, axes = _axes(len(joints), title or f"residual spectrum of the {result.chosen} fit")
    cutoff = result.preprocessing.cutoff_hz if result.preprocessing is not None else None
    for j, ax in enumerate(axes):
        f, P = scipy.signal.welch(tau[:, j] - pred[:, j], fs=rate, nperseg=min(t.size, max(32, t.size // 4)))
        ax.semilogy(f[1:], np.maximum(P[1:], 1e-300), lw=0.9)
        if cutoff is not None and cutoff < 0.5 * rate:
            ax.axvline(cutoff, color="r", ls="--", lw=0.8, label=f"cut-off {cutoff:.3g} Hz")
            ax.legend(fontsize=7, loc="upper right")
        ax.set_ylabel(f"{joints[j]}\n[{_unit(revolute[j])}$^2$/Hz]")
    axes[-1].set_xlabel("frequency [Hz]")
    return fig


def excitation_plot(result: ExcitationResult, joints: Sequence[str], revolute: Sequence[bool], title: str = "") -> Figure:
    """One period of an excitation: per joint its position, speed and acceleration against their limits."""
    traj, lim = result.trajectory, result.limits
    t = np.linspace(0.0, traj.period, 2001)
    q, qd, qdd = traj.evaluate(t)
    n = len(joints)
    fig = Figure(figsize=(12.0, 1.6 * n + 1.0), layout="constrained")
    axes = np.atleast_2d(fig.subplots(n, 3, sharex=True))
    fig.suptitle(title or f"excitation: {traj.harmonics} harmonics, period {traj.period:g} s, "
                          f"cond {result.condition_number:.4g} (from {result.initial_condition_number:.4g})")
    for j in range(n):
        u = "rad" if revolute[j] else "m"
        for k, (values, lo, hi, label) in enumerate(((q[:, j], lim.q_min[j], lim.q_max[j], f"q [{u}]"),
                                                     (qd[:, j], -lim.qd_max[j], lim.qd_max[j], f"qd [{u}/s]"),
                                                     (qdd[:, j], -lim.qdd_max[j], lim.qdd_max[j], f"qdd [{u}/s$^2$]"))):
            ax = axes[j, k]
            ax.plot(t, values, lw=0.9)
            # a limit far beyond the motion (1e308: none in effect) would squash the curve to a line
            reach = 10.0 * max(float(np.abs(values).max()), 1e-12)
            for bound in (lo, hi):
                if abs(bound) <= reach:
                    ax.axhline(bound, color="r", ls="--", lw=0.7)
            ax.grid(True, alpha=0.3)
            ax.set_ylabel(f"{joints[j]}\n{label}" if k == 0 else label)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    return fig
