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

import contextlib
import dataclasses
import hashlib
import json
import math
import re
import types
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import numpy as np
import numpy.typing as npt

from .errors import InputError, closest, did_you_mean
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
    "DRIVE_TRAIN_DEFAULTS",
    "BUILTIN_ROBOTS",
    "JOINT_TYPES",
    "TORQUE_LIMIT_FROM_FILE",
    "TORQUE_LIMIT_FROM_RULE",
    "FROM_DEFAULT",
    "FROM_FILE",
    "FROM_URDF",
    "identifier_from_name",
    "pose_matrix",
    "rpy_matrix",
    "tr2rpy",
]

BUILTIN_DIR = Path(__file__).resolve().parent / "robots"
BUILTIN_ROBOTS: tuple[str, ...] = ("scara", "planar2r", "planar3r", "arm4", "spherical", "puma560", "panda", "ur5",
                                   "manutec_r3")
#: Where a motor's torque limit comes from: its ``torque_limit`` in the robot file, or the design's
#: default rule (``control_design.joint_model.TORQUE_LIMIT_RULE``) when the file states none.
TORQUE_LIMIT_FROM_FILE = "robot file"
TORQUE_LIMIT_FROM_RULE = "default rule"
#: Where a link's friction coefficients come from: its robot file, the URDF's ``<dynamics damping friction>``
#: (converted to the motor side through the gear ratio), or the default 0.
FROM_FILE = "robot file"
FROM_URDF = "URDF"
FROM_DEFAULT = "default"
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
    # Joint speed and acceleration limits (joint side: rad/s, rad/s^2 or m/s, m/s^2); None when none is stated.
    velocity_limit: float | None = None
    acceleration_limit: float | None = None
    # The joint coordinate enters negated (theta = -q + theta, or d = -q + d), as the Robotics Toolbox's flip.
    flip: bool = False
    # Convention "urdf" only (a, alpha, d, theta are then 0 and unused): the joint frame's pose in the
    # previous link frame (link 0: frame 0, the robot base), a row-major 4x4 homogeneous transform as
    # 16 floats, and the unit joint axis in the joint frame. Link frame i is the joint frame moved by
    # the joint; com and inertia (about the com) are in link frame i.
    origin: tuple[float, ...] | None = None
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    # Where viscous_friction and coulomb_friction come from: FROM_FILE, FROM_URDF or FROM_DEFAULT each.
    friction_source: tuple[str, str] = field(default=(FROM_DEFAULT, FROM_DEFAULT), compare=False)
    # The drive train (docs/robot-file.md, "Drive-train keys"; the plant: model/drive_train.py). An elastic gear
    # (gear_stiffness not None) is a spring-damper on the motor side between the rotor (angle q_m) and G q;
    # friction_side says where the friction acts on an elastic joint ("motor": on the rotor, with the motor-side
    # coefficients; "link": on the joint, reflected as |G| Tc and G^2 B); friction_peak is the break-away torque
    # over the sliding Coulomb torque (>= 1); a current loop (current_bandwidth not None) makes the motor torque
    # follow its demand by a second-order law, with back-EMF when armature_resistance is stated.
    gear_stiffness: float | None = None
    gear_damping: float = 0.0
    friction_side: str = "motor"
    friction_peak: float = 1.0
    torque_constant: float | None = None
    current_bandwidth: float | None = None
    current_damping: float = 1.0
    armature_resistance: float | None = None

    @property
    def is_elastic(self) -> bool:
        """Whether the gear is elastic (a spring-damper between rotor and gear, motor side)."""
        return self.gear_stiffness is not None

    @property
    def has_current_loop(self) -> bool:
        """Whether the motor torque follows its demand through a second-order current loop."""
        return self.current_bandwidth is not None

    @property
    def is_revolute(self) -> bool:
        return self.joint == "revolute"

    @property
    def inertia_matrix(self) -> np.ndarray:
        """(3, 3) inertia about the centre of mass, frame i axes, kg m^2."""
        ixx, iyy, izz, ixy, iyz, ixz = self.inertia
        return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


