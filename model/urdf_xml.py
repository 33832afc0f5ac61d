"""The URDF elements a serial model needs, read from an already parsed (and guarded) XML tree.

:func:`parse_robot` turns the ``<robot>`` element into frozen records: each ``<link>``
with its ``<inertial>``, each ``<joint>`` with its type, parent and child, ``<origin>``
(4, 4), ``<axis>``, ``<limit>``, ``<mimic>`` and ``<dynamics>``, as the URDF
specification (ROS wiki, ``urdf/XML``) defines them: ``rpy`` is roll-pitch-yaw about the
fixed axes, ``R = Rz(yaw) Ry(pitch) Rx(roll)``; a missing ``<origin>`` is the identity, a
missing ``<axis>`` is ``1 0 0``. Visuals, collisions, meshes, transmissions and Gazebo tags
are not read. This reader is plain ElementTree and NumPy, so listing and loading URDF
robots starts in milliseconds; :mod:`model.urdf` builds the chain and checks the values.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .description import RobotDescriptionError, rpy_matrix

__all__ = ["UrdfDynamics", "UrdfInertial", "UrdfJoint", "UrdfLimit", "UrdfLink", "UrdfMimic", "UrdfRobot", "parse_robot"]


@dataclass(frozen=True)
class UrdfInertial:
    """``<inertial>``: ``origin`` (4, 4) of the centre-of-mass frame in the link frame (None: identity),
    ``mass`` (kg; None: no ``<mass>``), ``inertia`` (3, 3) about the com in that frame (None: no ``<inertia>``)."""

    origin: np.ndarray | None
    mass: float | None
    inertia: np.ndarray | None


@dataclass(frozen=True)
class UrdfLink:
    name: str
    inertial: UrdfInertial | None


@dataclass(frozen=True)
class UrdfLimit:
    """``<limit>``: bounds (rad or m), effort (N m or N) and velocity; None where the attribute is absent."""

    lower: float | None
    upper: float | None
    effort: float | None
    velocity: float | None


@dataclass(frozen=True)
class UrdfMimic:
    joint: str
    multiplier: float
    offset: float


@dataclass(frozen=True)
class UrdfDynamics:
    """``<dynamics>``: the attributes' text as written (None: absent); :mod:`model.urdf` reads the numbers."""

    damping: str | None
    friction: str | None


@dataclass(frozen=True)
class UrdfJoint:
    """``<joint>``: ``origin`` (4, 4) of the joint frame in the parent link frame (None: identity), ``axis`` (3,)."""

    name: str
    type: str | None
    parent: str
    child: str
    origin: np.ndarray | None
    axis: np.ndarray
    limit: UrdfLimit | None
    mimic: UrdfMimic | None
    dynamics: UrdfDynamics | None


@dataclass(frozen=True)
class UrdfRobot:
    name: str
    links: tuple[UrdfLink, ...]
    joints: tuple[UrdfJoint, ...]


class _Reader:
    """Number parsing with errors that name the file, the element and the attribute."""

    def __init__(self, path: str) -> None:
        self.path = path

    def fail(self, where: str, what: str) -> RobotDescriptionError:
        return RobotDescriptionError(f"{self.path}, {where}: {what}")

    def name(self, element: Any, kind: str) -> str:
        name = element.get("name")
        if not name:
            raise self.fail(f"a <{kind}>", "has no name attribute: every <link> and <joint> needs one")
        return name

    def number(self, element: Any, attribute: str, where: str, default: float | None = None) -> float | None:
        text = element.get(attribute)
        if text is None:
            return default
        try:
            return float(text)
        except ValueError:
            raise self.fail(where, f"<{element.tag} {attribute}={text!r}>: expected a number") from None

    def vector(self, element: Any, attribute: str, where: str, default: str) -> np.ndarray:
        text = element.get(attribute, default)
        try:
            values = [float(v) for v in text.split()]
        except ValueError:
            values = []
        if len(values) != 3:
            raise self.fail(where, f"<{element.tag} {attribute}={text!r}>: expected three numbers")
        return np.array(values)

    def origin(self, element: Any, where: str) -> np.ndarray | None:
        if element is None:
            return None
        T = np.eye(4)
        T[:3, :3] = rpy_matrix(self.vector(element, "rpy", where, "0 0 0"))
        T[:3, 3] = self.vector(element, "xyz", where, "0 0 0")
        return T

    def inertial(self, element: Any, where: str) -> UrdfInertial | None:
        if element is None:
            return None
        mass = element.find("mass")
        inertia = element.find("inertia")
        I = None
        if inertia is not None:
            keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            absent = [k for k in keys if inertia.get(k) is None]
            if absent:
                raise self.fail(where, f"<inertia> without {', '.join(absent)}: expected all of {', '.join(keys)}")
            ixx, ixy, ixz, iyy, iyz, izz = (self.number(inertia, k, where) for k in keys)
            I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=float)
        return UrdfInertial(origin=self.origin(element.find("origin"), f"{where} <inertial>"),
                            mass=None if mass is None else self.number(mass, "value", where, 0.0), inertia=I)

    def joint(self, element: Any) -> UrdfJoint:
        name = self.name(element, "joint")
        where = f"joint {name!r}"
        ends = {}
        for role in ("parent", "child"):
            node = element.find(role)
            if node is None or not node.get("link"):
                raise self.fail(where, f"no <{role} link=...>: every joint needs a parent and a child link")
            ends[role] = node.get("link")
        axis = element.find("axis")
        limit = element.find("limit")
        mimic = element.find("mimic")
        dynamics = element.find("dynamics")
        return UrdfJoint(
            name=name, type=element.get("type"), parent=ends["parent"], child=ends["child"],
            origin=self.origin(element.find("origin"), where),
            axis=np.array([1.0, 0.0, 0.0]) if axis is None else self.vector(axis, "xyz", where, "1 0 0"),
            limit=None if limit is None else UrdfLimit(*(self.number(limit, k, where)
                                                         for k in ("lower", "upper", "effort", "velocity"))),
            mimic=None if mimic is None else UrdfMimic(str(mimic.get("joint")), self.number(mimic, "multiplier", where, 1.0),
                                                      self.number(mimic, "offset", where, 0.0)),
            dynamics=None if dynamics is None else UrdfDynamics(dynamics.get("damping"), dynamics.get("friction")),
        )


def parse_robot(root: Any, path: str) -> UrdfRobot:
    """The links and joints of a URDF ``<robot>`` element (an ElementTree element); ``path`` names errors.

    Raises
    ------
    RobotDescriptionError
        A link or joint without a name, a joint without parent or child, a number that is not one,
        an ``<origin>`` or ``<axis>`` that is not three numbers, an ``<inertia>`` missing a component.
    """
    reader = _Reader(path)
    links = []
    for element in root.findall("link"):
        name = reader.name(element, "link")
        links.append(UrdfLink(name=name, inertial=reader.inertial(element.find("inertial"), f"link {name!r}")))
    joints = tuple(reader.joint(element) for element in root.findall("joint"))
    return UrdfRobot(name=str(root.get("name", "")), links=tuple(links), joints=joints)
