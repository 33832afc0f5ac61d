"""Robot description: a serial arm as frozen, validated data.

A robot is a TOML file (see ``model/robots/*.toml`` and ``docs/robot-file.md``,
which lists every key). :func:`load_description` parses and validates it once
into a :class:`RobotDescription`; everything else in the workbench reads only
that object (the kinematics through :mod:`model.chain`).

Conventions (those of the Robotics Toolbox):

* Standard Denavit-Hartenberg (default): ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``;
  modified (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``.
  For a revolute joint ``theta_i = q_i + theta`` (offset), for a prismatic one
  ``d_i = q_i + d``; ``flip`` negates q.
* Centre of mass and inertia of link i are given in frame i (standard: at the
  far end of link i; modified: at joint i); inertia is about the centre of mass,
  ordered ``[Ixx, Iyy, Izz, Ixy, Iyz, Ixz]``.
* ``base`` (frame 0 in the world) and ``tool`` (tool frame in frame n) are
  ``{xyz, rpy}`` tables, ``R = Rz(yaw) Ry(pitch) Rx(roll)``; gravity is in the world frame.
* SI units only; a ``[units]`` table saying otherwise is refused.
* Motor data are on the motor side: ``motor angle = G * q``; rotor inertia
  ``Jm``, viscous friction ``B`` and Coulomb friction ``Tc`` reflect to the
  joint as ``G^2 Jm``, ``G^2 B`` and ``|G| Tc``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import re
import types
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .errors import InputError
from .limits import MAX_JOINTS, MAX_WAYPOINTS

__all__ = [
    "CONVENTIONS",
    "SI_UNITS",
    "LinkDescription",
    "RobotDescription",
    "RobotDescriptionError",
    "InertiaConsistencyWarning",
    "description_from_dict",
    "BUILTIN_DIR",
    "BUILTIN_ROBOTS",
    "JOINT_TYPES",
    "TORQUE_LIMIT_FROM_FILE",
    "TORQUE_LIMIT_FROM_RULE",
    "identifier_from_name",
    "pose_matrix",
    "rpy_matrix",
]

BUILTIN_DIR = Path(__file__).resolve().parent / "robots"
BUILTIN_ROBOTS: tuple[str, ...] = ("scara", "planar2r", "planar3r", "arm4", "spherical", "puma560", "panda", "ur5")
#: Where a motor's torque limit comes from: its ``torque_limit`` in the robot file, or the design's
#: default rule (``control_design.joint_model.TORQUE_LIMIT_RULE``) when the file states none.
TORQUE_LIMIT_FROM_FILE = "robot file"
TORQUE_LIMIT_FROM_RULE = "default rule"
JOINT_TYPES = ("revolute", "prismatic")
CONVENTIONS = ("standard", "modified", "urdf")
#: The accepted spellings of the ``[units]`` table: SI only, one entry per quantity.
SI_UNITS: dict[str, tuple[str, ...]] = {
    "length": ("m",),
    "angle": ("rad",),
    "mass": ("kg",),
    "time": ("s",),
    "force": ("N",),
    "torque": ("N m", "N.m", "Nm"),
    "inertia": ("kg m^2", "kg.m2", "kg m2", "kg*m^2"),
    "velocity": ("m/s",),
    "angular_velocity": ("rad/s",),
    "acceleration": ("m/s^2", "m/s2"),
    "viscous_friction": ("N m s/rad", "N.m.s/rad"),
}


class RobotDescriptionError(InputError):
    """A robot description is invalid; the message names file, link, field, value and expectation."""


class InertiaConsistencyWarning(UserWarning):
    """A link inertia is positive semi-definite but breaks the triangle inequality."""


@dataclass(frozen=True)
class LinkDescription:
    """One link and its joint, base to tip. Units: m, rad, kg, kg m^2, N m s/rad, N m."""

    joint: str
    a: float
    alpha: float
    d: float
    theta: float
    mass: float = 0.0
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[float, float, float, float, float, float] = (0.0,) * 6
    motor_inertia: float = 0.0
    gear_ratio: float = 1.0
    viscous_friction: float = 0.0
    coulomb_friction: tuple[float, float] = (0.0, 0.0)
    qlim: tuple[float, float] | None = None
    name: str = ""
    # Rotor body for motor_model="full": the rotor of motor i is carried by link i-1
    # (the base for i = 1), spins about its joint axis, mass rotor_mass (kg) at the
    # joint-i origin. Its inertia about the spin axis is motor_inertia.
    rotor_mass: float = 0.0
    # Continuous torque rating of the motor (N m, motor side); None when the file states none.
    torque_limit: float | None = None
    # The joint coordinate enters negated (theta = -q + theta, or d = -q + d), as the Robotics Toolbox's flip.
    flip: bool = False
    # Convention "urdf" only (a, alpha, d, theta are then 0 and unused): the joint frame's pose in the
    # previous link frame (link 0: frame 0, the robot base), a row-major 4x4 homogeneous transform as
    # 16 floats, and the unit joint axis in the joint frame. Link frame i is the joint frame moved by
    # the joint; com and inertia (about the com) are in link frame i.
    origin: tuple[float, ...] | None = None
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    @property
    def is_revolute(self) -> bool:
        return self.joint == "revolute"

    @property
    def inertia_matrix(self) -> np.ndarray:
        """(3, 3) inertia about the centre of mass, frame i axes, kg m^2."""
        ixx, iyy, izz, ixy, iyz, ixz = self.inertia
        return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


@dataclass(frozen=True)
class RobotDescription:
    """A serial arm: DH links, gravity and metadata; validated on construction."""

    name: str
    links: tuple[LinkDescription, ...]
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    rest: tuple[float, ...] | None = None
    description: str = ""
    source: str = ""
    path: str = ""
    # "standard" (A_i = Rz(theta) Tz(d) Tx(a) Rx(alpha)), "modified" (Craig: A_i = Rx(alpha_{i-1})
    # Tx(a_{i-1}) Rz(theta) Tz(d), com and inertia in frame i at joint i) or "urdf" (see LinkDescription.origin).
    convention: str = "standard"
    # Fixed poses as row-major 4x4 transforms (16 floats), None = identity: frame 0 in the world (base),
    # the tool frame in the tip frame (tool), and for "urdf" the tip link's frame in the last moving
    # link frame (tip: the fixed joints after the last moving one, merged). gravity is in the world frame.
    base: tuple[float, ...] | None = None
    tool: tuple[float, ...] | None = None
    tip: tuple[float, ...] | None = None
    extra: Mapping[str, Any] = field(default_factory=lambda: types.MappingProxyType({}), compare=False, hash=False)

    @property
    def n(self) -> int:
        return len(self.links)

    @property
    def identifier(self) -> str:
        """A C- and file-safe identifier derived from :attr:`name` (e.g. ``"Puma 560 (Unimation)"`` ->
        ``"Puma_560_Unimation"``): ASCII letters, digits and ``_``, never empty, never starting with a digit."""
        return identifier_from_name(self.name)

    @property
    def tasks(self) -> tuple[Mapping[str, Any], ...]:
        """The ``[[tasks]]`` entries of the file, validated (name, waypoints, segment_time, labels, description)."""
        return tuple(self.extra.get("tasks", ()))

    @property
    def T_base(self) -> np.ndarray:
        """(4, 4) pose of frame 0 in the world frame."""
        return pose_matrix(self.base)

    @property
    def T_tool(self) -> np.ndarray:
        """(4, 4) pose of the tool frame in the tip frame (DH frame n)."""
        return pose_matrix(self.tool)

    @property
    def q_rest(self) -> np.ndarray:
        """Rest configuration (m or rad per joint); zeros if the file gives none."""
        return np.zeros(self.n) if self.rest is None else np.array(self.rest, dtype=float)

    def torque_limit_source(self, i: int) -> str:
        """Where motor ``i``'s (0-based) torque limit comes from: :data:`TORQUE_LIMIT_FROM_FILE` or :data:`TORQUE_LIMIT_FROM_RULE`."""
        return TORQUE_LIMIT_FROM_RULE if self.links[i].torque_limit is None else TORQUE_LIMIT_FROM_FILE

    @property
    def joint_types(self) -> str:
        """One letter per joint, 'R' or 'P' (e.g. 'RRPR' for the SCARA)."""
        return "".join("R" if link.is_revolute else "P" for link in self.links)

    @property
    def qlim(self) -> np.ndarray:
        """(2, n) joint limits; +-inf where a link states none."""
        lo = [-math.inf if lk.qlim is None else lk.qlim[0] for lk in self.links]
        hi = [math.inf if lk.qlim is None else lk.qlim[1] for lk in self.links]
        return np.array([lo, hi])

    def digest(self) -> str:
        """SHA-256 of the physical content (not name/path/metadata): the cache key of generated code."""
        payload = {
            "convention": self.convention, "base": self.base, "tool": self.tool, "tip": self.tip,
            "gravity": self.gravity,
            "links": [
                {k: v for k, v in dataclasses.asdict(lk).items() if k not in ("name", "qlim", "torque_limit")}
                for lk in self.links
            ],
        }
        text = json.dumps(payload, sort_keys=True, default=float)
        return hashlib.sha256(text.encode()).hexdigest()