#: Joint names the URDF export gives its fixed joints (:mod:`model.urdf_export`).
_RESERVED_JOINT_NAMES = frozenset({"base_joint", "flange_joint", "tool_joint"})


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
    def joint_names(self) -> tuple[str, ...]:
        """One name per joint, for files and tables: the links' names when every link has one, they are
        unique and none is a name the URDF export reserves; else ``joint1`` .. ``jointN``."""
        names = tuple(lk.name for lk in self.links)
        if all(names) and len(set(names)) == len(names) and not _RESERVED_JOINT_NAMES & set(names):
            return names
        return tuple(f"joint{i}" for i in range(1, self.n + 1))

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
        """Rest configuration (m or rad per joint): the file's ``rest`` (within ``qlim``, checked when read), else the
        point of the joint box ``qlim`` nearest to zero (0 where a joint's range holds it, else its nearer limit).

        Everything that starts the arm somewhere reads this one property: ``manip info``, the FMU's start
        values, ``validate-fmu``, the workspace figure, the generic tour (and so ``track``) and ``teach``.
        """
        if self.rest is not None:
            return np.array(self.rest, dtype=float)
        lo, hi = self.qlim
        return np.clip(np.zeros(self.n), lo, hi) + 0.0  # + 0.0: no -0.0

    def friction_source(self, i: int) -> tuple[str, str]:
        """Where joint ``i``'s (0-based) viscous and Coulomb friction come from: :data:`FROM_FILE`,
        :data:`FROM_URDF` or :data:`FROM_DEFAULT` each."""
        return self.links[i].friction_source

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
                {k: v for k, v in dataclasses.asdict(lk).items()
                 if k not in _NOT_PHYSICS and not (k in DRIVE_TRAIN_DEFAULTS and v == DRIVE_TRAIN_DEFAULTS[k])}
                for lk in self.links
            ],
        }
        text = json.dumps(payload, sort_keys=True, default=float)
        return hashlib.sha256(text.encode()).hexdigest()


#: The drive-train fields and their defaults (a rigid gear without current loop): at these values a link's
#: digest is the one it had before drive trains existed, so a rigid robot's compiled code is unchanged.
DRIVE_TRAIN_DEFAULTS: dict[str, Any] = {
    "gear_stiffness": None, "gear_damping": 0.0, "friction_side": "motor", "friction_peak": 1.0,
    "torque_constant": None, "current_bandwidth": None, "current_damping": 1.0, "armature_resistance": None,
}
#: Link fields that do not enter the equations of motion (so not the cache key of generated code): names and limits.
_NOT_PHYSICS = frozenset({"name", "qlim", "torque_limit", "velocity_limit", "acceleration_limit", "friction_source"})


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


#: Below this ``cos(pitch)`` a rotation is taken as at gimbal lock by :func:`tr2rpy` (yaw set to 0): far
#: above the rounding of a computed rotation (1e-16 per entry, so a composed pose at the lock is caught)
#: and far below what a printed angle shows.
_GIMBAL_COS = 1e-12


def tr2rpy(R: npt.ArrayLike) -> np.ndarray:
    """``[roll, pitch, yaw]`` (rad) with ``R = Rz(yaw) Ry(pitch) Rx(roll)``: the inverse of :func:`rpy_matrix`.

    ``pitch`` is in [-pi/2, pi/2], ``roll`` and ``yaw`` in [-pi, pi]. At gimbal lock (pitch = +-pi/2,
    ``cos(pitch)`` below 1e-12) only ``roll -+ yaw`` is defined; the convention is then ``yaw = 0``
    and the whole rotation about the aligned axes is ``roll``. Roll is always solved from what is left
    of ``R`` once yaw and pitch are removed, so ``rpy_matrix(tr2rpy(R))`` reproduces ``R`` to rounding
    near the lock too (where roll and yaw alone are ill-conditioned), within ``2 cos(pitch)`` (< 2e-12)
    where the convention sets yaw to 0, and nothing warns.

    Parameters
    ----------
    R
        (3, 3) rotation matrix (or the (4, 4) transform holding it).
    """
    R = np.asarray(R, dtype=float)[:3, :3]
    cos_pitch = math.hypot(R[0, 0], R[1, 0])
    pitch = math.atan2(-R[2, 0], cos_pitch)
    yaw = math.atan2(R[1, 0], R[0, 0]) if cos_pitch > _GIMBAL_COS else 0.0
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    M = Ry.T @ Rz.T @ R  # = Rx(roll)
    roll = math.atan2(M[2, 1] - M[1, 2], M[1, 1] + M[2, 2])
    return np.array([roll, pitch, yaw])


