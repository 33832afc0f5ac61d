"""The motor-side P-PI cascade (Modelica's ``RobotR3.Components.Controller``) as a sampled controller.

Per joint, on the rotor angle ``q_m`` and speed ``qd_m`` (the motor side: for an
elastic gear the rotor's own states, else ``G q``) and the joint-side reference::

    e_v = G qd_ref + kp (G q_ref - q_m) - qd_m           speed error, rad/s (motor side)
    x  <- x + dt e_v / ti                                 PI integrator (forward Euler, one period)
    i_ref = ks (x + e_v)                                  current demand, A
    u = k i_ref                                           torque demand, N m (k: torque constant, 1 if none)

``kp`` 1/s, ``ks`` A s/rad, ``ti`` s (``[cascade]`` of the robot file). The plant's
current loop (:mod:`model.drive_train`) makes the motor torque follow ``u``. The
MSL controller is continuous; sampled at a rate far above the speed loop's
crossover its result approaches it (the r3's test states by how much).
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from model.robot import Robot

from .controllers import Controller, _vec
from .errors import DesignSpecError
from .laws import NO_LIMIT, ControlLaw
from .reference import Reference

__all__ = ["CascadeController", "cascade_fingerprint", "cascade_from_robot", "cascade_law"]

#: The law's parameter inputs, in input order (``dt`` the period, s, a scalar).
_PARAMETERS = ("kp", "ks", "ti", "torque_constant", "gear_ratio", "dt")


def cascade_law(n: int) -> ControlLaw:
    """The cascade of ``n`` joints as a :class:`~control_design.laws.ControlLaw` of kind ``'cascade'`` (the law the
    compiled closed loop runs, :mod:`closed_loop.kernel`): the module docstring's equations, operation for
    operation as :meth:`CascadeController.update_motor`.

    Signals ``q_m``, ``qd_m`` (rotor angle and speed, motor side, rad, rad/s), ``q_d``, ``qd_d`` (reference, joint
    side); parameters ``kp`` (1/s), ``ks`` (A s/rad), ``ti`` (s), ``torque_constant`` (N m/A), ``gear_ratio``, ``dt``
    (s); state ``z`` (the PI integrator ``x``, rad/s); outputs ``tau_m`` (N m, before saturation) and ``z_next``.
    """
    sym = {name: ca.SX.sym(name, n) for name in ("q_m", "qd_m", "q_d", "qd_d", *_PARAMETERS[:-1], "z")}
    dt = ca.SX.sym("dt")
    qm, qdm, q_d, qd_d, z = (sym[k] for k in ("q_m", "qd_m", "q_d", "qd_d", "z"))
    kp, ks, ti, k, G = (sym[name] for name in _PARAMETERS[:-1])
    e = G * qd_d + kp * (G * q_d - qm) - qdm
    tau_m = k * ks * (z + e)
    z_next = z + dt * e / ti
    signals = ("q_m", "qd_m", "q_d", "qd_d")
    params = [*((name, sym[name]) for name in _PARAMETERS[:-1]), ("dt", dt)]
    inputs = [(name, sym[name]) for name in signals] + params + [("z", z)]
    function = ca.Function("cascade", [s for _, s in inputs], [tau_m, z_next], [name for name, _ in inputs],
                           ["tau_m", "z_next"])
    return ControlLaw("cascade", function, signals, tuple((name, int(s.numel())) for name, s in params), ("z",))


def cascade_fingerprint() -> str:
    """SHA-256 of this module: editing the law invalidates its compiled code."""
    return hashlib.sha256(Path(__file__).read_bytes()).hexdigest()


class CascadeController(Controller):
    """P-PI cascade per joint on the motor side; ``update_motor`` takes the rotor states (module docstring)."""

    kind = "cascade"
    #: The closed loops hand this controller the rotor angles and speeds (``update_motor``).
    measures_motor = True

    def __init__(self, kp: Any, ks: Any, ti: Any, gear_ratio: Any, torque_constant: Any, rate_hz: float,
                 tau_m_max: Any = None) -> None:
        n = int(np.size(gear_ratio))
        super().__init__(n, rate_hz, gear_ratio, tau_m_max)
        self.kp, self.ks, self.ti = _vec(kp, n, "kp"), _vec(ks, n, "ks"), _vec(ti, n, "ti")
        self.k = _vec(torque_constant, n, "torque_constant")
        for name, v in (("kp", self.kp), ("ks", self.ks), ("ti", self.ti), ("torque_constant", self.k)):
            if np.any(v <= 0):
                raise DesignSpecError(f"expected values > 0, got {v.tolist()}", parameter=name)
        self.x = np.zeros(n)

    def reset(self) -> None:
        """Integrators to zero."""
        self.x = np.zeros(self.n)

    def _error(self, qm: np.ndarray, qdm: np.ndarray, ref: Reference) -> np.ndarray:
        return self.G * ref.qd + self.kp * (self.G * ref.q - qm) - qdm

    def holding_state(self, qm: np.ndarray, qdm: np.ndarray, ref: Reference, tau_m: np.ndarray) -> np.ndarray:
        """(n,) the integrators (rad/s) whose first output at rotor angles ``qm``, speeds ``qdm`` is ``tau_m`` (N m)."""
        return np.asarray(tau_m, dtype=float) / (self.k * self.ks) - self._error(qm, qdm, ref)

    def hold_from(self, qm: np.ndarray, qdm: np.ndarray, ref: Reference, tau_m: np.ndarray) -> None:
        """Set the integrators so that the first output is ``tau_m`` (N m): the loop starts in equilibrium."""
        self.x = self.holding_state(qm, qdm, ref, tau_m)

    def parameter_values(self) -> dict[str, np.ndarray]:
        """The parameter inputs of :func:`cascade_law` and its saturation (``tau_m_max``, :data:`NO_LIMIT` without
        limits), by name, in input order."""
        limit = np.full(self.n, NO_LIMIT) if self.tau_m_max is None else np.asarray(self.tau_m_max, dtype=float)
        return {"kp": self.kp.copy(), "ks": self.ks.copy(), "ti": self.ti.copy(), "torque_constant": self.k.copy(),
                "gear_ratio": np.asarray(self.G, dtype=float).copy(), "dt": np.array([self.dt]),
                "tau_m_max": limit.copy()}

    def update_motor(self, t: float, q: np.ndarray, qd: np.ndarray, qm: np.ndarray, qdm: np.ndarray,
                     ref: Reference) -> np.ndarray:
        """Torque demands (n,), N m, from the rotor angles ``qm`` (rad) and speeds ``qdm`` (rad/s)."""
        e = self._error(np.asarray(qm, dtype=float), np.asarray(qdm, dtype=float), ref)
        u = self.k * self.ks * (self.x + e)
        self.x = self.x + self.dt * e / self.ti
        if self.tau_m_max is not None:
            u = np.clip(u, -self.tau_m_max, self.tau_m_max)
        return u

    def update(self, t: float, q: np.ndarray, qd: np.ndarray, ref: Reference) -> np.ndarray:
        """As :meth:`update_motor` with a rigid gear's rotor, ``G q`` and ``G qd``."""
        return self.update_motor(t, q, qd, self.G * np.asarray(q, dtype=float), self.G * np.asarray(qd, dtype=float),
                                 ref)


def cascade_from_robot(robot: Robot, rate_hz: float | None = None) -> CascadeController:
    """The cascade of ``robot``'s ``[cascade]`` table (gains, rate) and its torque constants.

    Raises DesignSpecError if the robot file has no ``[cascade]`` table with ``kp``, ``ks`` and ``ti``.
    """
    desc = robot.description
    table = desc.extra.get("cascade") if desc.extra is not None else None
    if not table or any(key not in table for key in ("kp", "ks", "ti")):
        raise DesignSpecError(f"{desc.name}: the cascade controller needs the robot file's [cascade] table with "
                              f"kp, ks and ti", parameter="cascade")
    rate = rate_hz if rate_hz is not None else float(table.get("rate", 1000.0))
    k = [1.0 if lk.torque_constant is None else lk.torque_constant for lk in desc.links]
    return CascadeController(table["kp"], table["ks"], table["ti"], robot.gear_ratio, k, rate)
