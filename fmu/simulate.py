"""Thin helpers around FMPy: input tables, Co-Simulation and Model Exchange runs.

Inputs are piecewise constant (a command updated every ``hold`` seconds, as a
digital controller would send it): :func:`step_input` writes them as FMPy's
step table (two rows at every switching time), so FMPy applies the value
after the switch in Co-Simulation and raises a time event at every switch in
Model Exchange. Results come back as a :class:`SimulationResult` of arrays.
Every FMU is opened by :func:`fmu.opened.open_fmu` (the archive checked) before FMPy's ``simulate_fmu`` runs it.

Names are the scalar names of the variable table (``tau_m[1]``, ``q[2]``) for
FMI 2.0 and FMI 3.0 alike: for an FMI 3.0 FMU, whose joint vectors are array
variables, the input table's columns ``tau_m[1..n]`` are joined into one array
column ``tau_m`` and the array outputs are split back into their elements.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from fmpy import simulate_fmu

from model.errors import InputError

from .opened import OpenedFmu, open_fmu

__all__ = ["SimulationResult", "step_input", "simulate_cs", "simulate_me", "variable_names", "fmi_version"]


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


def fmi_version(fmu_path: str | os.PathLike[str]) -> int:
    """2 or 3: the major FMI version of the FMU (:attr:`fmu.opened.OpenedFmu.fmi_version`).

    Read without FMPy's schema check, so that a description the schema refuses still tells its version
    (the schema check reports it).
    """
    with open_fmu(fmu_path, validate=False) as fmu:
        return fmu.fmi_version


def _sizes(fmu: OpenedFmu) -> dict[str, int]:
    """Number of elements of every variable (1 for a scalar) by name."""
    return {name: fmu.select([name]).total for name in fmu.variables}


def variable_names(fmu_path: str | os.PathLike[str], causality: str) -> list[str]:
    """Scalar names of the FMU's variables of one causality (``q[1]`` .. for an FMI 3.0 array ``q``)."""
    with open_fmu(fmu_path) as fmu:
        return fmu.names(causality)


def _base(name: str) -> str:
    return name.split("[", 1)[0]


def _array_inputs(table: np.ndarray | None, sizes: dict[str, int]) -> np.ndarray | None:
    """An input table with columns ``x[1..k]`` joined into one array column ``x`` (FMI 3.0)."""
    if table is None:
        return None
    columns: dict[str, list[str]] = {}
    for name in table.dtype.names[1:]:
        columns.setdefault(_base(name) if sizes.get(_base(name), 1) > 1 else name, []).append(name)
    dtype = [("time", np.float64)] + [(b, np.float64, (len(c),)) if len(c) > 1 or sizes.get(b, 1) > 1 else (b, np.float64)
                                      for b, c in columns.items()]
    out = np.zeros(table.shape, dtype=dtype)
    out["time"] = table["time"]
    for b, c in columns.items():
        out[b] = np.column_stack([table[n] for n in c]) if out[b].ndim > 1 else table[c[0]]
    return out


def _run(fmu: OpenedFmu, names: list[str], inputs: np.ndarray | None, **kwargs) -> dict[str, np.ndarray]:
    """FMPy's simulate_fmu, with scalar names for FMI 2.0 and 3.0: {"time": t, name: values}."""
    if fmu.fmi_version < 3:
        raw = simulate_fmu(str(fmu.path), input=inputs, output=names, **kwargs)
        return {n: np.array(raw[n]) for n in ["time", *names]}
    sizes = _sizes(fmu)
    bases = list(dict.fromkeys(_base(n) if sizes.get(_base(n), 1) > 1 else n for n in names))
    raw = simulate_fmu(str(fmu.path), input=_array_inputs(inputs, sizes), output=bases, **kwargs)
    values = {"time": np.array(raw["time"])}
    for n in names:
        b = _base(n)
        if sizes.get(b, 1) > 1:
            values[n] = np.array(raw[b][:, int(n[len(b) + 1:-1]) - 1])
        else:
            values[n] = np.array(raw[n])
    return values


def step_input(names: Sequence[str], t_switch: np.ndarray, values: np.ndarray) -> np.ndarray:
    """FMPy input table of a piecewise-constant signal.

    ``values[i]`` holds on ``[t_switch[i], t_switch[i + 1])``; the last one
    holds to the end. ``t_switch`` (K,) increasing, ``values`` (K, len(names)).
    """
    t_switch = np.asarray(t_switch, dtype=float)
    values = np.asarray(values, dtype=float)
    if values.shape != (t_switch.size, len(names)):
        raise InputError(f"expected shape ({t_switch.size}, {len(names)}), got {values.shape}", parameter="values")
    if np.any(np.diff(t_switch) <= 0):
        raise InputError("expected strictly increasing switching times", parameter="t_switch")
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


def _result(raw: dict[str, np.ndarray], names: Sequence[str], interface: str) -> SimulationResult:
    return SimulationResult(raw["time"], {n: raw[n] for n in names}, interface)


def simulate_cs(fmu_path: str | os.PathLike[str], stop_time: float, step: float, *,
                inputs: np.ndarray | None = None, outputs: Sequence[str] | None = None,
                start_values: dict[str, float] | None = None) -> SimulationResult:
    """Co-Simulation by FMPy with communication step ``step`` (s), outputs every step."""
    with open_fmu(fmu_path) as fmu:
        names = list(outputs) if outputs is not None else fmu.names("output")
        raw = _run(fmu, names, inputs, fmi_type="CoSimulation", stop_time=stop_time, output_interval=step,
                   start_values=start_values or {})
    return _result(raw, names, "CoSimulation")


def simulate_me(fmu_path: str | os.PathLike[str], stop_time: float, output_interval: float, *,
                inputs: np.ndarray | None = None, outputs: Sequence[str] | None = None,
                start_values: dict[str, float] | None = None, relative_tolerance: float = 1e-8) -> SimulationResult:
    """Model Exchange by FMPy with its CVode solver (BDF, Newton) at ``relative_tolerance``."""
    with open_fmu(fmu_path) as fmu:
        names = list(outputs) if outputs is not None else fmu.names("output")
        raw = _run(fmu, names, inputs, fmi_type="ModelExchange", solver="CVode", stop_time=stop_time,
                   output_interval=output_interval, relative_tolerance=relative_tolerance,
                   start_values=start_values or {})
    return _result(raw, names, "ModelExchange")
