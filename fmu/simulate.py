"""Thin helpers around FMPy: input tables, Co-Simulation and Model Exchange runs.

Inputs are piecewise constant (a command updated every ``hold`` seconds, as a
digital controller would send it): :func:`step_input` writes them as FMPy's
step table (two rows at every switching time), so FMPy applies the value
after the switch in Co-Simulation and raises a time event at every switch in
Model Exchange. Results come back as a :class:`SimulationResult` of arrays.
Every FMU passes :func:`fmu.archive.check_fmu_archive` before FMPy opens it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from fmpy import read_model_description, simulate_fmu

from .archive import check_fmu_archive

__all__ = ["SimulationResult", "step_input", "simulate_cs", "simulate_me", "variable_names"]


@dataclass(frozen=True)
class SimulationResult:
    """Samples of an FMU run: ``t`` (N,) and one (N,) array per variable name."""

    t: np.ndarray
    values: dict[str, np.ndarray]
    interface: str

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]

    def stack(self, names: Sequence[str]) -> np.ndarray:
        """(N, len(names)) array of the named variables."""
        return np.column_stack([self.values[n] for n in names])


def variable_names(fmu_path: str | os.PathLike[str], causality: str) -> list[str]:
    """Names of the FMU's variables of one causality, in value-reference order."""
    check_fmu_archive(fmu_path)
    md = read_model_description(str(fmu_path))
    return [v.name for v in sorted(md.modelVariables, key=lambda v: v.valueReference) if v.causality == causality]


def step_input(names: Sequence[str], t_switch: np.ndarray, values: np.ndarray) -> np.ndarray:
    """FMPy input table of a piecewise-constant signal.

    ``values[i]`` holds on ``[t_switch[i], t_switch[i + 1])``; the last one
    holds to the end. ``t_switch`` (K,) increasing, ``values`` (K, len(names)).
    """
    t_switch = np.asarray(t_switch, dtype=float)
    values = np.asarray(values, dtype=float)
    if values.shape != (t_switch.size, len(names)):
        raise ValueError(f"values: expected shape ({t_switch.size}, {len(names)}), got {values.shape}")
    if np.any(np.diff(t_switch) <= 0):
        raise ValueError("t_switch: expected strictly increasing switching times")
    rows_t = [t_switch[0]]
    rows_v = [values[0]]
    for i in range(1, t_switch.size):
        rows_t += [t_switch[i], t_switch[i]]
        rows_v += [values[i - 1], values[i]]
    table = np.zeros(len(rows_t), dtype=[("time", np.float64)] + [(n, np.float64) for n in names])
    table["time"] = rows_t
    stacked = np.array(rows_v)
    for j, n in enumerate(names):
        table[n] = stacked[:, j]
    return table


def _result(raw: np.ndarray, names: Sequence[str], interface: str) -> SimulationResult:
    return SimulationResult(np.array(raw["time"]), {n: np.array(raw[n]) for n in names}, interface)


def simulate_cs(fmu_path: str | os.PathLike[str], stop_time: float, step: float, *,
                inputs: np.ndarray | None = None, outputs: Sequence[str] | None = None,
                start_values: dict[str, float] | None = None) -> SimulationResult:
    """Co-Simulation by FMPy with communication step ``step`` (s), outputs every step."""
    check_fmu_archive(fmu_path)
    names = list(outputs) if outputs is not None else variable_names(fmu_path, "output")
    raw = simulate_fmu(str(fmu_path), fmi_type="CoSimulation", stop_time=stop_time, output_interval=step,
                       input=inputs, output=names, start_values=start_values or {})
    return _result(raw, names, "CoSimulation")


def simulate_me(fmu_path: str | os.PathLike[str], stop_time: float, output_interval: float, *,
                inputs: np.ndarray | None = None, outputs: Sequence[str] | None = None,
                start_values: dict[str, float] | None = None, relative_tolerance: float = 1e-8) -> SimulationResult:
    """Model Exchange by FMPy with its CVode solver (BDF, Newton) at ``relative_tolerance``."""
    check_fmu_archive(fmu_path)
    names = list(outputs) if outputs is not None else variable_names(fmu_path, "output")
    raw = simulate_fmu(str(fmu_path), fmi_type="ModelExchange", solver="CVode", stop_time=stop_time,
                       output_interval=output_interval, relative_tolerance=relative_tolerance,
                       input=inputs, output=names, start_values=start_values or {})
    return _result(raw, names, "ModelExchange")
