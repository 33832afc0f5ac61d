"""The limits a retimed motion keeps: motor torques (through the gears), joint speeds and accelerations.

Motor torque limits are motor side (``tau_m_max``, N m); the retime bounds the joint torque of the full
inverse dynamics by ``torque_margin * |G| tau_m_max`` (the margin leaves the rest of each motor's torque to
the feedback of the loop that tracks the motion). Joint velocity and acceleration limits are joint side
(rad/s, rad/s^2 or m/s, m/s^2): the robot file's ``velocity_limit`` and ``acceleration_limit`` per link, or
values given here, each times a scale factor. A joint with none has no such bound.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from ..robot import Robot

__all__ = ["DEFAULT_TORQUE_MARGIN", "RetimeLimits", "retime_limits"]

Array = npt.NDArray[np.float64]

#: Share of each motor's torque limit the retimed motion may use (the rest is the tracking loop's).
DEFAULT_TORQUE_MARGIN = 0.9


@dataclass(frozen=True, eq=False)
class RetimeLimits:
    """Per-joint limits of a retime.

    Attributes
    ----------
    tau_m_max
        (n,) motor torque limits, N m, motor side.
    torque_margin
        Share of them the motion may use, in (0, 1].
    tau_max
        (n,) the joint-side torque bound ``torque_margin |G| tau_m_max``, N m or N.
    velocity, acceleration
        (n,) joint speed (rad/s or m/s) and acceleration (rad/s^2 or m/s^2) bounds; ``inf`` where none.
    velocity_source, acceleration_source
        (n,) where each comes from: ``"robot file"``, ``"given"`` or ``"none"`` (a scale factor is noted).
    """

    tau_m_max: Array
    torque_margin: float
    tau_max: Array
    velocity: Array
    acceleration: Array
    velocity_source: tuple[str, ...]
    acceleration_source: tuple[str, ...]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: every bound per joint (``None`` for no bound) and where it comes from."""
        def finite(a: Array) -> list[float | None]:
            return [float(v) if math.isfinite(v) else None for v in a]

        return {"tau_m_max": self.tau_m_max.tolist(), "torque_margin": self.torque_margin,
                "tau_max_joint": self.tau_max.tolist(), "velocity": finite(self.velocity),
                "velocity_source": list(self.velocity_source), "acceleration": finite(self.acceleration),
                "acceleration_source": list(self.acceleration_source)}


def _per_joint(value: Any, n: int, name: str, unit: str) -> Array:
    """A scalar or (n,) positive bound (``inf`` allowed: no bound) as an (n,) array; InputError naming ``name``."""
    arr = np.array(value, dtype=float).reshape(-1) if np.ndim(value) else np.full(n, float(value))
    if arr.shape != (n,):
        raise InputError(f"{name}: expected one value or {n} values (one per joint), got {arr.size}")
    if np.any(np.isnan(arr)) or np.any(arr <= 0.0):
        bad = next(float(v) for v in arr if not v > 0.0)
        raise InputError(f"{name}: expected limits > 0 {unit} (inf: none), got {bad!r}")
    return arr


def _scale(value: float, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or value <= 0.0:
        raise InputError(f"{name}: expected a finite factor > 0, got {value!r}")
    return float(value)


def retime_limits(robot: "Robot", tau_m_max: npt.ArrayLike, *, torque_margin: float = DEFAULT_TORQUE_MARGIN,
                  velocity_limit: npt.ArrayLike | None = None, acceleration_limit: npt.ArrayLike | None = None,
                  velocity_scale: float = 1.0, acceleration_scale: float = 1.0) -> RetimeLimits:
    """The limits of a retime of ``robot``.

    Parameters
    ----------
    robot
        The arm (gear ratios; the description's ``velocity_limit`` and ``acceleration_limit``).
    tau_m_max
        (n,) motor torque limits, N m, motor side (e.g. ``control_design.design_robot(robot).tau_m_max``: the
        robot file's ``torque_limit`` or the design's default rule).
    torque_margin
        Share of each motor limit the motion may use, in (0, 1] (default 0.9).
    velocity_limit, acceleration_limit
        Joint-side bounds, one value for every joint or (n,) (``inf``: none), instead of the robot file's.
    velocity_scale, acceleration_scale
        Factors (> 0) on the bounds in force (the file's or the given ones).

    Raises
    ------
    InputError
        Naming the argument: a margin outside (0, 1], a bound or factor that is not > 0, a wrong count.
    """
    n = robot.n
    tm = np.array(tau_m_max, dtype=float).reshape(-1)
    if tm.shape != (n,) or not np.all(np.isfinite(tm)) or np.any(tm <= 0.0):
        raise InputError(f"tau_m_max: expected {n} finite motor torque limits > 0 N m, got {tm.tolist()}")
    if isinstance(torque_margin, bool) or not isinstance(torque_margin, (int, float, np.integer, np.floating)) \
            or not (0.0 < float(torque_margin) <= 1.0):
        raise InputError(f"torque_margin: expected a share of the motor torque limits in (0, 1], got {torque_margin!r}")
    links = robot.description.links
    out = {}
    for name, given, scale, field, unit in (
            ("velocity", velocity_limit, velocity_scale, "velocity_limit", "rad/s or m/s"),
            ("acceleration", acceleration_limit, acceleration_scale, "acceleration_limit", "rad/s^2 or m/s^2")):
        factor = _scale(scale, f"{name}_scale")
        if given is None:
            stated = [getattr(lk, field) for lk in links]
            values = np.array([math.inf if v is None else v for v in stated])
            source = ["none" if v is None else "robot file" for v in stated]
        else:
            values = _per_joint(given, n, field, unit)
            source = ["given" if math.isfinite(v) else "none" for v in values]
        if factor != 1.0:
            source = [s if s == "none" else f"{s} x {factor:g}" for s in source]
        out[name] = (values * factor, tuple(source))
    margin = float(torque_margin)
    return RetimeLimits(tau_m_max=tm, torque_margin=margin, tau_max=margin * np.abs(robot.gear_ratio) * tm,
                        velocity=out["velocity"][0], acceleration=out["acceleration"][0],
                        velocity_source=out["velocity"][1], acceleration_source=out["acceleration"][1])
