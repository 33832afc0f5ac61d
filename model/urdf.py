"""Robots from URDF: the serial chain of a URDF file as a :class:`~model.description.RobotDescription`.

A URDF is read by :mod:`model.urdf_xml` (links, joints and inertials; meshes never
loaded) after the bytes have passed ``defusedxml`` with document type declarations refused, so
neither an external entity (a local file, a URL) nor an entity bomb is ever
expanded; files above :data:`MAX_URDF_BYTES` and trees with more than
:data:`MAX_MOVING_JOINTS` moving joints on the chain are refused before any work (both are
the limits of :mod:`model.limits`, the same as for a robot TOML).

The model is the chain from ``base_link`` (default: the URDF root) to
``tip_link`` (default: the only leaf). Its links use the ``"urdf"`` convention
of :class:`~model.description.LinkDescription`: link i's ``origin`` is the pose
of joint frame i in link frame i-1 (fixed joints before it merged in), its
``axis`` the unit joint axis in the joint frame. What hangs rigidly on a moving
link, through fixed joints or through off-chain joints held at 0 (fingers, a
gripper), is lumped into that link's mass, centre of mass and inertia, as
Pinocchio's ``buildReducedModel`` does. The fixed joints after the last moving
joint up to ``tip_link`` become the description's ``tip``.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence
from xml.etree.ElementTree import ParseError

import numpy as np

from .description import (DRIVE_TRAIN_DEFAULTS, FROM_DEFAULT, FROM_FILE, FROM_URDF, RobotDescription, RobotDescriptionError, _check_keys,
                          _description, _link, _Where)
from .limits import MAX_FILE_BYTES as MAX_URDF_BYTES
from .limits import MAX_JOINTS as MAX_MOVING_JOINTS
from .limits import read_bounded
from .urdf_xml import UrdfRobot, parse_robot

__all__ = [
    "MAX_URDF_BYTES",
    "MAX_MOVING_JOINTS",
    "MOTOR_KEYS",
    "NO_LIMIT",
    "UrdfChain",
    "ChainJoint",
    "read_urdf",
    "serial_chain",
    "description_from_urdf",
    "description_from_urdf_toml",
]

#: The keys a ``[joints.NAME]`` table may hold: the motor keys of a ``[[links]]`` table, and its source.
MOTOR_KEYS = ("motor_inertia", "gear_ratio", "viscous_friction", "coulomb_friction", "torque_limit", "rotor_mass", "source",
              "velocity_limit", "acceleration_limit", "inertia_note", *DRIVE_TRAIN_DEFAULTS)
#: A ``<limit velocity>`` at or above this is "no limit": the value :mod:`model.urdf_export` writes for a joint whose
#: description states none (URDF requires the attribute and a finite number).
NO_LIMIT = sys.float_info.max
_MOVING = ("revolute", "continuous", "prismatic")
_REFUSED = {
    "floating": "a floating joint (6 degrees of freedom) is not a serial-arm joint",
    "planar": "a planar joint (3 degrees of freedom) is not a serial-arm joint",
}
_TOML_KEYS = ("name", "urdf", "base_link", "tip_link", "joints", "gravity", "rest", "description", "source",
              "units", "tasks", "base", "tool", "cascade")
_PASSED_ON = ("name", "gravity", "rest", "description", "source", "units", "tasks", "base", "tool", "cascade")


@dataclass(frozen=True)
class ChainJoint:
    """One moving joint of the chain with the rigid body it moves (URDF joint frame and link frame).

    ``origin`` (4, 4) is the joint frame in the previous moving link's frame (fixed joints merged);
    ``axis`` the unit axis in the joint frame; ``mass`` (kg), ``com`` (m) and ``inertia`` (3, 3, kg m^2,
    about the com) are the lumped body in the child link frame; ``damping`` (N m s/rad or N s/m) and
    ``friction`` (N m or N) the joint-side ``<dynamics>``, ``velocity`` the ``<limit velocity>`` (rad/s or
    m/s; None: not stated, or 0, or :data:`NO_LIMIT`).
    """

    name: str
    joint: str
    origin: np.ndarray
    axis: np.ndarray
    qlim: tuple[float, float] | None
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    damping: float = 0.0
    friction: float = 0.0
    velocity: float | None = None


@dataclass(frozen=True)
class UrdfChain:
    """The serial chain ``base_link`` -> ``tip_link`` of a URDF; ``tip`` (4, 4) is the tip link in the last link frame."""

    robot_name: str
    base_link: str
    tip_link: str
    joints: tuple[ChainJoint, ...]
    tip: np.ndarray


# --------------------------------------------------------------------------- reading


def read_urdf(path: str | Path) -> UrdfRobot:
    """Parse a URDF file safely into its links and joints (:class:`~model.urdf_xml.UrdfRobot`; no mesh read).

    Raises
    ------
    RobotDescriptionError
        The file is missing, larger than :data:`MAX_URDF_BYTES`, declares a document type
        (entities), is not well-formed XML or not a ``<robot>``, or an element of it cannot be read
        (:func:`~model.urdf_xml.parse_robot`).
    """
    import defusedxml
    import defusedxml.ElementTree as safe_et

    path = Path(path)
    data = read_bounded(path, "URDF", RobotDescriptionError)
    try:
        root = safe_et.fromstring(data, forbid_dtd=True, forbid_entities=True, forbid_external=True)
    except (defusedxml.DTDForbidden, defusedxml.EntitiesForbidden, defusedxml.ExternalReferenceForbidden):
        raise RobotDescriptionError(
            f"{path}: refused: the file declares a document type (<!DOCTYPE ...>), whose entities could read "
            "other files or expand without bound; a URDF needs none"
        ) from None
    except ParseError as exc:
        raise RobotDescriptionError(f"{path}: not well-formed XML: {exc}") from None
    if root.tag != "robot":
        raise RobotDescriptionError(f"{path}: the root element is <{root.tag}>: expected a URDF <robot>")
    return parse_robot(root, str(path))


def _unit_axis(path: Path, joint: Any) -> np.ndarray:
    axis = np.asarray(joint.axis, dtype=float)
    norm = float(np.linalg.norm(axis)) if axis.shape == (3,) else 0.0
    if not (math.isfinite(norm) and norm > 1e-9):
        raise RobotDescriptionError(f"{path}, joint {joint.name!r}: axis {axis.tolist()}: expected a non-zero axis xyz")
    return axis / norm


def _origin(path: Path, what: str, origin: Any) -> np.ndarray:
    T = np.eye(4) if origin is None else np.asarray(origin, dtype=float)
    if not np.all(np.isfinite(T)):
        raise RobotDescriptionError(f"{path}, {what}: origin {T[:3, 3].tolist()}: expected finite xyz and rpy")
    return T


def _body(path: Path, link: Any) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass, com and inertia about the com of one URDF link, in its link frame."""
    inertial = link.inertial
    if inertial is None:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    mass = 0.0 if inertial.mass is None else float(inertial.mass)
    T = _origin(path, f"link {link.name!r} <inertial>", inertial.origin)
    I = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, dtype=float)
    if not (math.isfinite(mass) and mass >= 0 and np.all(np.isfinite(I))):
        raise RobotDescriptionError(f"{path}, link {link.name!r}: <inertial> mass {mass!r}: expected a finite mass >= 0 "
                                    "and a finite inertia")
    R = T[:3, :3]
    return mass, T[:3, 3].copy(), R @ I @ R.T


