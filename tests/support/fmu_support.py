"""Shared helpers of the FMU tests: FMUs built once per test process, and a low-level FMPy harness.

Each FMU is built on first request into one temporary folder (removed at exit),
so the five ``test_fmu_*`` modules share the builds however pytest orders them.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
import warnings
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from model import InertiaConsistencyWarning

__all__ = ["build_root", "scara_fmu", "trivial_fmu", "planar2r_full_fmu", "heavy_scara_fmu", "puma_fmu", "scara_dir",
           "LogRecorder", "Harness", "make_callbacks"]


@lru_cache(maxsize=None)
def build_root() -> Path:
    root = Path(tempfile.mkdtemp(prefix="test_fmu_"))
    atexit.register(shutil.rmtree, root, ignore_errors=True)
    return root


def _quiet(fn, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return fn(*args, **kwargs)


@lru_cache(maxsize=None)
def scara_fmu() -> Path:
    """The SCARA FMU (reflected motors, internal step 1 ms)."""
    from fmu import export_fmu

    return _quiet(export_fmu, "scara", build_root() / "scara.fmu")


@lru_cache(maxsize=None)
def trivial_fmu() -> Path:
    """The one-state lag FMU."""
    from fmu import export_trivial_fmu

    return export_trivial_fmu(build_root() / "trivial.fmu")


@lru_cache(maxsize=None)
def planar2r_full_fmu() -> Path:
    """A second robot and motor model, internal step 0.5 ms."""
    from fmu import export_fmu

    return _quiet(export_fmu, "planar2r", build_root() / "planar2r_full.fmu", step=5e-4, motor_model="full")


@lru_cache(maxsize=None)
def heavy_scara_fmu() -> Path:
    """A modified SCARA: link masses and inertias x 1.5 (``plant_with_mismatch``; same name and path)."""
    from control_design import plant_with_mismatch
    from control_design.computed_torque import ModelMismatch
    from fmu import export_fmu
    from model import load_robot

    robot = _quiet(load_robot, "scara")
    heavy = _quiet(plant_with_mismatch, robot, ModelMismatch(link_mass_scale=1.5))
    return _quiet(export_fmu, heavy, build_root() / "scara_heavy.fmu")


@lru_cache(maxsize=None)
def puma_fmu() -> Path:
    """The Puma 560 FMU (reflected motors, its Coulomb friction: stick-slip modes)."""
    from fmu import export_fmu

    return _quiet(export_fmu, "puma560", build_root() / "puma560.fmu")


@lru_cache(maxsize=None)
def scara_dir() -> Path:
    """The SCARA FMU extracted (for FMPy's low-level classes and the C driver)."""
    from fmpy import extract

    return Path(extract(str(scara_fmu()), unzipdir=str(build_root() / "scara_unzipped")))


@dataclass
class LogRecorder:
    """An ``fmi2CallbackLogger`` that keeps every message as (status, category, message)."""

    messages: list[tuple[int, str, str]] = field(default_factory=list)

    def __call__(self, env, instance_name, status, category, message) -> None:
        self.messages.append((int(status), (category or b"").decode(), (message or b"").decode()))

    def text(self) -> str:
        return "\n".join(m for _, _, m in self.messages)


def make_callbacks(recorder: LogRecorder, with_memory: bool = True):
    """``fmi2CallbackFunctions`` with ``recorder`` as logger (and FMPy's calloc/free)."""
    from fmpy import calloc, free
    from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                           fmi2CallbackLoggerTYPE)

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(recorder)
    if with_memory:
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return callbacks


class Harness:
    """One FMPy ``FMU2Slave`` or ``FMU2Model`` of the SCARA with a recording logger.

    ``vr(name)`` maps names to value references; ``start()`` instantiates and
    (optionally) initialises; the instance is freed by ``close()``.
    """

    def __init__(self, kind: str = "cs", name: str = "under_test") -> None:
        from fmpy import read_model_description
        from fmpy.fmi2 import FMU2Model, FMU2Slave

        self.md = read_model_description(str(scara_dir()))
        cls = FMU2Slave if kind == "cs" else FMU2Model
        self.fmu = cls(guid=self.md.guid, unzipDirectory=str(scara_dir()), modelIdentifier="scara",
                       instanceName=name)
        self.log = LogRecorder()
        self.callbacks = make_callbacks(self.log)
        self._names = {v.name: v.valueReference for v in self.md.modelVariables}
        self.nx = len(self.md.derivatives)

    def vr(self, *names: str) -> list[int]:
        return [self._names[n] for n in names]

    def start(self, initialise: bool = True) -> "Harness":
        self.fmu.instantiate(callbacks=self.callbacks)
        if initialise:
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
        return self

    @property
    def c(self):
        return self.fmu.component

    def call(self, function: str, *args) -> int:
        """Call an fmi2 function of the binary directly (any interface type); returns the status."""
        from ctypes import c_int

        f = getattr(self.fmu.dll, function)
        f.restype = c_int
        return int(f(self.c, *args))

    def close(self) -> None:
        if self.fmu.component is not None:
            self.fmu.fmi2FreeInstance(self.fmu.component)
            self.fmu.component = None
        self.fmu.freeLibrary()

    def states(self) -> np.ndarray:
        return np.array(self.fmu.getReal(list(range(self.nx))))
