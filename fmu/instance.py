"""One instance of an opened FMU, the same calls for FMI 2.0 and 3.0, every call through one choke point.

:class:`Instance` wraps FMPy's ``FMU2Slave``/``FMU2Model``/``FMU3Slave``/``FMU3Model``. Every FMI call goes
through :meth:`Instance.call`: a status above warning (FMPy's ``FMICallException``) becomes an
:class:`FmuCallError` naming the file, the instance, the FMI function, the status and the FMU's last log
message; the FMU's log messages are collected (:attr:`Instance.messages`), not printed. A test that probes a
status on purpose asks :meth:`Instance.status`, the same path without the raise.

Variables are scalar names (``q[2]``, see :meth:`fmu.opened.OpenedFmu.select`); values are float64 NumPy
arrays. The hot loops of the closed-loop masters use :meth:`Instance.reader`, :meth:`Instance.writer` and
:meth:`Instance.stepper`: closures over preallocated ctypes buffers that still go through FMPy's own status
check and convert its exception here.
"""

from __future__ import annotations

import ctypes
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from model.errors import InputError, ToolchainError

from .selection import Selection


__all__ = ["FmuCallError", "Instance"]

_STATUS = ("OK", "Warning", "Discard", "Error", "Fatal", "Pending")
#: FMI's status codes (the same numbers in FMI 2.0 and 3.0).
OK, WARNING, DISCARD, ERROR, FATAL = range(5)


class FmuCallError(ToolchainError):
    """An FMI call returned Discard, Error or Fatal; :attr:`function`, :attr:`status` and :attr:`log` tell which."""

    def __init__(self, message: str, *, function: str, status: int, log: Sequence[str] = ()) -> None:
        super().__init__(message)
        self.function = function
        self.status = status
        self.log = tuple(log)


def _label(status: int) -> str:
    return _STATUS[status] if 0 <= status < len(_STATUS) else f"status {status}"