def _lump(bodies: Sequence[tuple[float, np.ndarray, np.ndarray]]) -> tuple[float, np.ndarray, np.ndarray]:
    """One rigid body from several in one frame: total mass, common com, inertia about it (parallel axes)."""
    mass = sum(m for m, _, _ in bodies)
    com = sum((m * c for m, c, _ in bodies), np.zeros(3)) / mass if mass > 0 else np.zeros(3)
    inertia = np.zeros((3, 3))
    for m, c, I in bodies:
        d = c - com
        inertia += I + m * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return mass, com, inertia


def _limit(path: Path, joint: Any) -> tuple[float, float] | None:
    if joint.type == "continuous" or joint.limit is None:
        return None
    lo = 0.0 if joint.limit.lower is None else float(joint.limit.lower)
    hi = 0.0 if joint.limit.upper is None else float(joint.limit.upper)
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
        raise RobotDescriptionError(f"{path}, joint {joint.name!r}: <limit lower={lo!r} upper={hi!r}>: expected "
                                    "finite lower <= upper")
    return None if lo == hi else (lo, hi)


def _dynamics(path: Path, joint: Any) -> tuple[float, float]:
    """The joint-side ``<dynamics damping friction>`` (0 where absent), each finite and >= 0."""
    dyn = joint.dynamics
    if dyn is None:
        return 0.0, 0.0
    values = []
    for name in ("damping", "friction"):
        raw = getattr(dyn, name)
        try:
            value = 0.0 if raw is None else float(raw)
        except (TypeError, ValueError):
            value = math.nan
        if not (math.isfinite(value) and value >= 0):
            raise RobotDescriptionError(f"{path}, joint {joint.name!r}: <dynamics {name}={raw!r}>: expected a finite "
                                        "number >= 0")
        values.append(value + 0.0)
    return values[0], values[1]