# --------------------------------------------------------------------------- parsing

_TOP_REQUIRED = ("name", "links")
_TOP_OPTIONAL = ("gravity", "rest", "description", "source", "units", "tasks", "convention", "base", "tool", "cascade")
_LINK_REQUIRED = ("joint", "a", "alpha", "d", "theta")
_LINK_OPTIONAL = (
    "mass", "com", "inertia", "motor_inertia", "gear_ratio", "viscous_friction",
    "coulomb_friction", "qlim", "name", "rotor_mass", "torque_limit", "source", "flip", "inertia_note",
    "velocity_limit", "acceleration_limit", *DRIVE_TRAIN_DEFAULTS,
)
_POSE_KEYS = ("xyz", "rpy")
_TASK_REQUIRED = ("name", "waypoints")
_TASK_OPTIONAL = ("segment_time", "labels", "description", "kind", "hold_time")
#: Task kinds: through the waypoints, segment by segment; or the synchronised trapezoidal point-to-point motion.
TASK_KINDS = ("waypoints", "ptp")
_CASCADE_KEYS = ("kp", "ks", "ti", "rate", "reference")


class _Where:
    """Builds error messages that name the file, the link and the field, and collects them.

    A check raises ``w.fail(...)``; a caller that can go on to the next field runs the check
    inside ``with w.collect():``, which records the problem instead. :meth:`raise_problems`
    then raises one error carrying every problem (``problems`` may be shared by several).
    """

    def __init__(self, path: str, problems: list[str] | None = None) -> None:
        self.path = path or "<dict>"
        self.problems: list[str] = [] if problems is None else problems

    def fail(self, link: int | None, fieldname: str, value: Any, expected: str) -> RobotDescriptionError:
        where = f"{self.path}"
        if link is not None:
            where += f", link {link + 1}"
        return RobotDescriptionError(f"{where}: field '{fieldname}' = {value!r}: expected {expected}")

    @contextlib.contextmanager
    def collect(self) -> Iterator[None]:
        """Record a :class:`RobotDescriptionError` raised inside the block and go on after it."""
        try:
            yield
        except RobotDescriptionError as exc:
            self.problems.extend(exc.problems)

    def raise_problems(self) -> None:
        """Raise one :class:`RobotDescriptionError` holding every problem collected, if there is any."""
        if self.problems:
            raise RobotDescriptionError.collected(self.problems, self.path)


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


def _check_keys(w: _Where, link: int | None, data: Mapping[str, Any], required: Sequence[str],
                optional: Sequence[str], prefix: str = "", what: str = "one of the known keys") -> None:
    """Record every missing required key and every unknown key of ``data`` (fields named ``prefix + key``).

    An unknown key close to a known one (:func:`~model.errors.closest`) gets "did you mean"; a missing
    required key with such a near-miss in the file is one problem naming both.
    """
    known = (*required, *optional)
    unknown = [key for key in data if key not in known]
    absent = [key for key in known if key not in data]
    for key in required:
        if key in data:
            continue
        typo = closest(key, unknown)
        if typo is None:
            w.problems.append(str(w.fail(link, prefix + key, None, "this required key (it is missing)")))
        else:
            unknown.remove(typo)
            w.problems.append(str(w.fail(link, prefix + key, None, f"this required key (it is missing; the file has "
                                                                    f"'{prefix}{typo}' = {data[typo]!r}: did you mean "
                                                                    f"'{prefix}{key}'?)")))
    for key in unknown:
        w.problems.append(str(w.fail(link, prefix + key, data[key],
                                     f"{what} ({', '.join(known)}); this key is unknown{did_you_mean(key, absent)}")))


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
            InertiaConsistencyWarning, stacklevel=5,
        )
    return inertia