def identifier_from_name(name: str) -> str:
    """A C- and file-safe identifier from any text: runs of other characters become one ``_``.

    ``"Puma 560 (Unimation)"`` -> ``"Puma_560_Unimation"``; ``"6-axis"`` -> ``"r_6_axis"``; ``"?"`` -> ``"robot"``.
    """
    ident = re.sub(r"[^A-Za-z0-9]+", "_", name).strip("_")
    if not ident:
        return "robot"
    return f"r_{ident}" if ident[0].isdigit() else ident


def pose_matrix(pose: Sequence[float] | None) -> np.ndarray:
    """(4, 4) homogeneous transform from 16 row-major floats; identity for None."""
    return np.eye(4) if pose is None else np.array(pose, dtype=float).reshape(4, 4)


def rpy_matrix(rpy: Sequence[float]) -> np.ndarray:
    """(3, 3) rotation ``Rz(yaw) Ry(pitch) Rx(roll)`` of ``rpy = [roll, pitch, yaw]`` (rad), as URDF."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


# --------------------------------------------------------------------------- parsing

_TOP_REQUIRED = ("name", "links")
_TOP_OPTIONAL = ("gravity", "rest", "description", "source", "units", "tasks", "convention", "base", "tool")
_LINK_REQUIRED = ("joint", "a", "alpha", "d", "theta")
_LINK_OPTIONAL = (
    "mass", "com", "inertia", "motor_inertia", "gear_ratio", "viscous_friction",
    "coulomb_friction", "qlim", "name", "rotor_mass", "torque_limit", "source", "flip", "inertia_note",
)
_POSE_KEYS = ("xyz", "rpy")
_TASK_REQUIRED = ("name", "waypoints")
_TASK_OPTIONAL = ("segment_time", "labels", "description")


class _Where:
    """Builds error messages that name the file, the link and the field."""

    def __init__(self, path: str) -> None:
        self.path = path or "<dict>"

    def fail(self, link: int | None, fieldname: str, value: Any, expected: str) -> RobotDescriptionError:
        where = f"{self.path}"
        if link is not None:
            where += f", link {link + 1}"
        return RobotDescriptionError(f"{where}: field '{fieldname}' = {value!r}: expected {expected}")


def _number(w: _Where, link: int | None, name: str, value: Any, *, nonneg: bool = False, nonzero: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise w.fail(link, name, value, "a number")
    x = float(value)
    if not math.isfinite(x):
        raise w.fail(link, name, value, "a finite number")
    if nonneg and x < 0:
        raise w.fail(link, name, value, "a number >= 0")
    if nonzero and x == 0:
        raise w.fail(link, name, value, "a non-zero number")
    return x


def _vector(w: _Where, link: int | None, name: str, value: Any, size: int) -> tuple[float, ...]:
    if not isinstance(value, (list, tuple)) or len(value) != size:
        raise w.fail(link, name, value, f"a list of {size} numbers")
    return tuple(_number(w, link, f"{name}[{i}]", v) for i, v in enumerate(value))


def _check_keys(w: _Where, link: int | None, data: Mapping[str, Any], required: Sequence[str], optional: Sequence[str]) -> None:
    for key in required:
        if key not in data:
            raise w.fail(link, key, None, "this required key (it is missing)")
    for key in data:
        if key not in required and key not in optional:
            allowed = ", ".join((*required, *optional))
            raise w.fail(link, key, data[key], f"one of the known keys ({allowed}); this key is unknown")


def _inertia(w: _Where, link: int, value: Any, note: str | None = None) -> tuple[float, ...]:
    """The six inertia entries, positive semi-definite; a warning if they break the triangle inequality,
    unless the file acknowledges it in the link's ``inertia_note`` (published data kept as given)."""
    inertia = _vector(w, link, "inertia", value, 6)
    ixx, iyy, izz, ixy, iyz, ixz = inertia
    matrix = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    scale = max(1.0, float(np.abs(matrix).max()))
    eig = np.linalg.eigvalsh(matrix)
    if eig.min() < -1e-12 * scale:
        raise w.fail(link, "inertia", value, f"a positive semi-definite inertia (its eigenvalues are {eig.round(12).tolist()})")
    tol = 1e-12 * scale
    if eig[0] + eig[1] < eig[2] - tol and not note:
        warnings.warn(
            f"{w.path}, link {link + 1}: field 'inertia' = {list(value)!r} breaks the triangle inequality "
            f"(principal moments {eig.round(9).tolist()}): no rigid body has it; using it as given",
            InertiaConsistencyWarning, stacklevel=4,
        )
    return inertia


