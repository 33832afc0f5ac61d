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


def plant_with_mismatch(robot: Robot, mismatch: ModelMismatch) -> Robot:
    """A new :class:`Robot` for the simulated plant: ``robot`` changed by ``mismatch``.

    The controller keeps using ``robot``; the payload and friction are the plant's
    parameters (``robot.parameters`` changed by ``with_payload``, ``with_friction``;
    without a mass scaling the plant shares ``robot``'s compiled model), the mass
    scaling a scaled description (compiled once, then cached).
    """
    if mismatch.link_mass_scale == 1.0:
        plant = robot
    else:
        plant = Robot(_scaled_description(robot, mismatch.link_mass_scale), motor_model=robot.motor_model)
    params = robot.parameters  # the same layout for a scaled description
    if mismatch.payload_mass:
        params = params.with_payload(mismatch.payload_mass, mismatch.payload_com, mismatch.payload_inertia)
    if mismatch.friction_scale != 1.0:
        s = mismatch.friction_scale
        params = params.with_friction(*(s * params.field(f) for f in ("viscous_friction", "coulomb_friction_pos",
                                                                       "coulomb_friction_neg")))
    return plant.with_parameters(params)