def _coulomb(w: _Where, i: int, tc: Any) -> tuple[float, float]:
    if isinstance(tc, (list, tuple)):
        pos, neg = _vector(w, i, "coulomb_friction", tc, 2)
        if pos < 0 or neg > 0:
            raise w.fail(i, "coulomb_friction", tc, "[Tc_pos, Tc_neg] with Tc_pos >= 0 and Tc_neg <= 0")
    else:
        pos = _number(w, i, "coulomb_friction", tc, nonneg=True)
        neg = -pos
    return (pos + 0.0, neg + 0.0)  # + 0.0 turns -0.0 into 0.0: one digest per physics


def _link(w: _Where, i: int, data: Any) -> LinkDescription | None:
    """Link ``i`` of ``data``, every bad field recorded in ``w``; None when it has any."""
    if not isinstance(data, Mapping):
        raise w.fail(i, "links", data, "a table of link fields")
    start = len(w.problems)
    _check_keys(w, i, data, _LINK_REQUIRED, _LINK_OPTIONAL)
    kw: dict[str, Any] = {}
    if "joint" in data:
        with w.collect():
            if data["joint"] not in JOINT_TYPES:
                raise w.fail(i, "joint", data["joint"], "'revolute' or 'prismatic'")
            kw["joint"] = data["joint"]
    for key in ("a", "alpha", "d", "theta"):
        if key in data:
            with w.collect():
                kw[key] = _number(w, i, key, data[key])
    for key, default, nonneg in (("mass", 0.0, True), ("motor_inertia", 0.0, True), ("viscous_friction", 0.0, True),
                                 ("rotor_mass", 0.0, True)):
        with w.collect():
            kw[key] = _number(w, i, key, data.get(key, default), nonneg=nonneg)
    with w.collect():
        kw["gear_ratio"] = _number(w, i, "gear_ratio", data.get("gear_ratio", 1.0), nonzero=True)
    with w.collect():
        kw["com"] = _vector(w, i, "com", data.get("com", [0.0, 0.0, 0.0]), 3)
    with w.collect():
        note = data.get("inertia_note")
        if note is not None and not (isinstance(note, str) and note.strip()):
            raise w.fail(i, "inertia_note", note, "a non-empty text saying why the inertia is kept as given")
        kw["inertia"] = _inertia(w, i, data.get("inertia", [0.0] * 6), note)
    with w.collect():
        kw["coulomb_friction"] = _coulomb(w, i, data.get("coulomb_friction", 0.0))
    if "qlim" in data:
        with w.collect():
            lo, hi = _vector(w, i, "qlim", data["qlim"], 2)
            if not lo < hi:
                raise w.fail(i, "qlim", data["qlim"], "[lower, upper] with lower < upper")
            kw["qlim"] = (lo, hi)
    if "name" in data:
        with w.collect():
            if not isinstance(data["name"], str):
                raise w.fail(i, "name", data["name"], "a string")
            kw["name"] = data["name"]
    _positive_keys(w, i, data, kw, (("torque_limit", "a motor torque rating > 0 (N m)"),
                                    ("velocity_limit", "a joint speed limit > 0 (rad/s or m/s)"),
                                    ("acceleration_limit", "a joint acceleration limit > 0 (rad/s^2 or m/s^2)")))
    _drive_train(w, i, data, kw)
    kw["friction_source"] = tuple(FROM_FILE if key in data else FROM_DEFAULT
                                  for key in ("viscous_friction", "coulomb_friction"))
    if "flip" in data:
        with w.collect():
            if not isinstance(data["flip"], bool):
                raise w.fail(i, "flip", data["flip"], "true or false")
            kw["flip"] = data["flip"]
    return None if len(w.problems) > start else LinkDescription(**kw)


def _positive_keys(w: _Where, i: int, data: Mapping[str, Any], kw: dict[str, Any],
                   keys: tuple[tuple[str, str], ...]) -> None:
    """Each ``(key, what)`` of link ``i`` that ``data`` states: a number > 0 into ``kw``, else a problem in ``w``."""
    for key, what in keys:
        if key in data:
            with w.collect():
                value = _number(w, i, key, data[key])
                if value <= 0:
                    raise w.fail(i, key, data[key], what)
                kw[key] = value