def _link(w: _Where, i: int, data: Any) -> LinkDescription:
    if not isinstance(data, Mapping):
        raise w.fail(i, "links", data, "a table of link fields")
    _check_keys(w, i, data, _LINK_REQUIRED, _LINK_OPTIONAL)
    joint = data["joint"]
    if joint not in JOINT_TYPES:
        raise w.fail(i, "joint", joint, "'revolute' or 'prismatic'")
    kw: dict[str, Any] = {"joint": joint}
    for key in ("a", "alpha", "d", "theta"):
        kw[key] = _number(w, i, key, data[key])
    kw["mass"] = _number(w, i, "mass", data.get("mass", 0.0), nonneg=True)
    kw["com"] = _vector(w, i, "com", data.get("com", [0.0, 0.0, 0.0]), 3)
    note = data.get("inertia_note")
    if note is not None and not (isinstance(note, str) and note.strip()):
        raise w.fail(i, "inertia_note", note, "a non-empty text saying why the inertia is kept as given")
    kw["inertia"] = _inertia(w, i, data.get("inertia", [0.0] * 6), note)
    kw["motor_inertia"] = _number(w, i, "motor_inertia", data.get("motor_inertia", 0.0), nonneg=True)
    kw["gear_ratio"] = _number(w, i, "gear_ratio", data.get("gear_ratio", 1.0), nonzero=True)
    kw["viscous_friction"] = _number(w, i, "viscous_friction", data.get("viscous_friction", 0.0), nonneg=True)
    tc = data.get("coulomb_friction", 0.0)
    if isinstance(tc, (list, tuple)):
        pos, neg = _vector(w, i, "coulomb_friction", tc, 2)
        if pos < 0 or neg > 0:
            raise w.fail(i, "coulomb_friction", tc, "[Tc_pos, Tc_neg] with Tc_pos >= 0 and Tc_neg <= 0")
    else:
        pos = _number(w, i, "coulomb_friction", tc, nonneg=True)
        neg = -pos
    kw["coulomb_friction"] = (pos + 0.0, neg + 0.0)  # + 0.0 turns -0.0 into 0.0: one digest per physics
    if "qlim" in data:
        lo, hi = _vector(w, i, "qlim", data["qlim"], 2)
        if not lo < hi:
            raise w.fail(i, "qlim", data["qlim"], "[lower, upper] with lower < upper")
        kw["qlim"] = (lo, hi)
    if "name" in data:
        if not isinstance(data["name"], str):
            raise w.fail(i, "name", data["name"], "a string")
        kw["name"] = data["name"]
    kw["rotor_mass"] = _number(w, i, "rotor_mass", data.get("rotor_mass", 0.0), nonneg=True)
    if "torque_limit" in data:
        limit = _number(w, i, "torque_limit", data["torque_limit"])
        if limit <= 0:
            raise w.fail(i, "torque_limit", data["torque_limit"], "a motor torque rating > 0 (N m)")
        kw["torque_limit"] = limit
    if "flip" in data:
        if not isinstance(data["flip"], bool):
            raise w.fail(i, "flip", data["flip"], "true or false")
        kw["flip"] = data["flip"]
    return LinkDescription(**kw)