def _velocity(path: Path, joint: Any) -> float | None:
    """The ``<limit velocity>`` (rad/s or m/s); None where absent, 0 (a common "not given") or :data:`NO_LIMIT`."""
    raw = None if joint.limit is None else joint.limit.velocity
    if raw is None:
        return None
    try:
        value = float(raw)
    except (TypeError, ValueError):
        value = math.nan
    if not (value >= 0 and not math.isnan(value)):
        raise RobotDescriptionError(f"{path}, joint {joint.name!r}: <limit velocity={raw!r}>: expected a number >= 0")
    return None if value == 0 or value >= NO_LIMIT else value


def _listing(names: Sequence[str], limit: int = 20) -> str:
    names = sorted(names)
    shown = ", ".join(names[:limit])
    return shown + (f", ... ({len(names)} in all)" if len(names) > limit else "")


def serial_chain(robot: Any, path: str | Path, base_link: str | None = None, tip_link: str | None = None) -> UrdfChain:
    """The chain ``base_link`` -> ``tip_link`` of a parsed URDF, off-chain bodies lumped (joints at 0).

    Raises
    ------
    RobotDescriptionError
        Naming the joint or link: duplicate names, a link with two parents (a closed chain), no single
        root, a floating or planar joint, a mimic joint on the chain, an unknown joint type, an unknown
        ``base_link``/``tip_link``, a branching tree without ``tip_link``, or too many moving joints on the chain
        (the first of these stops the reading); then every bad origin, axis, limit, dynamics or
        inertial of the chain's joints and bodies, all in one error (its ``problems``).
    """
    path = Path(path)
    links = {}
    for link in robot.links:
        if link.name in links:
            raise RobotDescriptionError(f"{path}, link {link.name!r}: defined twice: expected unique link names")
        links[link.name] = link
    joints: dict[str, Any] = {}
    parent_of: dict[str, Any] = {}
    children: dict[str, list[Any]] = {name: [] for name in links}
    for joint in robot.joints:
        if joint.name in joints:
            raise RobotDescriptionError(f"{path}, joint {joint.name!r}: defined twice: expected unique joint names")
        joints[joint.name] = joint
        for role, name in (("parent", joint.parent), ("child", joint.child)):
            if name not in links:
                raise RobotDescriptionError(f"{path}, joint {joint.name!r}: {role} link {name!r} is not a <link> of the file")
        if joint.type in _REFUSED:
            raise RobotDescriptionError(f"{path}, joint {joint.name!r}: type {joint.type!r} refused: {_REFUSED[joint.type]}")
        if joint.type not in (*_MOVING, "fixed"):
            raise RobotDescriptionError(f"{path}, joint {joint.name!r}: type {joint.type!r}: expected revolute, "
                                        "continuous, prismatic or fixed")
        if joint.child in parent_of:
            raise RobotDescriptionError(
                f"{path}, joint {joint.name!r}: link {joint.child!r} already has the parent joint "
                f"{parent_of[joint.child].name!r}: a closed chain, which a serial model cannot represent")
        parent_of[joint.child] = joint
        children[joint.parent].append(joint)
    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        detail = f"roots {_listing(roots)}" if roots else "every link has a parent (a loop)"
        raise RobotDescriptionError(f"{path}: expected one root link, found {detail}")
    base = roots[0] if base_link is None else base_link
    if base not in links:
        raise RobotDescriptionError(f"{path}: base_link {base!r} is not a link of the file; the links are {_listing(links)}")
    below = _subtree(base, children)
    if tip_link is None:
        leaves = [name for name in below if not children[name]]
        if len(leaves) != 1:
            raise RobotDescriptionError(f"{path}: the tree branches below {base!r} into the leaves {_listing(leaves)}: "
                                        "name the end of the arm with tip_link")
        tip_link = leaves[0]
    elif tip_link not in below:
        where = "is not a link of the file" if tip_link not in links else f"is not below base_link {base!r}"
        raise RobotDescriptionError(f"{path}: tip_link {tip_link!r} {where}; the links below {base!r} are {_listing(below)}")
    path_joints = []
    name = tip_link
    while name != base:
        path_joints.append(parent_of[name])
        name = parent_of[name].parent
    path_joints.reverse()
    # the limit is the model's (its build grows like n^2): a humanoid's file holds more joints than one arm
    if sum(j.type in _MOVING for j in path_joints) > MAX_MOVING_JOINTS:
        raise RobotDescriptionError(f"{path}: more than {MAX_MOVING_JOINTS} moving joints: above the joint-count limit "
                                    f"(on the chain {base!r} -> {tip_link!r})")
    on_chain = {j.name for j in path_joints}
    for joint in path_joints:
        if joint.mimic is not None and joint.type != "fixed":
            raise RobotDescriptionError(f"{path}, joint {joint.name!r}: a mimic joint (it follows {joint.mimic.joint!r}) "
                                        "cannot be a joint of the serial model")

    # The tree's shape is settled; the values of its joints and links (origins, axes, limits, inertials)
    # are independent of each other: every bad one is collected, then raised together.
    problems: list[str] = []

    def checked(check: Any, default: Any, *args: Any) -> Any:
        try:
            return check(*args)
        except RobotDescriptionError as exc:
            problems.extend(exc.problems)
            return default

    def origin(joint: Any) -> np.ndarray:
        return checked(_origin, np.eye(4), path, f"joint {joint.name!r}", joint.origin)

    def hanging(link_name: str, T: np.ndarray) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """The bodies of ``link_name`` and of everything off the chain below it, in the frame where it sits at T."""
        out = []
        stack = [(link_name, T)]
        while stack:
            current, T_cur = stack.pop()
            m, c, I = checked(_body, (0.0, np.zeros(3), np.zeros((3, 3))), path, links[current])
            R = T_cur[:3, :3]
            out.append((m, R @ c + T_cur[:3, 3], R @ I @ R.T))
            for joint in children[current]:
                if joint.name not in on_chain:
                    stack.append((joint.child, T_cur @ origin(joint)))
        return out

    chain: list[ChainJoint] = []
    pending = np.eye(4)  # fixed joints since the last moving joint, in its link frame
    bodies: list[tuple[float, np.ndarray, np.ndarray]] = []
    spec: dict[str, Any] | None = None

    def close_link() -> None:
        if spec is not None:
            chain.append(ChainJoint(**spec, **dict(zip(("mass", "com", "inertia"), _lump(bodies)))))

    for joint in path_joints:
        T = pending @ origin(joint)
        if joint.type == "fixed":
            pending = T
            if spec is not None:
                bodies += hanging(joint.child, T)
            continue
        close_link()
        spec = dict(name=joint.name, joint="prismatic" if joint.type == "prismatic" else "revolute", origin=T,
                    axis=checked(_unit_axis, np.array([0.0, 0.0, 1.0]), path, joint),
                    qlim=checked(_limit, None, path, joint),
                    **dict(zip(("damping", "friction"), checked(_dynamics, (0.0, 0.0), path, joint))),
                    velocity=checked(_velocity, None, path, joint))
        pending = np.eye(4)
        bodies = hanging(joint.child, np.eye(4))
    close_link()
    if problems:
        raise RobotDescriptionError.collected(problems, str(path))
    if not chain:
        raise RobotDescriptionError(f"{path}: no moving joint between {base!r} and {tip_link!r}: expected at least one")
    # descendants of the tip that hang below it were collected by hanging(); the tip pose is what is pending
    return UrdfChain(robot_name=str(robot.name), base_link=base, tip_link=tip_link, joints=tuple(chain), tip=pending)


