"""Run FMUs in libcosim (Open Simulation Platform), the second, independent importer.

libcosimpy is a thin ctypes layer: a slave whose FMU failed to load is a NULL
pointer, and adding it to an execution crashes the process. Every pointer and
index is therefore checked here before use, and a failure raises
:class:`CosimError` naming what failed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .opened import open_fmu
from model.errors import ToolchainError

__all__ = ["CosimError", "LibcosimUnavailableError", "CosimResult", "add_slave", "last_error", "libcosim_unavailable",
           "run_libcosim"]

NS_PER_S = 1_000_000_000


class CosimError(ToolchainError):
    """libcosim refused a call (load, add, connect, step); the message says which and why."""


class LibcosimUnavailableError(CosimError):
    """libcosimpy cannot be imported (not installed, or its native library fails to load)."""


def libcosim_unavailable() -> str | None:
    """Why libcosimpy cannot be used here, or None if it imports."""
    try:
        import libcosimpy.CosimExecution  # noqa: F401  (loads the native library)
    except (ImportError, OSError) as exc:
        return f"libcosimpy is not importable: {exc}"
    return None


@dataclass(frozen=True)
class CosimResult:
    """Samples of a libcosim run after every step: ``t`` (N,), per instance an (N, len(outputs)) array."""

    t: np.ndarray
    outputs: tuple[str, ...]
    values: dict[str, np.ndarray]


def last_error() -> str:
    """libcosim's last error message (or a placeholder when it has none)."""
    from libcosimpy._internal import get_last_error_message

    try:
        return get_last_error_message()
    except (OSError, AttributeError, UnicodeDecodeError):
        return "no message from libcosim"


def add_slave(execution: Any, path: Path, name: str) -> tuple[Any, int]:
    """Load ``path`` as libcosim slave ``name`` and add it to ``execution``: (the slave, its index).

    The slave must outlive ``execution``; the caller holds it.
    """
    from libcosimpy.CosimSlave import CosimLocalSlave

    slave = CosimLocalSlave(str(path), name)
    if not slave.ptr():  # a NULL slave would crash cosim_execution_add_slave
        raise CosimError(f"libcosim could not load {path.name} as instance {name!r}: {last_error()}")
    index = execution.add_local_slave(slave)
    if index is None or index < 0:
        raise CosimError(f"libcosim refused instance {name!r} of {path.name}: {last_error()}")
    return slave, index


def run_libcosim(fmu_path: str | os.PathLike[str], *, stop_time: float, step: float,
                 inputs: Callable[[float], Sequence[float]] | None = None,
                 input_names: Sequence[str] = (), output_names: Sequence[str] = (),
                 instances: Sequence[str] = ("robot_a", "robot_b"), start_values: dict[str, float] | None = None,
                 quiet: bool = True) -> CosimResult:
    """Simulate ``instances`` of one FMU side by side in libcosim with a fixed step.

    Parameters
    ----------
    fmu_path
        The FMU.
    stop_time, step
        End time and communication step, s (libcosim counts time in ns).
    inputs
        ``inputs(t)`` gives the input values held over the step starting at ``t``;
        every instance receives the same values.
    input_names, output_names
        FMU variable names; outputs are sampled after every step.
    instances
        Instance names; each becomes one libcosim slave.
    start_values
        Initial values of parameters (by name), the same for every instance.
    quiet
        Set libcosim's (process-wide) log level to warnings; its default prints
        every FMI call.

    Raises
    ------
    LibcosimUnavailableError
        libcosimpy does not import (see :func:`libcosim_unavailable`).
    CosimError
        libcosim refused a call.
    fmu.archive.FmuArchiveError
        The archive breaks a limit of :mod:`fmu.archive` (checked by :func:`fmu.opened.open_fmu` before libcosim
        extracts it).
    """
    reason = libcosim_unavailable()
    if reason is not None:
        raise LibcosimUnavailableError(reason)
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimManipulator import CosimManipulator
    from libcosimpy.CosimObserver import CosimObserver

    if quiet:
        log_output_level(CosimLogLevel.WARNING)
    path = Path(fmu_path).resolve()
    if not path.is_file():
        raise CosimError(f"expected an FMU file, got {str(path)!r}", parameter="fmu_path")
    open_fmu(path, validate=False).close()  # the archive checked and its description read before libcosim extracts it
    step_ns = int(round(step * NS_PER_S))
    if step_ns <= 0:
        raise CosimError(f"expected at least 1 ns, got {step!r} s", parameter="step")
    n_steps = int(round(stop_time / step))

    execution = CosimExecution.from_step_size(step_ns)
    slaves = []
    indices: dict[str, int] = {}
    for name in instances:
        slave, index = add_slave(execution, path, name)
        slaves.append(slave)
        indices[name] = index

    references: dict[int, dict[str, int]] = {}
    for name, index in indices.items():
        refs = {v.name.decode(): int(v.reference) for v in execution.slave_variables(index)}
        missing = [n for n in [*input_names, *output_names, *(start_values or {})] if n not in refs]
        if missing:
            raise CosimError(f"instance {name!r}: no variables {missing} in {path.name}")
        references[index] = refs
        for var, value in (start_values or {}).items():
            if not execution.real_initial_value(index, refs[var], float(value)):
                raise CosimError(f"libcosim refused the initial value {var} = {value}: {last_error()}")

    manipulator = CosimManipulator.create_override()
    observer = CosimObserver.create_last_value()
    if not execution.add_manipulator(manipulator) or not execution.add_observer(observer):
        raise CosimError(f"libcosim refused the manipulator or the observer: {last_error()}")

    t = np.arange(1, n_steps + 1) * step  # t0 + k h from the step counter, after each step
    values = {name: np.zeros((n_steps, len(output_names))) for name in indices}

    def sample(k: int) -> None:
        for name, index in indices.items():
            vrs = [references[index][n] for n in output_names]
            values[name][k] = observer.last_real_values(index, vrs) if vrs else []  # noqa: F821 - deleted after the run

    def apply(time: float) -> None:
        if inputs is None or not input_names:
            return
        u = [float(v) for v in inputs(time)]
        for index in indices.values():
            vrs = [references[index][n] for n in input_names]
            if not manipulator.slave_real_values(index, vrs, u):  # noqa: F821 - deleted after the run
                raise CosimError(f"libcosim refused the inputs at t = {time}: {last_error()}")

    for k in range(n_steps):
        apply(k * step)
        if not execution.step(1):
            raise CosimError(f"libcosim step {k + 1} (t = {k * step:.6g} s) failed: {last_error()}")
        sample(k)
    del execution  # before the slaves, manipulator and observer it uses
    del observer, manipulator, slaves
    return CosimResult(t, tuple(output_names), values)
