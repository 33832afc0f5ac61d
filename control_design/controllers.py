"""Sampled joint controllers with one interface: ``update(t, q, qd, ref) -> tau_m``.

A controller is called once per control period ``dt = 1 / rate_hz`` with the
measured joint state (q rad or m, qd rad/s or m/s) and the reference at that
instant (:class:`~control_design.reference.Reference`, joint side); it returns
the motor torques (N m) to hold until the next call (zero-order hold). The
Python closed loop (:mod:`control_design.simulate`) and a co-simulation master
driving an FMU of the arm use it the same way.

* :class:`DecentralisedController` - per-joint PD / PD + gravity compensation /
  PID / PD + feed-forward on the motor angle ``theta_m = G q``.
* :class:`ComputedTorqueController` - ``tau = rne(q, qd, qdd_d + Kd e' + Kp e)``
  on a controller model, then ``tau_m = tau / G``.

Both saturate at the per-motor limit when one is given; the PID integrator
stops integrating while its output is saturated in the direction of the error
(conditional integration, against wind-up).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from model.robot import Robot

from .errors import DesignSpecError, UnknownControllerError
from .reference import Reference

__all__ = ["Controller", "DecentralisedController", "ComputedTorqueController"]


def _vec(value: Any, n: int, name: str) -> np.ndarray:
    arr = np.array(np.broadcast_to(np.asarray(value, dtype=float), (n,)))
    if not np.all(np.isfinite(arr)):
        raise DesignSpecError(f"{name}: expected {n} finite values, got {arr.tolist()}")
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
            raise DesignSpecError(f"rate: expected a positive number of Hz, got {rate_hz!r}")
        self.n = int(n)
        self.rate_hz = float(rate_hz)
        self.G = _vec(gear_ratio, n, "gear_ratio")
        self.tau_m_max = None if tau_m_max is None else _vec(tau_m_max, n, "tau_m_max")
        if self.tau_m_max is not None and np.any(self.tau_m_max <= 0):
            raise DesignSpecError(f"tau_m_max: expected positive torque limits (N m), got {self.tau_m_max.tolist()}")

    @property
    def dt(self) -> float:
        """Control period, s."""
        return 1.0 / self.rate_hz

    def reset(self) -> None:
        """Clear internal state (integrators) before a new run."""

    def _saturate(self, tau_m: np.ndarray) -> np.ndarray:
        if self.tau_m_max is None:
            return tau_m
        return np.clip(tau_m, -self.tau_m_max, self.tau_m_max)

    @abstractmethod
    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        """Motor torques (n,) N m for the measured ``q``, ``qd`` and the reference at time ``t`` (s)."""


class DecentralisedController(Controller):
    """Independent joint loops on the motor angle.

    ``tau_m = Kp e_m + Kd e_m' + Ki int(e_m) [+ J_ff theta_m,d'' + B_ff theta_m,d'] [+ g(q) / G]``
    with ``e_m = G (q_d - q)``, ``e_m' = G (qd_d - qd)``; the feed-forward in brackets for
    'pd-ff', the gravity compensation for 'pd-g'.

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
        The robot model whose ``gravload`` 'pd-g' compensates.
    """

    def __init__(self, kind: str, Kp: Any, Kd: Any, Ki: Any, gear_ratio: Any, rate_hz: float,
                 tau_m_max: Any = None, J_ff_m: Any = None, B_ff_m: Any = None, gravity_model: Robot | None = None) -> None:
        G = np.atleast_1d(np.asarray(gear_ratio, dtype=float))
        super().__init__(G.size, rate_hz, G, tau_m_max)
        if kind not in ("pd", "pd-g", "pid", "pd-ff"):
            raise UnknownControllerError(f"kind: expected one of pd, pd-g, pid, pd-ff, got {kind!r}")
        n = self.n
        self.kind = kind
        self.Kp, self.Kd = _vec(Kp, n, "Kp"), _vec(Kd, n, "Kd")
        self.Ki = _vec(Ki, n, "Ki") if kind == "pid" else np.zeros(n)
        if kind == "pd-ff":
            if J_ff_m is None or B_ff_m is None:
                raise DesignSpecError("J_ff_m, B_ff_m: a 'pd-ff' controller needs the decoupled inertia and friction to feed forward")
            self.J_ff_m, self.B_ff_m = _vec(J_ff_m, n, "J_ff_m"), _vec(B_ff_m, n, "B_ff_m")
        if kind == "pd-g" and gravity_model is None:
            raise DesignSpecError("gravity_model: a 'pd-g' controller needs a robot model to compensate gravity")
        self.gravity_model = gravity_model
        self._z = np.zeros(n)

    def reset(self) -> None:
        self._z = np.zeros(self.n)

    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        G = self.G
        e_m = G * (ref.q - q)
        ed_m = G * (ref.qd - qd)
        tau_m = self.Kp * e_m + self.Kd * ed_m + self.Ki * self._z
        if self.kind == "pd-ff":
            tau_m = tau_m + self.J_ff_m * G * ref.qdd + self.B_ff_m * G * ref.qd
        elif self.kind == "pd-g":
            assert self.gravity_model is not None
            tau_m = tau_m + self.gravity_model.gravload(q) / G
        out = self._saturate(tau_m)
        if self.kind == "pid":
            winding = (out != tau_m) & (np.sign(e_m) == np.sign(tau_m))
            self._z = self._z + np.where(winding, 0.0, self.dt * e_m)
        return out


class ComputedTorqueController(Controller):
    """Computed torque (inverse dynamics) on a controller model.

    ``tau = B(q)(qdd_d + Kd (qd_d - qd) + Kp (q_d - q)) + C(q, qd) qd + F(qd) + g(q)``,
    evaluated as one ``model.rne(q, qd, v)`` call, then ``tau_m = tau / G``.

    Parameters
    ----------
    model
        The controller's robot model (may differ from the plant: payload, friction, masses).
    Kp, Kd
        (n,) outer-loop gains, 1/s^2 and 1/s (``wn^2`` and ``2 zeta wn``).
    rate_hz, tau_m_max
        As :class:`Controller`.
    """

    kind = "ct"

    def __init__(self, model: Robot, Kp: Any, Kd: Any, rate_hz: float, tau_m_max: Any = None) -> None:
        super().__init__(model.n, rate_hz, model.gear_ratio, tau_m_max)
        self.model = model
        self.Kp, self.Kd = _vec(Kp, self.n, "Kp"), _vec(Kd, self.n, "Kd")

    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        v = ref.qdd + self.Kd * (ref.qd - qd) + self.Kp * (ref.q - q)
        return self._saturate(self.model.rne(q, qd, v) / self.G)