def _pose(w: _Where, key: str, value: Any) -> tuple[float, ...] | None:
    """``{xyz = [...], rpy = [...]}`` (m, rad) as 16 row-major floats; None for the identity."""
    if not isinstance(value, Mapping):
        raise w.fail(None, key, value, "a table {xyz = [x, y, z], rpy = [roll, pitch, yaw]} (m, rad)")
    for k in value:
        if k not in _POSE_KEYS:
            raise w.fail(None, f"{key}.{k}", value[k], "one of the known keys (xyz, rpy); this key is unknown")
    xyz = _vector(w, None, f"{key}.xyz", value.get("xyz", [0.0, 0.0, 0.0]), 3)
    rpy = _vector(w, None, f"{key}.rpy", value.get("rpy", [0.0, 0.0, 0.0]), 3)
    if not any(xyz) and not any(rpy):
        return None
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(rpy)
    T[:3, 3] = xyz
    return tuple(float(v) + 0.0 for v in T.ravel())  # + 0.0: no -0.0, one digest per pose


def _units(w: _Where, value: Any) -> Mapping[str, str]:
    if not isinstance(value, Mapping):
        raise w.fail(None, "units", value, "a table of quantity = SI unit")
    for key, unit in value.items():
        if key not in SI_UNITS:
            raise w.fail(None, f"units.{key}", unit, f"one of the known quantities ({', '.join(SI_UNITS)}); this key is unknown")
        if unit not in SI_UNITS[key]:
            spellings = " or ".join(repr(u) for u in SI_UNITS[key])
            raise w.fail(None, f"units.{key}", unit, f"the SI unit {spellings}: robot files are in SI units only")
    return dict(value)