def _subtree(base: str, children: Mapping[str, list[Any]]) -> list[str]:
    out, stack = [], [base]
    while stack:
        name = stack.pop()
        out.append(name)
        stack.extend(j.child for j in children[name])
    return out


# --------------------------------------------------------------------------- description


class _JointWhere(_Where):
    """Error messages that name the URDF joint (``[joints.NAME]``) instead of a link number."""

    def __init__(self, path: str, names: Sequence[str], problems: list[str] | None = None) -> None:
        super().__init__(path, problems)
        self.names = names

    def fail(self, link: int | None, fieldname: str, value: Any, expected: str) -> RobotDescriptionError:
        if link is None:
            return super().fail(link, fieldname, value, expected)
        return RobotDescriptionError(f"{self.path}, joint {self.names[link]!r}: field '{fieldname}' = {value!r}: "
                                     f"expected {expected}")


def _pose16(T: np.ndarray) -> tuple[float, ...] | None:
    return None if np.array_equal(T, np.eye(4)) else tuple(float(v) for v in np.asarray(T).ravel())


def _urdf_motor_fields(cj: ChainJoint, table: Mapping[str, Any]) -> dict[str, Any]:
    """The URDF's joint-side friction and velocity limit as robot-file fields (motor side, through the gear ratio).

    ``<dynamics damping>`` D becomes ``viscous_friction = D / G^2`` and ``friction`` F ``coulomb_friction =
    F / |G|`` (both directions), so that the model's joint friction ``G^2 B qd + |G| Tc sign(qd)`` is the URDF's;
    a key the robot file states for the joint wins. ``G^2`` is the product ``G * G`` the model reflects with, and
    the quotient is correctly rounded, so reflecting it back gives D to the last bit, or its neighbouring double
    where no motor-side double reflects to D exactly (one unit in the last place: 2.2e-16 relative at most).
    A gear ratio the file states wrongly is reported by the link check; the conversion then uses 1.
    """
    g = table.get("gear_ratio", 1.0)
    G = float(g) if isinstance(g, (int, float)) and not isinstance(g, bool) and math.isfinite(g) and g != 0 else 1.0
    out: dict[str, Any] = {}
    if cj.damping:
        out["viscous_friction"] = cj.damping / (G * G)
    if cj.friction:
        out["coulomb_friction"] = cj.friction / abs(G)
    if cj.velocity is not None:
        out["velocity_limit"] = cj.velocity
    return out