def _drive_train(w: _Where, i: int, data: Mapping[str, Any], kw: dict[str, Any]) -> None:
    """The drive-train keys of link ``i`` into ``kw`` (each bad one recorded in ``w``)."""
    _positive_keys(w, i, data, kw, (("gear_stiffness", "a gear stiffness > 0 (N m/rad, motor side)"),
                                    ("torque_constant", "a torque constant > 0 (N m/A)"),
                                    ("current_bandwidth", "a current-loop bandwidth > 0 (rad/s)"),
                                    ("current_damping", "a current-loop damping ratio > 0"),
                                    ("armature_resistance", "an armature resistance > 0 (Ohm)")))
    if "gear_damping" in data:
        with w.collect():
            kw["gear_damping"] = _number(w, i, "gear_damping", data["gear_damping"], nonneg=True)
    if "friction_peak" in data:
        with w.collect():
            peak = _number(w, i, "friction_peak", data["friction_peak"])
            if peak < 1:
                raise w.fail(i, "friction_peak", data["friction_peak"], "a break-away factor >= 1")
            kw["friction_peak"] = peak
    if "friction_side" in data:
        with w.collect():
            if data["friction_side"] not in ("motor", "link"):
                raise w.fail(i, "friction_side", data["friction_side"], "'motor' or 'link'")
            kw["friction_side"] = data["friction_side"]
    for key, needs in (("gear_damping", "gear_stiffness"), ("friction_side", "gear_stiffness"),
                       ("current_damping", "current_bandwidth"), ("armature_resistance", "current_bandwidth"),
                       ("armature_resistance", "torque_constant")):
        if key in data and needs not in data:
            with w.collect():
                raise w.fail(i, key, data[key], f"to be stated with '{needs}' (it means nothing without it)")
    if "gear_stiffness" in data and kw.get("motor_inertia", 0.0) <= 0:
        with w.collect():
            raise w.fail(i, "motor_inertia", data.get("motor_inertia", 0.0),
                         "a rotor inertia > 0 for an elastic gear (the rotor is a body of its own)")


def _pose(w: _Where, key: str, value: Any) -> tuple[float, ...] | None:
    """``{xyz = [...], rpy = [...]}`` (m, rad) as 16 row-major floats; None for the identity."""
    if not isinstance(value, Mapping):
        raise w.fail(None, key, value, "a table {xyz = [x, y, z], rpy = [roll, pitch, yaw]} (m, rad)")
    start = len(w.problems)
    _check_keys(w, None, value, (), _POSE_KEYS, prefix=f"{key}.")
    parts = []
    for part in _POSE_KEYS:
        with w.collect():
            parts.append(_vector(w, None, f"{key}.{part}", value.get(part, [0.0, 0.0, 0.0]), 3))
    if len(w.problems) > start:
        return None
    xyz, rpy = parts
    if not any(xyz) and not any(rpy):
        return None
    T = np.eye(4)
    T[:3, :3] = rpy_matrix(rpy)
    T[:3, 3] = xyz
    return tuple(float(v) + 0.0 for v in T.ravel())  # + 0.0: no -0.0, one digest per pose


def _units(w: _Where, value: Any) -> Mapping[str, str]:
    if not isinstance(value, Mapping):
        raise w.fail(None, "units", value, "a table of quantity = SI unit")
    _check_keys(w, None, value, (), tuple(SI_UNITS), prefix="units.", what="one of the known quantities")
    for key, unit in value.items():
        if key in SI_UNITS and unit not in SI_UNITS[key]:
            spellings = " or ".join(repr(u) for u in SI_UNITS[key])
            w.problems.append(str(w.fail(None, f"units.{key}", unit, f"the SI unit {spellings}: robot files are in SI units only")))
    return dict(value)


def _qlims(links: Sequence[LinkDescription | None]) -> list[tuple[float, float] | None]:
    """Each joint's limits; None where it states none or where the link itself is bad."""
    return [None if link is None else link.qlim for link in links]


