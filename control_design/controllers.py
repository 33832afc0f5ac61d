"""Sampled joint controllers with one interface: ``update(t, q, qd, ref) -> tau_m``.

A controller is called once per control period ``dt = 1 / rate_hz`` with the
measured joint state (q rad or m, qd rad/s or m/s) and the reference at that
instant (:class:`~control_design.reference.Reference`, joint side); it returns
the motor torques (N m) to hold until the next call (zero-order hold). The
closed loops of :mod:`closed_loop` use it that way.

* :class:`DecentralisedController` - per-joint PD / PD + gravity compensation /
  PID / PD + feed-forward on the motor angle ``theta_m = G q``.
* :class:`ComputedTorqueController` - ``tau = rne(q, qd, qdd_d + Kd e' + Kp e)``
  on a controller model, then ``tau_m = tau / G``.

Both are a :class:`LawController`: ``update`` evaluates the law's CasADi
Function followed by the saturation (:func:`control_design.laws.controller_function`),
compiled once per law and robot (:mod:`model.codegen`), the same Function a
controller FMU carries. The PID integrator stops integrating while its output
is saturated in the direction of the error (conditional integration, against
wind-up).
"""

from __future__ import annotations

import math
import warnings
from abc import ABC, abstractmethod
from typing import Any

import casadi as ca
import numpy as np

from model.codegen import CompiledLibrary, CompilerNotFoundError, build_library
from model.dynamics.core import NoCompilerWarning, source_fingerprint
from model.robot import Robot

from .errors import DesignSpecError, UnknownControllerError
from .laws import NO_LIMIT, ControlLaw, control_law, controller_function, law_fingerprint
from .reference import Reference

__all__ = ["Controller", "LawController", "DecentralisedController", "ComputedTorqueController"]


def _vec(value: Any, n: int, name: str) -> np.ndarray:
    arr = np.array(np.broadcast_to(np.asarray(value, dtype=float), (n,)))
    if not np.all(np.isfinite(arr)):
        raise DesignSpecError(f"expected {n} finite values, got {arr.tolist()}", parameter=name)
    return arr


class Controller(ABC):
    """A sampled controller: ``update`` once every ``dt`` s returns the motor torques to hold.

    Parameters
    ----------
    n
        Number of joints.
    rate_hz
        Control rate, Hz.
    gear_ratio
        (n,) reduction ratios G (motor angle = G q).
    tau_m_max
        (n,) motor torque limits, N m; ``None`` for no saturation.
    """

    kind: str = ""

    def __init__(self, n: int, rate_hz: float, gear_ratio: Any, tau_m_max: Any = None) -> None:
        if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
            raise DesignSpecError(f"expected a positive number of Hz, got {rate_hz!r}", parameter="rate")
        self.n = int(n)
        self.rate_hz = float(rate_hz)
        self.G = _vec(gear_ratio, n, "gear_ratio")
        self.tau_m_max = None if tau_m_max is None else _vec(tau_m_max, n, "tau_m_max")
        if self.tau_m_max is not None and np.any(self.tau_m_max <= 0):
            raise DesignSpecError(f"expected positive torque limits (N m), got {self.tau_m_max.tolist()}",
                                  parameter="tau_m_max")

    @property
    def dt(self) -> float:
        """Control period, s."""
        return 1.0 / self.rate_hz

    def reset(self) -> None:
        """Clear internal state (integrators) before a new run."""

    @abstractmethod
    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        """Motor torques (n,) N m for the measured ``q``, ``qd`` and the reference at time ``t`` (s)."""


_LIBRARIES: dict[str, CompiledLibrary | None] = {}


def _compiled(law: ControlLaw, model: Robot | None, function: ca.Function) -> CompiledLibrary | None:
    """The compiled library of ``function`` (cached per process and on disk); None without a C compiler."""
    key = f"control law|{law.kind}|{function.size1_in(0)}|{law_fingerprint()}"
    if model is not None:
        key += f"|{model.description.digest()}|{model.motor_model}|{source_fingerprint()}"
    if key not in _LIBRARIES:
        stem = f"law-{law.kind}" + (f"-{model.name}" if model is not None else f"-{function.size1_in(0)}")
        try:
            _LIBRARIES[key] = build_library(stem, key, lambda: [function])[0]
        except CompilerNotFoundError as exc:
            warnings.warn(f"{exc}; evaluating the control law with CasADi instead", NoCompilerWarning, stacklevel=4)
            _LIBRARIES[key] = None
    return _LIBRARIES[key]