def _task(w: _Where, k: int, data: Any, links: Sequence[LinkDescription], names: set[str]) -> Mapping[str, Any]:
    where = f"tasks[{k + 1}]"
    if not isinstance(data, Mapping):
        raise w.fail(None, where, data, "a [[tasks]] table")
    for key in _TASK_REQUIRED:
        if key not in data:
            raise w.fail(None, f"{where}.{key}", None, "this required key (it is missing)")
    for key in data:
        if key not in _TASK_REQUIRED and key not in _TASK_OPTIONAL:
            allowed = ", ".join((*_TASK_REQUIRED, *_TASK_OPTIONAL))
            raise w.fail(None, f"{where}.{key}", data[key], f"one of the known keys ({allowed}); this key is unknown")
    name = data["name"]
    if not isinstance(name, str) or not name.strip():
        raise w.fail(None, f"{where}.name", name, "a non-empty string")
    if name in names:
        raise w.fail(None, f"{where}.name", name, "a task name not used by another [[tasks]] entry")
    names.add(name)
    rows = data["waypoints"]
    if not isinstance(rows, list) or len(rows) < 2:
        raise w.fail(None, f"{where}.waypoints", rows, f"a list of at least 2 joint vectors of {len(links)} values")
    if len(rows) > MAX_WAYPOINTS:
        raise RobotDescriptionError(f"{w.path}: {where}.waypoints: {len(rows)} waypoints: more than the waypoint "
                                    f"limit of {MAX_WAYPOINTS}")
    waypoints = []
    for r, row in enumerate(rows, 1):
        vec = _vector(w, None, f"{where}.waypoints[{r}]", row, len(links))
        for j, (x, link) in enumerate(zip(vec, links)):
            if link.qlim is not None and not link.qlim[0] <= x <= link.qlim[1]:
                raise w.fail(j, f"{where}.waypoints[{r}]", x, f"a joint value within qlim [{link.qlim[0]}, {link.qlim[1]}]")
        waypoints.append(vec)
    out: dict[str, Any] = {"name": name, "waypoints": tuple(waypoints)}
    segment_time = _number(w, None, f"{where}.segment_time", data.get("segment_time", 3.0))
    if segment_time <= 0:
        raise w.fail(None, f"{where}.segment_time", data["segment_time"], "a duration > 0 (s)")
    out["segment_time"] = segment_time
    labels = data.get("labels", [f"waypoint {r}" for r in range(len(rows))])
    if not isinstance(labels, list) or len(labels) != len(rows) or not all(isinstance(x, str) for x in labels):
        raise w.fail(None, f"{where}.labels", labels, f"a list of {len(rows)} strings, one per waypoint")
    out["labels"] = tuple(labels)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise w.fail(None, f"{where}.description", description, "a string")
    out["description"] = description
    return types.MappingProxyType(out)