class Instance:
    """An FMU instance of interface ``kind`` ("cs" or "me"); made by :meth:`fmu.opened.OpenedFmu.instance`.

    The FMPy object (and with it the shared library) is created by :meth:`instantiate`; :meth:`close`
    terminates and frees whatever state the instance reached, and is safe to call twice.
    """

    def __init__(self, fmu: Any, kind: str, name: str, *, logging_on: bool = False) -> None:
        # fmu: the fmu.opened.OpenedFmu (not imported here: opened imports this module)
        self.fmu = fmu
        self.kind = kind
        self.name = name
        self.logging_on = logging_on
        self.messages: list[tuple[str, str, str]] = []  # (status, category, message) in arrival order
        self.raw: Any = None                            # FMPy's object, after instantiate()
        self._live = False
        self._terminated = False
        self._callbacks: Any = None

    # ------------------------------------------------------------------ the choke point

    @property
    def fmi3(self) -> bool:
        """True for an FMI 3.0 FMU."""
        return self.fmu.fmi_version >= 3

    def _log(self, status: int, category: bytes | None, message: bytes | None) -> None:
        self.messages.append((_label(int(status)), (category or b"").decode("utf-8", "replace"),
                              (message or b"").decode("utf-8", "replace")))

    def last_message(self) -> str:
        """The FMU's last log message, or an empty string."""
        return self.messages[-1][2] if self.messages else ""

    def error(self, function: str, status: int) -> FmuCallError:
        """The :class:`FmuCallError` for ``function`` having returned ``status``."""
        said = self.last_message()
        return FmuCallError(f"{self.fmu.name}: {function} of instance {self.name!r} returned {_label(status)}"
                            + (f": {said}" if said else ""), function=function, status=status,
                            log=[m for _, _, m in self.messages])

    def call(self, method: str, *args: Any) -> Any:
        """Call FMPy's ``method`` on the instance; a status above Warning raises :class:`FmuCallError`."""
        from fmpy.fmi1 import FMICallException

        if self.raw is None:
            raise InputError(f"{self.fmu.name}: {method} before instantiate", parameter="method")
        try:
            return getattr(self.raw, method)(*args)
        except FMICallException as exc:
            raise self.error(exc.function, exc.status) from None

    def status(self, method: str, *args: Any) -> int:
        """The FMI status of ``method`` (0 OK .. 4 Fatal), without raising: for probes of refused calls."""
        from fmpy.fmi1 import FMICallException

        try:
            getattr(self.raw, method)(*args)
        except FMICallException as exc:
            return int(exc.status)
        return OK

    # ------------------------------------------------------------------ life cycle

    def instantiate(self) -> "Instance":
        """Load the library and instantiate (logger collecting into :attr:`messages`)."""
        if self.raw is not None:
            return self
        ident = self.fmu.interfaces[self.kind]
        unzip = self.fmu.unzip_dir
        common = dict(guid=self.fmu.guid, unzipDirectory=unzip, modelIdentifier=ident, instanceName=self.name)
        try:
            if self.fmi3:
                from fmpy.fmi3 import FMU3Model, FMU3Slave

                self.raw = (FMU3Slave if self.kind == "cs" else FMU3Model)(**common)
                self.raw.instantiate(loggingOn=self.logging_on,
                                     logMessage=lambda env, status, category, message: self._log(status, category,
                                                                                                  message))
            else:
                from fmpy.fmi2 import (FMU2Model, FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
                from fmpy import calloc, free

                self.raw = (FMU2Slave if self.kind == "cs" else FMU2Model)(**common)
                cb = fmi2CallbackFunctions()
                cb.logger = fmi2CallbackLoggerTYPE(lambda comp, inst, status, category, message:
                                                   self._log(status, category, message))
                cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
                cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
                try:
                    from fmpy.logging import addLoggerProxy

                    addLoggerProxy(ctypes.byref(cb))  # formats the variadic message in C
                except Exception:  # noqa: BLE001 - FMPy without its logging helper: the raw format string is kept
                    pass
                self._callbacks = cb
                self.raw.instantiate(callbacks=cb, loggingOn=self.logging_on)
        except Exception as exc:  # FMPy raises plain Exceptions for a missing library or a NULL instance
            from fmpy.fmi1 import FMICallException

            if isinstance(exc, FMICallException):
                raise self.error(exc.function, exc.status) from None
            said = self.last_message()
            raise FmuCallError(f"{self.fmu.name}: instantiating {self.name!r} failed: {exc}"
                               + (f" ({said})" if said else ""), function="instantiate", status=ERROR) from None
        self._live = True
        return self

    def start(self, t0: float = 0.0, values: Mapping[str, float] | None = None, *, tolerance: float | None = None,
              stop_time: float | None = None, continuous: bool = True) -> "Instance":
        """Instantiate if needed, set ``values`` (scalar names) in Initialization Mode and leave it.

        Model Exchange: the discrete states are then iterated to a fixed point and, when ``continuous``,
        the instance enters Continuous-Time Mode. FMI 3.0 Co-Simulation is in Step Mode after this.
        """
        self.instantiate()
        if self.fmi3:
            self.call("enterInitializationMode", tolerance, float(t0), stop_time)
        else:
            self.call("setupExperiment", tolerance, float(t0), stop_time)
            self.call("enterInitializationMode")
        if values:
            self.set(list(values), [float(v) for v in values.values()])
        self.call("exitInitializationMode")
        if self.kind == "me":
            self.event_iteration()
            if continuous:
                self.call("enterContinuousTimeMode")
        return self

    def terminate(self) -> None:
        """``fmi*Terminate`` (raises on a refused call); :meth:`close` then only frees the instance."""
        self.call("terminate")
        self._terminated = True

    def close(self) -> None:
        """Terminate (a refusal from an instance in error state is ignored) and free; unload the library."""
        from fmpy.fmi1 import FMICallException

        if self.raw is None:
            return
        raw, self.raw = self.raw, None
        if not self._live:
            raw.freeLibrary()
            return
        self._live = False
        try:
            if not self._terminated:
                raw.terminate()
        except FMICallException:
            pass  # an instance in Error or Terminated state refuses it; it is freed all the same
        finally:
            raw.freeInstance()

    def __enter__(self) -> "Instance":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ values

    def _sel(self, names: Sequence[str] | Selection) -> Selection:
        return names if isinstance(names, Selection) else self.fmu.select(list(names))

    def get(self, names: Sequence[str] | Selection) -> np.ndarray:
        """The float64 values of scalar ``names``, in their order."""
        sel = self._sel(names)
        if self.fmi3:
            raw = np.array(self.call("getFloat64", list(sel.vrs), sel.total), dtype=float)
        else:
            raw = np.array(self.call("getReal", list(sel.vrs)), dtype=float)
        return raw if sel.whole else raw[list(sel.where)]

    def set(self, names: Sequence[str] | Selection, values: Sequence[float] | np.ndarray) -> None:
        """Set scalar ``names`` to ``values`` (an FMI 3.0 array partly named keeps its other elements)."""
        sel = self._sel(names)
        vals = np.asarray(values, dtype=float).ravel()
        if vals.size != len(sel.names):
            raise InputError(f"expected {len(sel.names)} values for {list(sel.names)}, got {vals.size}",
                             parameter="values")
        if self.fmi3:
            full = vals if sel.whole else self.get(self._whole(sel))
            if not sel.whole:
                full[list(sel.where)] = vals
            self.call("setFloat64", list(sel.vrs), [float(v) for v in full])
        else:
            self.call("setReal", list(sel.vrs), [float(v) for v in vals])

    def _whole(self, sel: Selection) -> Selection:
        """The selection of every element of the arrays behind ``sel``."""
        return Selection(tuple(f"#{i}" for i in range(sel.total)), sel.vrs, sel.sizes, tuple(range(sel.total)))

    def reader(self, names: Sequence[str]) -> Callable[[], np.ndarray]:
        """A fast getter of ``names``: returns a view of one buffer (copy it to keep the values)."""
        sel = self._sel(names)
        n_vr, total = len(sel.vrs), sel.total
        vrs = (ctypes.c_uint32 * n_vr)(*sel.vrs)
        buf = (ctypes.c_double * total)()
        view = np.ctypeslib.as_array(buf)
        raw, comp = self.raw, self.raw.component
        where = None if sel.whole else np.array(sel.where)
        if self.fmi3:
            def low() -> None:
                raw.fmi3GetFloat64(comp, vrs, n_vr, buf, total)
        else:
            def low() -> None:
                raw.fmi2GetReal(comp, vrs, n_vr, buf)
        from fmpy.fmi1 import FMICallException

        def read() -> np.ndarray:
            try:
                low()
            except FMICallException as exc:
                raise self.error(exc.function, exc.status) from None
            return view if where is None else view[where]
        return read

    def writer(self, names: Sequence[str]) -> tuple[np.ndarray, Callable[[], None]]:
        """A fast setter of whole variables ``names``: fill the returned array, then call the function."""
        sel = self._sel(names)
        if not sel.whole:
            raise InputError(f"a writer takes whole variables in order, got {list(sel.names)}", parameter="names")
        n_vr, total = len(sel.vrs), sel.total
        vrs = (ctypes.c_uint32 * n_vr)(*sel.vrs)
        buf = (ctypes.c_double * total)()
        view = np.ctypeslib.as_array(buf)
        raw, comp = self.raw, self.raw.component
        from fmpy.fmi1 import FMICallException

        if self.fmi3:
            def low() -> None:
                raw.fmi3SetFloat64(comp, vrs, n_vr, buf, total)
        else:
            def low() -> None:
                raw.fmi2SetReal(comp, vrs, n_vr, buf)

        def write() -> None:
            try:
                low()
            except FMICallException as exc:
                raise self.error(exc.function, exc.status) from None
        return view, write

    def stepper(self) -> Callable[[float, float], None]:
        """A fast Co-Simulation step ``(t, h)``; a refused step raises :class:`FmuCallError`."""
        raw, comp = self.raw, self.raw.component
        from fmpy.fmi1 import FMICallException

        if self.fmi3:
            flags = [ctypes.c_bool() for _ in range(3)]
            last = ctypes.c_double()
            refs = [ctypes.byref(f) for f in flags] + [ctypes.byref(last)]

            def low(t: float, h: float) -> None:
                raw.fmi3DoStep(comp, t, h, True, *refs)
        else:
            def low(t: float, h: float) -> None:
                raw.fmi2DoStep(comp, t, h, 1)

        def step(t: float, h: float) -> None:
            try:
                low(t, h)
            except FMICallException as exc:
                raise self.error(exc.function, exc.status) from None
        return step

    def do_step(self, t: float, h: float) -> None:
        """One Co-Simulation step from ``t`` over ``h`` s."""
        self.call("doStep", float(t), float(h))

    # ------------------------------------------------------------------ Model Exchange

    def enter_event_mode(self) -> None:
        self.call("enterEventMode")

    def enter_continuous_time_mode(self) -> None:
        self.call("enterContinuousTimeMode")

    def event_iteration(self, max_iterations: int = 100) -> None:
        """Update the discrete states until they settle (``fmi2NewDiscreteStates``/``fmi3UpdateDiscreteStates``).

        Raises
        ------
        FmuCallError
            The FMU asks to terminate, or has not settled after ``max_iterations``.
        """
        for _ in range(max_iterations):
            if self.fmi3:
                again, terminate, *_ = self.call("updateDiscreteStates")
            else:
                again, terminate, *_ = self.call("newDiscreteStates")
            if terminate:
                raise FmuCallError(f"{self.fmu.name}: the FMU asked to terminate during the event iteration"
                                   + (f": {self.last_message()}" if self.messages else ""),
                                   function="updateDiscreteStates", status=ERROR)
            if not again:
                return
        raise FmuCallError(f"{self.fmu.name}: the discrete states did not settle in {max_iterations} iterations",
                           function="updateDiscreteStates", status=ERROR)

    def set_time(self, t: float) -> None:
        self.call("setTime", float(t))

    def completed_integrator_step(self) -> tuple[bool, bool]:
        """``(enter event mode, terminate)``."""
        out = self.call("completedIntegratorStep")
        return bool(out[0]), bool(out[1])

    def _vector(self, method: str, n: int) -> np.ndarray:
        buf = (ctypes.c_double * n)()
        self.call(method, buf, n)
        return np.array(buf[:])

    def get_x(self) -> np.ndarray:
        """The continuous states."""
        return self._vector("getContinuousStates", self.fmu.n_states)

    def set_x(self, x: np.ndarray) -> None:
        x = np.asarray(x, dtype=float)
        self.call("setContinuousStates", (ctypes.c_double * x.size)(*x), x.size)

    def get_dx(self) -> np.ndarray:
        """The state derivatives."""
        return self._vector("getContinuousStateDerivatives" if self.fmi3 else "getDerivatives", self.fmu.n_states)

    def get_z(self) -> np.ndarray:
        """The event indicators."""
        return self._vector("getEventIndicators", self.fmu.n_event_indicators)

    def solver_functions(self) -> dict[str, Callable[..., Any]]:
        """The callables FMPy's ``CVodeSolver`` takes (``get_x``, ``set_x``, ``get_dx``, ``get_z``,
        ``get_nominals``, ``set_time``), bound to this instance."""
        r = self.raw
        return dict(get_x=r.getContinuousStates, set_x=r.setContinuousStates,
                    get_dx=r.getContinuousStateDerivatives if self.fmi3 else r.getDerivatives,
                    get_z=r.getEventIndicators, get_nominals=r.getNominalsOfContinuousStates, set_time=r.setTime)

    # ------------------------------------------------------------------ states and derivatives

    def get_state(self) -> Any:
        return self.call("getFMUState" if self.fmi3 else "getFMUstate")

    def set_state(self, state: Any) -> None:
        self.call("setFMUState" if self.fmi3 else "setFMUstate", state)

    def free_state(self, state: Any) -> None:
        self.call("freeFMUState" if self.fmi3 else "freeFMUstate", state)

    def serialize(self, state: Any) -> bytes:
        return bytes(self.call("serializeFMUState" if self.fmi3 else "serializeFMUstate", state))

    def deserialize(self, data: bytes) -> Any:
        return self.call("deserializeFMUState" if self.fmi3 else "deSerializeFMUstate", data)

    def directional(self, unknowns: Sequence[str], knowns: Sequence[str], seed: Sequence[float]) -> np.ndarray:
        """``J @ seed`` for the Jacobian of scalar ``unknowns`` with respect to scalar ``knowns``."""
        return self._derivative("getDirectionalDerivative", unknowns, knowns, seed)

    def adjoint(self, unknowns: Sequence[str], knowns: Sequence[str], seed: Sequence[float]) -> np.ndarray:
        """``seed @ J`` (FMI 3.0's adjoint derivatives; ``seed`` has one value per unknown)."""
        if not self.fmi3:
            raise InputError(f"{self.fmu.name}: FMI 2.0 has no adjoint derivatives", parameter="method")
        return self._derivative("getAdjointDerivative", unknowns, knowns, seed)

    def _derivative(self, method: str, unknowns: Sequence[str], knowns: Sequence[str],
                    seed: Sequence[float]) -> np.ndarray:
        su, sk = self._sel(unknowns), self._sel(knowns)
        adjoint = method == "getAdjointDerivative"
        seed_sel, out_sel = (su, sk) if adjoint else (sk, su)
        seed = np.asarray(seed, dtype=float).ravel()
        if self.fmi3:
            full = np.zeros(seed_sel.total)
            full[list(seed_sel.where)] = seed
            raw = np.array(self.call(method, list(su.vrs), list(sk.vrs), list(full), out_sel.total))
            return raw[list(out_sel.where)]
        return np.array(self.call(method, list(su.vrs), list(sk.vrs), list(seed)))