def description_from_urdf(urdf_path: str | Path, data: Mapping[str, Any] | None = None,
                          path: str | Path | None = None) -> RobotDescription:
    """A :class:`RobotDescription` (convention ``"urdf"``) from a URDF file and optional TOML data.

    Parameters
    ----------
    urdf_path
        The URDF file.
    data
        The parsed TOML of a robot file that points at the URDF (``urdf = ...``): ``name``,
        ``base_link``, ``tip_link``, ``[joints.NAME]`` motor data, ``gravity`` (m/s^2, world frame),
        ``rest``, ``tool``, ... ; None for a bare URDF (name from ``<robot name>``).
    path
        The file named in error messages (the TOML file; default ``urdf_path``).

    Raises
    ------
    RobotDescriptionError
        One line naming the file, the joint or key, the value and what was expected.
    """
    urdf_path = Path(urdf_path)
    where = str(path if path is not None else urdf_path)
    w = _Where(where)
    desc = None
    with w.collect():  # the URDF or its chain is unusable: nothing further to check
        desc = _urdf_description(w, urdf_path, dict(data or {}))
    w.raise_problems()
    assert desc is not None
    return desc


def _urdf_description(w: _Where, urdf_path: Path, data: dict[str, Any]) -> RobotDescription | None:
    """:func:`description_from_urdf` with every independent problem recorded in ``w``; None when there is any.

    Raises at once when the URDF cannot be read or its chain cannot be formed (nothing further to check).
    """
    _check_keys(w, None, data, (), _TOML_KEYS, what="one of the known keys of a URDF robot file")
    ends: dict[str, str | None] = {}
    for key in ("base_link", "tip_link"):
        ends[key] = data.get(key) if isinstance(data.get(key), str) else None
        if key in data and ends[key] is None:
            w.problems.append(str(w.fail(None, key, data[key], "a URDF link name (a string)")))
    robot = read_urdf(urdf_path)
    chain = serial_chain(robot, urdf_path, ends["base_link"], ends["tip_link"])
    names = [j.name for j in chain.joints]
    motors = data.get("joints", {})
    if not isinstance(motors, Mapping):
        w.problems.append(str(w.fail(None, "joints", motors, "a table of [joints.NAME] tables")))
        motors = {}
    good_motors: dict[str, Mapping[str, Any]] = {}
    for name, table in motors.items():
        if name not in names:
            w.problems.append(str(w.fail(None, f"joints.{name}", table, f"a moving joint of the chain ({', '.join(names)}); "
                                                                         f"{name!r} is not one")))
        elif not isinstance(table, Mapping):
            w.problems.append(str(w.fail(None, f"joints.{name}", table, "a table of motor data")))
        else:
            start = len(w.problems)
            _check_keys(w, None, table, (), MOTOR_KEYS, prefix=f"joints.{name}.", what="one of the motor keys")
            if len(w.problems) == start:
                good_motors[name] = table
    jw = _JointWhere(w.path, names, w.problems)
    links = []
    for i, cj in enumerate(chain.joints):
        ixx, iyy, izz, ixy, iyz, ixz = (cj.inertia[0, 0], cj.inertia[1, 1], cj.inertia[2, 2], cj.inertia[0, 1],
                                        cj.inertia[1, 2], cj.inertia[0, 2])
        table = good_motors.get(cj.name, {})
        fields: dict[str, Any] = {
            "joint": cj.joint, "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "name": cj.name,
            "mass": cj.mass, "com": [float(v) for v in cj.com], "inertia": [float(v) for v in (ixx, iyy, izz, ixy, iyz, ixz)],
            **_urdf_motor_fields(cj, table), **table,
        }
        if cj.qlim is not None:
            fields["qlim"] = list(cj.qlim)
        link = _link(jw, i, fields)
        if link is not None:
            sources = tuple(FROM_FILE if key in table else FROM_URDF if value else FROM_DEFAULT
                            for key, value in (("viscous_friction", cj.damping), ("coulomb_friction", cj.friction)))
            links.append(dataclasses.replace(link, origin=tuple(float(v) for v in cj.origin.ravel()),
                                             axis=tuple(float(v) for v in cj.axis), friction_source=sources))
    # Top-level keys (gravity, rest, tool, tasks, ...) are checked by the TOML reader on a DH skeleton of
    # the same joints; its links are then replaced by the URDF ones.
    skeleton = {key: data[key] for key in _PASSED_ON if key in data}
    skeleton.setdefault("name", chain.robot_name)
    skeleton["links"] = [{"joint": cj.joint, "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0,
                          **({"qlim": list(cj.qlim)} if cj.qlim is not None else {})} for cj in chain.joints]
    desc = _description(w, skeleton, w.path)
    if desc is None or w.problems:
        return None
    return dataclasses.replace(desc, links=tuple(links), convention="urdf", tip=_pose16(chain.tip))


def description_from_urdf_toml(data: Mapping[str, Any], path: str | Path) -> RobotDescription:
    """A :class:`RobotDescription` from a robot TOML file whose ``urdf`` key names a URDF (relative to the TOML)."""
    urdf = data["urdf"]
    if not isinstance(urdf, str) or not urdf:
        raise _Where(str(path)).fail(None, "urdf", urdf, "the path of a URDF file, relative to this file")
    urdf_path = Path(path).resolve().parent / urdf
    if not urdf_path.is_file():
        state = "is a directory" if urdf_path.is_dir() else "does not exist"
        raise _Where(str(path)).fail(None, "urdf", urdf, f"the path of a URDF file relative to this file; {urdf_path} {state}")
    return description_from_urdf(urdf_path, {k: v for k, v in data.items() if k != "urdf"}, path)
