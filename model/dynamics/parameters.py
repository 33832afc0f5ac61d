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
from typing import Any, NamedTuple, Sequence

import casadi as ca
import numpy as np

from ..arrays import finite_vector
from ..description import RobotDescription
from ..errors import InputError

__all__ = [
    "DynamicsParameters",
    "Payload",
    "ParameterLayout",
    "SymbolicParameters",
    "parameter_layout",
    "split_parameters",
    "inertia_matrix_sx",
]


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


def _payload(mass: Any, com: Any, inertia: Any) -> tuple[float, np.ndarray, np.ndarray]:
    """The payload fields checked: mass >= 0 kg, (3,) centre of mass, (6,) positive semi-definite inertia."""
    m = float(mass)
    if not np.isfinite(m) or m < 0:
        raise InputError(f"expected a finite number >= 0 kg, got {m!r}", parameter="mass")
    c = finite_vector(com, 3, "com")
    six = finite_vector(inertia, 6, "inertia")
    ixx, iyy, izz, ixy, iyz, ixz = six
    eig = np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))
    if eig[0] < -1e-12 * max(1.0, abs(eig).max()):
        raise InputError(f"expected a positive semi-definite inertia, got {six.tolist()} "
                         f"(eigenvalues {eig.tolist()})", parameter="inertia")
    return m, c, six


#: The friction fields: argument name, field, sign the values must have, the rule in words.
_FRICTION = (
    ("viscous", "viscous_friction", 1.0, ">= 0"),
    ("coulomb_pos", "coulomb_friction_pos", 1.0, ">= 0"),
    ("coulomb_neg", "coulomb_friction_neg", -1.0, "<= 0"),
)


def _friction(n: int, name: str, value: Any, sign: float, expect: str) -> np.ndarray:
    v = finite_vector(value, n, name)
    if np.any(sign * v < 0):
        raise InputError(f"expected values {expect}, got {v.tolist()}", parameter=name)
    return v