def _task(w: _Where, k: int, data: Any, qlims: Sequence[tuple[float, float] | None], names: set[str]) -> Mapping[str, Any]:
    where = f"tasks[{k + 1}]"
    if not isinstance(data, Mapping):
        raise w.fail(None, where, data, "a [[tasks]] table")
    _check_keys(w, None, data, _TASK_REQUIRED, _TASK_OPTIONAL, prefix=f"{where}.")
    out: dict[str, Any] = {}
    if "name" in data:
        with w.collect():
            name = data["name"]
            if not isinstance(name, str) or not name.strip():
                raise w.fail(None, f"{where}.name", name, "a non-empty string")
            if name in names:
                raise w.fail(None, f"{where}.name", name, "a task name not used by another [[tasks]] entry")
            names.add(name)
            out["name"] = name
    rows = data.get("waypoints")
    if "waypoints" in data:
        with w.collect():
            if not isinstance(rows, list) or len(rows) < 2:
                raise w.fail(None, f"{where}.waypoints", rows, f"a list of at least 2 joint vectors of {len(qlims)} values")
            if len(rows) > MAX_WAYPOINTS:
                raise RobotDescriptionError(f"{w.path}: {where}.waypoints: {len(rows)} waypoints: more than the waypoint "
                                            f"limit of {MAX_WAYPOINTS}")
            waypoints = []
            for r, row in enumerate(rows, 1):
                vec = _vector(w, None, f"{where}.waypoints[{r}]", row, len(qlims))
                for j, (x, qlim) in enumerate(zip(vec, qlims)):
                    if qlim is not None and not qlim[0] <= x <= qlim[1]:
                        raise w.fail(j, f"{where}.waypoints[{r}]", x, f"a joint value within qlim [{qlim[0]}, {qlim[1]}]")
                waypoints.append(vec)
            out["waypoints"] = tuple(waypoints)
    with w.collect():
        segment_time = _number(w, None, f"{where}.segment_time", data.get("segment_time", 3.0))
        if segment_time <= 0:
            raise w.fail(None, f"{where}.segment_time", data["segment_time"], "a duration > 0 (s)")
        out["segment_time"] = segment_time
    if isinstance(rows, list):
        with w.collect():
            labels = data.get("labels", [f"waypoint {r}" for r in range(len(rows))])
            if not isinstance(labels, list) or len(labels) != len(rows) or not all(isinstance(x, str) for x in labels):
                raise w.fail(None, f"{where}.labels", labels, f"a list of {len(rows)} strings, one per waypoint")
            out["labels"] = tuple(labels)
    with w.collect():
        description = data.get("description", "")
        if not isinstance(description, str):
            raise w.fail(None, f"{where}.description", description, "a string")
        out["description"] = description
    with w.collect():
        kind = data.get("kind", "waypoints")
        if kind not in TASK_KINDS:
            raise w.fail(None, f"{where}.kind", kind, f"one of {', '.join(repr(k) for k in TASK_KINDS)}")
        if kind == "ptp" and isinstance(rows, list) and len(rows) != 2:
            raise w.fail(None, f"{where}.waypoints", rows, "2 joint vectors (begin, end) for a 'ptp' task")
        out["kind"] = kind
    with w.collect():
        out["hold_time"] = _number(w, None, f"{where}.hold_time", data.get("hold_time", 0.0), nonneg=True)
    return types.MappingProxyType(out)


def _cascade(w: _Where, data: Any, n: int) -> Mapping[str, Any]:
    """The ``[cascade]`` table: P-PI cascade gains, each one number or n numbers, and the rate."""
    if not isinstance(data, Mapping):
        raise w.fail(None, "cascade", data, "a table of kp, ks, ti, rate")
    _check_keys(w, None, data, (), _CASCADE_KEYS, prefix="cascade.")
    out: dict[str, Any] = {}
    for key, what in (("kp", "position gains > 0 (1/s)"), ("ks", "speed gains > 0 (A s/rad, or N m s/rad)"),
                      ("ti", "PI time constants > 0 (s)")):
        if key in data:
            with w.collect():
                raw = data[key]
                values = _vector(w, None, f"cascade.{key}", raw, n) if isinstance(raw, list) else \
                    (_number(w, None, f"cascade.{key}", raw),) * n
                if min(values) <= 0:
                    raise w.fail(None, f"cascade.{key}", raw, what)
                out[key] = values
    if "reference" in data:
        with w.collect():
            if not isinstance(data["reference"], str) or not data["reference"]:
                raise w.fail(None, "cascade.reference", data["reference"], "a CSV file name, relative to the robot file")
            out["reference"] = data["reference"]
    if "rate" in data:
        with w.collect():
            rate = _number(w, None, "cascade.rate", data["rate"])
            if rate <= 0:
                raise w.fail(None, "cascade.rate", data["rate"], "a control rate > 0 (Hz)")
            out["rate"] = rate
    return types.MappingProxyType(out)