class LawController(Controller):
    """A controller that evaluates a control law (:mod:`control_design.laws`) and its saturation.

    Parameters
    ----------
    law
        The law.
    parameters
        Its parameter values by name (every entry of ``law.parameters`` but ``tau_m_max``).
    rate_hz, gear_ratio, tau_m_max
        As :class:`Controller`; ``gear_ratio`` is also the law's ``gear_ratio`` parameter.
    model
        The robot model of a 'pd-g' or 'ct' law.
    """

    def __init__(self, law: ControlLaw, parameters: dict[str, Any], rate_hz: float, gear_ratio: Any,
                 tau_m_max: Any = None, model: Robot | None = None) -> None:
        G = np.atleast_1d(np.asarray(gear_ratio, dtype=float))
        super().__init__(G.size, rate_hz, G, tau_m_max)
        self.law = law
        self.kind = law.kind
        limit = np.full(self.n, NO_LIMIT) if self.tau_m_max is None else self.tau_m_max
        values = {**parameters, "gear_ratio": self.G, "tau_m_max": limit}
        self.function = controller_function(law)
        f = self.function
        names = [f.name_in(i) for i in range(f.n_in())]
        self._values: dict[str, np.ndarray] = {}
        for name in names[len(law.signals):]:
            if name in law.states:
                continue
            arr = np.array(np.atleast_1d(np.asarray(values[name], dtype=float)))
            arr.flags.writeable = False
            self._values[name] = arr
        self._state_index = [names.index(s) for s in law.states]
        self._lib = _compiled(law, model, f)
        self._ev = None
        if self._lib is not None:
            external = {names.index(k): v for k, v in self._values.items()}
            self._ev = self._lib.point_evaluator(f.name(), external)
        self._states = [np.zeros(self.n) for _ in law.states]

    def parameter_values(self) -> dict[str, np.ndarray]:
        """The parameter inputs of :attr:`function` (``tau_m_max`` included, :data:`~control_design.laws.NO_LIMIT`
        without saturation), by name, in input order."""
        return {k: v.copy() for k, v in self._values.items()}

    def reset(self) -> None:
        self._states = [np.zeros(self.n) for _ in self.law.states]

    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        signals = (q, qd, ref.q, ref.qd, ref.qdd)
        ev = self._ev
        if ev is None:
            f = self.function
            args: list[Any] = []
            k = 0
            for i in range(f.n_in()):
                name = f.name_in(i)
                if i < len(self.law.signals):
                    args.append(signals[i])
                elif name in self.law.states:
                    args.append(self._states[k])
                    k += 1
                else:
                    args.append(self._values[name])
            out = f(*args)
            out = list(out) if isinstance(out, (list, tuple)) else [out]
            self._states = [np.array(o).reshape(-1) for o in out[1:]]
            return np.array(out[0]).reshape(-1)
        inputs = ev.inputs
        for i in range(len(self.law.signals)):
            inputs[i][...] = signals[i]
        for j, z in zip(self._state_index, self._states):
            inputs[j][...] = z
        ev()
        outputs = ev.outputs
        if len(outputs) > 1:
            self._states = [o.copy() for o in outputs[1:]]
        return outputs[0].copy()


