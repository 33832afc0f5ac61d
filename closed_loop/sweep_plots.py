"""Drawing a sweep: the distribution of the worst error, error against each parameter, a 2-D grid's map.

Every function takes the sweep's table (a pandas DataFrame of
:func:`closed_loop.sweep.assemble`) and returns a :class:`matplotlib.figure.Figure`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from .plots import tracking_error_plot
from .sweep_spec import QUANTITIES, SweepSpec

__all__ = ["error_histogram", "error_scatter", "grid_heatmap", "sweep_figures"]


def _label(q: str) -> str:
    unit = QUANTITIES.get(q, ("",))[0]
    return f"{q} [{unit}]" if unit else q


def error_histogram(table: Any, unit: str, bound: float | None = None, title: str = "") -> Figure:
    """Histogram of ``max_error`` over the cases (diverged cases counted in the title), the bound dashed."""
    err = table["max_error"].to_numpy()
    finite = err[np.isfinite(err)]
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.subplots()
    ax.hist(finite, bins=min(60, max(10, int(np.sqrt(finite.size)))), color="tab:blue", alpha=0.85)
    if bound is not None:
        k = int(np.sum(~(err <= bound)))
        ax.axvline(bound, color="r", ls="--", lw=1.2, label=f"bound {bound:g}: exceeded in {k}/{err.size} cases")
        ax.legend(fontsize=8)
    ax.set_xlabel(f"max tracking error, worst joint [{unit}]")
    ax.set_ylabel("cases")
    ax.grid(True, alpha=0.3)
    diverged = int(np.sum(~np.isfinite(err)))
    ax.set_title(title or f"{err.size} cases" + (f", {diverged} diverged" if diverged else ""))
    return fig


def error_scatter(table: Any, quantities: tuple[str, ...], unit: str, bound: float | None = None) -> Figure:
    """``max_error`` against each varied quantity, one panel each (log scale when it spans a decade)."""
    d = len(quantities)
    cols = min(d, 3)
    rows = -(-d // cols)
    fig = Figure(figsize=(4.2 * cols, 3.4 * rows), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    err = table["max_error"].to_numpy()
    finite = err[np.isfinite(err)]
    log = finite.size > 0 and finite.min() > 0 and finite.max() / finite.min() > 10
    for ax, q in zip(axes, quantities):
        ax.scatter(table[q], err, s=6, alpha=0.5, lw=0)
        if bound is not None:
            ax.axhline(bound, color="r", ls="--", lw=1.0)
        ax.set_xlabel(_label(q))
        ax.set_ylabel(f"max error [{unit}]")
        if log:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
    for ax in axes[d:]:
        ax.set_visible(False)
    fig.suptitle("worst-joint max tracking error against each varied quantity")
    return fig


def grid_heatmap(table: Any, quantities: tuple[str, str], unit: str) -> Figure:
    """``max_error`` over a 2-D grid as a colour map (cells at the grid values)."""
    qx, qy = quantities
    xs, ys = np.unique(table[qx]), np.unique(table[qy])
    Z = np.full((ys.size, xs.size), np.nan)
    ix = np.searchsorted(xs, table[qx].to_numpy())
    iy = np.searchsorted(ys, table[qy].to_numpy())
    Z[iy, ix] = table["max_error"].to_numpy()
    fig = Figure(figsize=(6.5, 5.0), layout="constrained")
    ax = fig.subplots()
    mesh = ax.pcolormesh(xs, ys, np.ma.masked_invalid(Z), shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label=f"max error, worst joint [{unit}]")
    ax.set_xlabel(_label(qx))
    ax.set_ylabel(_label(qy))
    ax.set_title("max tracking error over the grid (white: diverged)")
    return fig


def sweep_figures(spec: SweepSpec, table: Any, summary: dict[str, Any], worst: Any = None) -> dict[str, Figure]:
    """The figures of a sweep by file stem: ``hist_max_error``, ``scatter_max_error``, ``heatmap_max_error``
    (a 2-D grid only) and ``worst_case_tracking_error`` (when the worst case's samples are given)."""
    unit = summary["max_error_unit"]
    bound = spec.bound
    figs = {"hist_max_error": error_histogram(table, unit, bound),
            "scatter_max_error": error_scatter(table, spec.quantities, unit, bound)}
    if spec.method == "grid" and len(spec.quantities) == 2:
        figs["heatmap_max_error"] = grid_heatmap(table, spec.quantities, unit)  # type: ignore[arg-type]
    if worst is not None:
        w = summary["worst_case"]
        params = ", ".join(f"{k} = {v:.4g}" for k, v in w["parameters"].items())
        figs["worst_case_tracking_error"] = tracking_error_plot(worst, f"worst case {w['case']}: {params}")
    return figs
