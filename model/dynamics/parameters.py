"""The dynamic parameter vector ``p``: payload, friction and gravity.

These quantities change without regenerating code: they enter every dynamics
Function as the input ``p`` (and become FMU parameters). Link inertial data
stay constants (see ``docs/model-equations.md``). Layout, 1-based FMI-style
names::

    payload_mass                 kg
    payload_com[1..3]            m, frame n
    payload_inertia[1..6]        kg m^2 about the payload COM, frame-n axes, [Ixx Iyy Izz Ixy Iyz Ixz]
    viscous_friction[1..n]       N m s/rad, motor side
    coulomb_friction_pos[1..n]   N m, motor side, used when qd > 0
    coulomb_friction_neg[1..n]   N m, motor side, used when qd < 0 (<= 0)
    gravity[1..3]                m/s^2, world frame
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import casadi as ca
import numpy as np

from ..description import RobotDescription

__all__ = ["ParameterLayout", "SymbolicParameters", "parameter_layout", "split_parameters", "inertia_matrix_sx"]


class SymbolicParameters(NamedTuple):
    """The pieces of ``p`` as CasADi expressions (column vectors)."""

    payload_mass: Any
    payload_com: Any
    payload_inertia: Any
    viscous_friction: Any
    coulomb_friction_pos: Any
    coulomb_friction_neg: Any
    gravity: Any


@dataclass(frozen=True)
class ParameterLayout:
    """Names, defaults, units and slices of the parameter vector of one robot.

    Attributes
    ----------
    n
        Number of joints.
    names, descriptions, units
        One entry per scalar parameter, in vector order.
    defaults
        (np,) values from the robot description (no payload).
    slices
        Field name -> slice into ``p`` (fields as in :class:`SymbolicParameters`).
    """

    n: int
    names: tuple[str, ...]
    descriptions: tuple[str, ...]
    units: tuple[str, ...]
    defaults: np.ndarray
    slices: dict[str, slice]

    @property
    def size(self) -> int:
        """Length of ``p``."""
        return len(self.names)


_FIELDS = (
    # field, length (None = n), unit, description
    ("payload_mass", 1, "kg", "payload mass, rigidly fixed to frame n"),
    ("payload_com", 3, "m", "payload centre of mass in frame n"),
    ("payload_inertia", 6, "kg.m2", "payload inertia about its centre of mass, frame-n axes, [Ixx Iyy Izz Ixy Iyz Ixz]"),
    ("viscous_friction", None, "N.m.s/rad", "motor viscous friction (motor side)"),
    ("coulomb_friction_pos", None, "N.m", "motor Coulomb friction for positive joint velocity (motor side)"),
    ("coulomb_friction_neg", None, "N.m", "motor Coulomb friction for negative joint velocity (motor side, <= 0)"),
    ("gravity", 3, "m/s2", "gravitational acceleration in the world frame"),
)


def parameter_layout(desc: RobotDescription) -> ParameterLayout:
    """The parameter layout of ``desc`` with its defaults (no payload, friction and gravity from the file)."""
    n = desc.n
    values = {
        "payload_mass": [0.0],
        "payload_com": [0.0] * 3,
        "payload_inertia": [0.0] * 6,
        "viscous_friction": [lk.viscous_friction for lk in desc.links],
        "coulomb_friction_pos": [lk.coulomb_friction[0] for lk in desc.links],
        "coulomb_friction_neg": [lk.coulomb_friction[1] for lk in desc.links],
        "gravity": list(desc.gravity),
    }
    names: list[str] = []
    descriptions: list[str] = []
    units: list[str] = []
    defaults: list[float] = []
    slices: dict[str, slice] = {}
    for field, length, unit, text in _FIELDS:
        size = n if length is None else length
        start = len(names)
        if size == 1:
            names.append(field)
            descriptions.append(text)
        else:
            for k in range(size):
                names.append(f"{field}[{k + 1}]")
                descriptions.append(f"{text}, element {k + 1}")
        units.extend([unit] * size)
        defaults.extend(float(v) for v in values[field])
        slices[field] = slice(start, start + size)
    return ParameterLayout(
        n=n, names=tuple(names), descriptions=tuple(descriptions), units=tuple(units),
        defaults=np.array(defaults), slices=slices,
    )


def split_parameters(layout: ParameterLayout, p: Any) -> SymbolicParameters:
    """Cut a symbolic (or numeric) parameter vector ``p`` into its named pieces."""
    return SymbolicParameters(*(p[layout.slices[f]] for f in SymbolicParameters._fields))


def inertia_matrix_sx(six: Any) -> ca.SX:
    """(3, 3) symmetric inertia from ``[Ixx Iyy Izz Ixy Iyz Ixz]`` (symbolic or numeric)."""
    ixx, iyy, izz, ixy, iyz, ixz = (six[k] for k in range(6))
    return ca.vertcat(
        ca.horzcat(ixx, ixy, ixz),
        ca.horzcat(ixy, iyy, iyz),
        ca.horzcat(ixz, iyz, izz),
    )