def description_from_dict(data: Mapping[str, Any], path: str = "") -> RobotDescription:
    """Validate a parsed TOML document (or an equivalent dict) into a :class:`RobotDescription`.

    Raises
    ------
    RobotDescriptionError
        Naming the file, the link (1-based), the field, the value and what was expected.
    """
    w = _Where(path)
    if not isinstance(data, Mapping):
        raise w.fail(None, "<document>", data, "a TOML table")
    _check_keys(w, None, data, _TOP_REQUIRED, _TOP_OPTIONAL)
    name = data["name"]
    if not isinstance(name, str) or not name.strip():
        raise w.fail(None, "name", name, "a non-empty string")
    convention = data.get("convention", "standard")
    if convention not in ("standard", "modified"):
        raise w.fail(None, "convention", convention, "'standard' or 'modified' (URDF robots are read from a .urdf file)")
    raw_links = data["links"]
    if not isinstance(raw_links, list) or not raw_links:
        raise w.fail(None, "links", raw_links, "at least one [[links]] table")
    if len(raw_links) > MAX_JOINTS:
        raise RobotDescriptionError(f"{w.path}: {len(raw_links)} links: more than the joint-count limit of {MAX_JOINTS}")
    links = tuple(_link(w, i, lk) for i, lk in enumerate(raw_links))
    gravity = _vector(w, None, "gravity", data.get("gravity", [0.0, 0.0, -9.81]), 3)
    rest = None
    if "rest" in data:
        rest = _vector(w, None, "rest", data["rest"], len(links))
        for i, (value, link) in enumerate(zip(rest, links)):
            if link.qlim is not None and not link.qlim[0] <= value <= link.qlim[1]:
                raise w.fail(i, "rest", value, f"a rest position within qlim [{link.qlim[0]}, {link.qlim[1]}]")
    for key in ("description", "source"):
        if key in data and not isinstance(data[key], str):
            raise w.fail(None, key, data[key], "a string")
    base = _pose(w, "base", data["base"]) if "base" in data else None
    tool = _pose(w, "tool", data["tool"]) if "tool" in data else None
    extra: dict[str, Any] = {}
    if "units" in data:
        extra["units"] = _units(w, data["units"])
    if "tasks" in data:
        if not isinstance(data["tasks"], list):
            raise w.fail(None, "tasks", data["tasks"], "a list of [[tasks]] tables")
        names: set[str] = set()
        extra["tasks"] = tuple(_task(w, k, t, links, names) for k, t in enumerate(data["tasks"]))
    return RobotDescription(
        name=name, links=links, gravity=gravity, rest=rest,  # type: ignore[arg-type]
        description=data.get("description", ""), source=data.get("source", ""),
        path=str(path), convention=convention, base=base, tool=tool,
        extra=types.MappingProxyType(extra),
    )