def _description(w: _Where, data: Any, path: str) -> RobotDescription | None:
    """The description of ``data``, every independent problem recorded in ``w``; None when there is any.

    Raises at once (with the problems so far) when nothing further can be checked: ``data``
    is not a table, or it has more links than :data:`~model.limits.MAX_JOINTS`.
    """
    if not isinstance(data, Mapping):
        raise w.fail(None, "<document>", data, "a TOML table")
    start = len(w.problems)
    _check_keys(w, None, data, _TOP_REQUIRED, _TOP_OPTIONAL)
    if "name" in data:
        with w.collect():
            if not isinstance(data["name"], str) or not data["name"].strip():
                raise w.fail(None, "name", data["name"], "a non-empty string")
    convention = data.get("convention", "standard")
    with w.collect():
        if convention not in ("standard", "modified"):
            raise w.fail(None, "convention", convention, "'standard' or 'modified' (URDF robots are read from a .urdf file)")
    links: list[LinkDescription | None] = []
    if "links" in data:
        raw_links = data["links"]
        if not isinstance(raw_links, list) or not raw_links:
            w.problems.append(str(w.fail(None, "links", raw_links, "at least one [[links]] table")))
        elif len(raw_links) > MAX_JOINTS:
            raise RobotDescriptionError(f"{w.path}: {len(raw_links)} links: more than the joint-count limit of {MAX_JOINTS}")
        else:
            for i, lk in enumerate(raw_links):
                link = None
                with w.collect():
                    link = _link(w, i, lk)
                links.append(link)
    with w.collect():
        gravity = _vector(w, None, "gravity", data.get("gravity", [0.0, 0.0, -9.81]), 3)
    rest = None
    if "rest" in data and links:
        with w.collect():
            rest = _vector(w, None, "rest", data["rest"], len(links))
            for i, (value, qlim) in enumerate(zip(rest, _qlims(links))):
                if qlim is not None and not qlim[0] <= value <= qlim[1]:
                    raise w.fail(i, "rest", value, f"a rest position within qlim [{qlim[0]}, {qlim[1]}]")
    for key in ("description", "source"):
        if key in data and not isinstance(data[key], str):
            w.problems.append(str(w.fail(None, key, data[key], "a string")))
    poses: dict[str, tuple[float, ...] | None] = {}
    for key in ("base", "tool"):
        with w.collect():
            poses[key] = _pose(w, key, data[key]) if key in data else None
    extra: dict[str, Any] = {}
    if "units" in data:
        with w.collect():
            extra["units"] = _units(w, data["units"])
    if "tasks" in data and links:
        names: set[str] = set()
        with w.collect():
            if not isinstance(data["tasks"], list):
                raise w.fail(None, "tasks", data["tasks"], "a list of [[tasks]] tables")
            tasks = []
            for k, t in enumerate(data["tasks"]):
                with w.collect():
                    tasks.append(_task(w, k, t, _qlims(links), names))
            extra["tasks"] = tuple(tasks)
    if "cascade" in data and links:
        with w.collect():
            extra["cascade"] = _cascade(w, data["cascade"], len(links))
    if len(w.problems) > start:
        return None
    return RobotDescription(
        name=data["name"], links=tuple(links), gravity=gravity, rest=rest,  # type: ignore[arg-type]
        description=data.get("description", ""), source=data.get("source", ""),
        path=str(path), convention=convention, base=poses["base"], tool=poses["tool"],
        extra=types.MappingProxyType(extra),
    )


def description_from_dict(data: Mapping[str, Any], path: str = "") -> RobotDescription:
    """Validate a parsed TOML document (or an equivalent dict) into a :class:`RobotDescription`.

    Every independent problem is reported, not only the first (as FMPy's validation does).

    Raises
    ------
    RobotDescriptionError
        Naming the file, the link (1-based), the field, the value and what was expected; with several
        problems, its ``problems`` holds one such message each and its message is a count line and them.
    """
    w = _Where(path)
    desc = None
    with w.collect():  # a problem that stops the checks: reported after those found so far
        desc = _description(w, data, path)
    w.raise_problems()
    assert desc is not None
    return desc
