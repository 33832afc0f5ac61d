"""Computed torque: outer-loop design and the plant/controller model mismatch.

With an exact model, ``tau = B(q) v + C(q, qd) qd + F(qd) + g(q)`` and
``v = qdd_d + Kd e' + Kp e`` turn every joint into a double integrator
``qdd = v``: the error obeys ``e'' + Kd e' + Kp e = 0``. Each outer loop is
therefore designed as a :class:`~control_design.loops.JointLoop` on the plant
``1 / s^2`` (``J_m = 1``, ``B_m = 0``, ``G = 1``): ``Kp = wn^2`` (1/s^2),
``Kd = 2 zeta wn`` (1/s), with the same bandwidth/damping/phase-margin
specification, Bode and step analysis as the decentralised loops. Motor
torques are ``tau_m = tau / G`` (see
:class:`~control_design.controllers.ComputedTorqueController`).

Robustness: :class:`ModelMismatch` describes how the simulated plant differs
from the controller's model (a payload the controller does not know, scaled
friction, scaled link masses); :func:`plant_with_mismatch` builds that plant
as a second :class:`~model.robot.Robot`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from model.description import RobotDescription
from model.robot import Robot

from .decentralised import DEFAULT_BANDWIDTH, design_joint
from .errors import DesignSpecError
from .loops import JointLoop, JointPlant

__all__ = ["CT_KIND", "ModelMismatch", "outer_loop_plant", "design_outer_loops", "plant_with_mismatch"]

CT_KIND = "ct"


def outer_loop_plant(name: str = "", unit: str = "rad") -> JointPlant:
    """The double integrator ``qdd = v`` a computed-torque outer loop sees."""
    return JointPlant(J_m=1.0, B_m=0.0, G=1.0, name=name, unit=unit)


def design_outer_loops(robot: Robot, bandwidth: float = DEFAULT_BANDWIDTH, damping: float | None = None, *,
                       phase_margin: float | None = None, rate_hz: float | None = None) -> tuple[JointLoop, ...]:
    """One double-integrator outer loop per joint (same gains, each with its joint's name and unit).

    Parameters
    ----------
    robot
        Names and units of the joints.
    bandwidth, damping, phase_margin, rate_hz
        As :func:`control_design.decentralised.design_joint` (bandwidth in rad/s).
    """
    loops = []
    for i, link in enumerate(robot.description.links):
        plant = outer_loop_plant(link.name or f"joint{i + 1}", "rad" if link.is_revolute else "m")
        loops.append(design_joint(plant, CT_KIND, bandwidth, damping, phase_margin=phase_margin, rate_hz=rate_hz))
    return tuple(loops)


def _nonneg(value: float, name: str, unit: str) -> float:
    x = float(value)
    if not (math.isfinite(x) and x >= 0):
        raise DesignSpecError(f"expected a finite value >= 0{' ' + unit if unit else ''}, got {value!r}", parameter=name)
    return x


@dataclass(frozen=True)
class ModelMismatch:
    """How the simulated plant differs from the controller's model.

    Attributes
    ----------
    payload_mass
        Payload on the plant only, kg (point mass unless ``payload_inertia``).
    payload_com
        Its centre of mass in the last link frame, m.
    payload_inertia
        ``[Ixx Iyy Izz Ixy Iyz Ixz]`` about its centre of mass, kg m^2.
    friction_scale
        Plant motor friction (viscous and Coulomb) = this times the model's.
    link_mass_scale
        Plant link masses and inertias = this times the model's (centres of mass unchanged).
    """

    payload_mass: float = 0.0
    payload_com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    payload_inertia: tuple[float, float, float, float, float, float] = (0.0,) * 6
    friction_scale: float = 1.0
    link_mass_scale: float = 1.0

    def __post_init__(self) -> None:
        _nonneg(self.payload_mass, "payload", "kg")
        _nonneg(self.friction_scale, "friction_scale", "")
        if not (math.isfinite(self.link_mass_scale) and self.link_mass_scale > 0):
            raise DesignSpecError(f"expected a factor > 0, got {self.link_mass_scale!r}", parameter="link_mass_scale")

    @property
    def is_exact(self) -> bool:
        """True when plant and controller model are the same."""
        return self.payload_mass == 0.0 and self.friction_scale == 1.0 and self.link_mass_scale == 1.0

    def describe(self) -> str:
        """One line for reports."""
        if self.is_exact:
            return "exact model"
        parts = []
        if self.payload_mass:
            parts.append(f"{self.payload_mass:g} kg payload unknown to the controller")
        if self.friction_scale != 1.0:
            parts.append(f"plant friction x{self.friction_scale:g}")
        if self.link_mass_scale != 1.0:
            parts.append(f"plant link masses x{self.link_mass_scale:g}")
        return ", ".join(parts)


def _scaled_description(robot: Robot, scale: float) -> RobotDescription:
    desc = robot.description
    links = tuple(dataclasses.replace(lk, mass=lk.mass * scale, inertia=tuple(x * scale for x in lk.inertia))
                  for lk in desc.links)
    return dataclasses.replace(desc, links=links)


def _check_plant(plant: Robot, parameter: str, value: float, what: str) -> Robot:
    """``plant`` if, at rest, its inertia matrix is finite and positive definite in floating point and its gravity
    torque and viscous-friction rate are finite; else a :class:`DesignSpecError` naming the mismatch ``parameter``."""
    import numpy as np

    q = plant.q_rest
    problem = None
    with np.errstate(all="ignore"):  # an overflow is the finding here, not a warning
        B, g = plant.inertia(q), plant.gravload(q)
        G, B_m = plant.gear_ratio, plant.parameters.viscous_friction
        if not (np.all(np.isfinite(B)) and np.all(np.isfinite(g))):
            problem = "overflow (its inertia matrix or gravity torque is not finite)"
        else:
            try:
                np.linalg.cholesky(B)
                if not np.all(np.isfinite(np.linalg.solve(B, np.diag(G * G * B_m)))):
                    problem = "overflow (its friction rate B^-1 G^2 B_m is not finite)"
            except np.linalg.LinAlgError:
                problem = "singular: its inertia matrix is not positive definite in floating point"
    if problem is not None:
        raise DesignSpecError(f"{value:g}{what} makes the plant's dynamics at rest (q = {q.tolist()}) {problem}",
                              parameter=parameter)
    return plant


def plant_with_mismatch(robot: Robot, mismatch: ModelMismatch) -> Robot:
    """A new :class:`Robot` for the simulated plant: ``robot`` changed by ``mismatch``.

    The controller keeps using ``robot``; the payload and friction are the plant's
    parameters (``robot.parameters`` changed by ``with_payload``, ``with_friction``;
    without a mass scaling the plant shares ``robot``'s compiled model), the mass
    scaling a scaled description (compiled once, then cached).

    Raises
    ------
    DesignSpecError
        A mismatch so large that the plant's numbers overflow (``parameter`` names it): a scaled link mass or
        friction coefficient that is not finite, or an inertia matrix, gravity torque or friction rate at the
        rest configuration that is not (checked after each change, so the first one to overflow is named).
    """
    import numpy as np

    if mismatch.link_mass_scale == 1.0:
        plant = robot
    else:
        s = mismatch.link_mass_scale
        with np.errstate(all="ignore"):
            scaled = [x * s for lk in robot.description.links for x in (lk.mass, *lk.inertia)]
        if not np.all(np.isfinite(scaled)):
            raise DesignSpecError(f"{s:g} times the link masses and inertias is not finite", parameter="link_mass_scale")
        plant = _check_plant(Robot(_scaled_description(robot, s), motor_model=robot.motor_model),
                             "link_mass_scale", s, " times the link masses")
    params = robot.parameters  # the same layout for a scaled description
    if mismatch.payload_mass:
        params = params.with_payload(mismatch.payload_mass, mismatch.payload_com, mismatch.payload_inertia)
        _check_plant(plant.with_parameters(params), "payload_mass", mismatch.payload_mass, " kg of payload")
    if mismatch.friction_scale != 1.0:
        s = mismatch.friction_scale
        with np.errstate(all="ignore"):
            friction = [s * params.field(f) for f in ("viscous_friction", "coulomb_friction_pos", "coulomb_friction_neg")]
        if not all(np.all(np.isfinite(f)) for f in friction):
            raise DesignSpecError(f"{s:g} times the friction coefficients is not finite", parameter="friction_scale")
        params = params.with_friction(*friction)
        _check_plant(plant.with_parameters(params), "friction_scale", s, " times the friction")
    return plant.with_parameters(params)