class DecentralisedController(LawController):
    """Independent joint loops on the motor angle.

    ``tau_m = Kp e_m + Kd e_m' + Ki int(e_m) [+ J_ff theta_m,d'' + B_ff theta_m,d'] [+ g(q) / G]``
    with ``e_m = G (q_d - q)``, ``e_m' = G (qd_d - qd)``; the feed-forward in brackets for
    'pd-ff', the gravity compensation for 'pd-g' (laws in :mod:`control_design.laws`).

    Parameters
    ----------
    kind
        'pd', 'pd-g', 'pid' or 'pd-ff'.
    Kp, Kd, Ki
        (n,) motor-side gains, N m/rad, N m s/rad, N m/(rad s) (Ki used by 'pid' only).
    gear_ratio, rate_hz, tau_m_max
        As :class:`Controller`.
    J_ff_m, B_ff_m
        (n,) decoupled inertia (kg m^2) and viscous friction (N m s/rad) fed forward by 'pd-ff'.
    gravity_model
        The robot model whose ``gravload`` (with its parameters) 'pd-g' compensates.
    """

    def __init__(self, kind: str, Kp: Any, Kd: Any, Ki: Any, gear_ratio: Any, rate_hz: float,
                 tau_m_max: Any = None, J_ff_m: Any = None, B_ff_m: Any = None, gravity_model: Robot | None = None) -> None:
        G = np.atleast_1d(np.asarray(gear_ratio, dtype=float))
        n = G.size
        if kind not in ("pd", "pd-g", "pid", "pd-ff"):
            raise UnknownControllerError(f"expected one of pd, pd-g, pid, pd-ff, got {kind!r}", parameter="kind")
        self.Kp, self.Kd = _vec(Kp, n, "Kp"), _vec(Kd, n, "Kd")
        self.Ki = _vec(Ki, n, "Ki") if kind == "pid" else np.zeros(n)
        values: dict[str, Any] = {"Kp": self.Kp, "Kd": self.Kd}
        if kind == "pd-ff":
            if J_ff_m is None or B_ff_m is None:
                raise DesignSpecError("J_ff_m, B_ff_m: a 'pd-ff' controller needs the decoupled inertia and friction to feed forward")
            self.J_ff_m, self.B_ff_m = _vec(J_ff_m, n, "J_ff_m"), _vec(B_ff_m, n, "B_ff_m")
            values.update(J_ff_m=self.J_ff_m, B_ff_m=self.B_ff_m)
        if kind == "pd-g":
            if gravity_model is None:
                raise DesignSpecError("a 'pd-g' controller needs a robot model to compensate gravity",
                                      parameter="gravity_model")
            values["p_model"] = gravity_model.parameters.vector
        if kind == "pid":
            if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
                raise DesignSpecError(f"expected a positive number of Hz, got {rate_hz!r}", parameter="rate")
            values.update(Ki=self.Ki, dt=1.0 / rate_hz)
        self.gravity_model = gravity_model
        super().__init__(control_law(kind, n, gravity_model if kind == "pd-g" else None), values, rate_hz, G,
                         tau_m_max, model=gravity_model if kind == "pd-g" else None)

    @property
    def _z(self) -> np.ndarray:
        """(n,) PID integrator state, rad s on the motor side (zeros for the other kinds)."""
        return self._states[0].copy() if self._states else np.zeros(self.n)


class ComputedTorqueController(LawController):
    """Computed torque (inverse dynamics) on a controller model.

    ``tau = B(q)(qdd_d + Kd (qd_d - qd) + Kp (q_d - q)) + C(q, qd) qd + F(qd) + g(q)``,
    evaluated as one ``rne(q, qd, v)`` of the model (with its parameters), then ``tau_m = tau / G``.

    Parameters
    ----------
    model
        The controller's robot model (may differ from the plant: payload, friction, masses).
    Kp, Kd
        (n,) outer-loop gains, 1/s^2 and 1/s (``wn^2`` and ``2 zeta wn``).
    rate_hz, tau_m_max
        As :class:`Controller`.
    """

    def __init__(self, model: Robot, Kp: Any, Kd: Any, rate_hz: float, tau_m_max: Any = None) -> None:
        n = model.n
        self.model = model
        self.Kp, self.Kd = _vec(Kp, n, "Kp"), _vec(Kd, n, "Kd")
        super().__init__(control_law("ct", n, model), {"Kp": self.Kp, "Kd": self.Kd, "p_model": model.parameters.vector},
                         rate_hz, model.gear_ratio, tau_m_max, model=model)