@dataclass(frozen=True, eq=False)
class Payload:
    """A rigid payload fixed to frame n (the tip frame: DH frame n of a DH table, body n of a urdf).

    Attributes
    ----------
    mass
        kg (0: no payload).
    com
        (3,) centre of mass in frame n, m.
    inertia
        (3, 3) inertia about the centre of mass, frame-n axes, kg m^2 (zeros: a point mass).
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def __post_init__(self) -> None:
        for name in ("com", "inertia"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def inertia6(self) -> np.ndarray:
        """(6,) ``[Ixx Iyy Izz Ixy Iyz Ixz]`` of :attr:`inertia`, kg m^2 (the order of ``with_payload``)."""
        I = self.inertia
        return np.array([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2]])


@dataclass(frozen=True, eq=False)
class DynamicsParameters:
    """An immutable value of the parameter vector ``p`` of one robot (layout :class:`ParameterLayout`).

    Every numeric dynamics method takes one (``p=``); changing a payload, friction or
    gravity makes a new value (:meth:`with_payload`, :meth:`with_friction`,
    :meth:`with_gravity`) and leaves this one and every model untouched.

    Parameters
    ----------
    layout
        The robot's parameter layout.
    vector
        (np,) values in layout order; checked field by field (payload mass >= 0 kg, a
        positive semi-definite payload inertia, viscous and Tc+ friction >= 0, Tc- <= 0,
        everything finite), a ValueError ``"p: <field>: ..."`` otherwise. Stored as a
        read-only copy.
    """

    layout: ParameterLayout
    vector: np.ndarray

    def __post_init__(self) -> None:
        lay = self.layout
        p = np.array(finite_vector(self.vector, lay.size, "p"), dtype=np.float64)
        sl = lay.slices
        try:
            _payload(p[sl["payload_mass"]][0], p[sl["payload_com"]], p[sl["payload_inertia"]])
            for name, field, sign, expect in _FRICTION:
                _friction(lay.n, name, p[sl[field]], sign, expect)
        except ValueError as exc:
            raise InputError(f"{exc}", parameter="p") from None
        p.flags.writeable = False
        object.__setattr__(self, "vector", p)

    @classmethod
    def defaults(cls, layout: ParameterLayout) -> "DynamicsParameters":
        """The description's values: no payload, its friction and gravity."""
        return cls(layout, layout.defaults)

    def __repr__(self) -> str:
        return f"DynamicsParameters({dict(zip(self.layout.names, self.vector.tolist()))!r})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, DynamicsParameters):
            return NotImplemented
        return self.layout.names == other.layout.names and bool(np.array_equal(self.vector, other.vector))

    __hash__ = None  # type: ignore[assignment]  # equal values, not identity; the vector is an array

    def field(self, name: str) -> np.ndarray:
        """A copy of one field (``payload_mass``, ``payload_com``, ``viscous_friction``, ..., ``gravity``)."""
        if name not in self.layout.slices:
            raise InputError(f"expected one of {', '.join(self.layout.slices)}, got {name!r}", parameter="field")
        return self.vector[self.layout.slices[name]].copy()

    @property
    def payload_mass(self) -> float:
        """Payload mass, kg."""
        return float(self.vector[self.layout.slices["payload_mass"]][0])

    @property
    def payload(self) -> Payload:
        """The payload: mass (kg), centre of mass (m) and inertia (kg m^2) in frame n."""
        v, sl = self.vector, self.layout.slices
        six = v[sl["payload_inertia"]]
        I = np.array([[six[0], six[3], six[5]], [six[3], six[1], six[4]], [six[5], six[4], six[2]]])
        return Payload(mass=float(v[sl["payload_mass"]][0]), com=v[sl["payload_com"]].copy(), inertia=I)

    @property
    def viscous_friction(self) -> np.ndarray:
        """(n,) motor-side viscous friction, N m s/rad."""
        return self.field("viscous_friction")

    @property
    def gravity(self) -> np.ndarray:
        """(3,) gravitational acceleration in the world frame W, m/s^2."""
        return self.field("gravity")

    def as_dict(self) -> dict[str, float]:
        """``{name: value}`` in layout order (the FMU parameter names)."""
        return dict(zip(self.layout.names, (float(v) for v in self.vector)))

    def _replace(self, values: dict[str, Any]) -> "DynamicsParameters":
        p = self.vector.copy()
        for field, value in values.items():
            p[self.layout.slices[field]] = value
        return DynamicsParameters(self.layout, p)

    def with_payload(self, mass: float, com: Sequence[float] = (0.0, 0.0, 0.0),
                     inertia: Sequence[float] = (0.0,) * 6) -> "DynamicsParameters":
        """A rigid payload fixed to frame n (replacing any other).

        Parameters
        ----------
        mass
            kg, >= 0 (0 removes the payload).
        com
            (3,) centre of mass in frame n, m.
        inertia
            (6,) ``[Ixx Iyy Izz Ixy Iyz Ixz]`` about the payload COM, frame-n axes, kg m^2 (zeros: point mass).
        """
        m, c, six = _payload(mass, com, inertia)
        return self._replace({"payload_mass": m, "payload_com": c, "payload_inertia": six})

    def with_friction(self, viscous: Any = None, coulomb_pos: Any = None,
                      coulomb_neg: Any = None) -> "DynamicsParameters":
        """Motor-side friction per joint: viscous (N m s/rad, >= 0), Coulomb Tc+ (>= 0) and Tc- (<= 0), N m.

        Arguments left as None keep this value's.
        """
        values = {}
        for (name, field, sign, expect), value in zip(_FRICTION, (viscous, coulomb_pos, coulomb_neg)):
            if value is not None:
                values[field] = _friction(self.layout.n, name, value, sign, expect)
        return self._replace(values)

    def with_gravity(self, gravity: Any) -> "DynamicsParameters":
        """Gravitational acceleration in the world frame W, (3,) m/s^2."""
        return self._replace({"gravity": finite_vector(gravity, 3, "gravity")})


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
