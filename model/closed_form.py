"""Arm structures with closed-form inverse kinematics, recognised from the DH table.

One place holds what the workbench knows about a structure: how to recognise it
from a :class:`~model.description.RobotDescription` (the numbers, not the name,
so a user TOML with the same geometry is recognised too), which task-space
rows it can control, its named singular configurations and its closed-form
inverse kinematics. :mod:`model.ik` and :mod:`model.singularity` both read it.

Recognised structures (standard DH, ``theta_i = q_i + theta`` offsets and
prismatic ``d_i = q_i + d`` offsets allowed throughout):

``scara``
    RRPR; alpha = (0, +-pi or 0, 0, 0), a3 = a4 = 0. Task x, y, z, yaw.
``planar3r`` / ``planar2r``
    RRR / RR with every alpha = 0 (any a3, any d). Task x, y (and yaw).
``arm4``
    RRRR; alpha1 = +-pi/2, alpha2..4 = 0, d2..4 = 0 (base rotation and a planar
    3R chain in the vertical plane, shoulder offset a1). Task x, y, z and the
    hand pitch about the arm-plane normal.
``spherical``
    RRP; alpha = (-pi/2, +pi/2, any), a1 = a2 = a3 = 0 (Stanford arm without
    wrist, lateral shoulder offset d2). Task x, y, z.

Only standard-DH chains are recognised (a modified-DH or URDF chain is not
offered a closed form, numeric IK serves every convention); ``flip`` is
honoured. The structures solve for the DH frame n in frame 0: a world target
``T_WE`` is first moved to ``T_0n = base^-1 T_WE tool^-1`` (:func:`chain_target`),
and :func:`chain_jacobian` gives the matching Jacobian (frame-0 axes, origin of
DH frame n) for the task rows. m and rad.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .description import RobotDescription
from .errors import InputError, WorkbenchError

__all__ = [
    "IKSolution",
    "WorkspaceError",
    "NoClosedFormError",
    "ClosedForm",
    "Scara",
    "Planar2R",
    "Planar3R",
    "Arm4",
    "SphericalRRP",
    "STRUCTURES",
    "POSE_TOL",
    "closed_form_for",
    "require_closed_form",
    "joint_values",
    "chain_target",
    "chain_jacobian",
]

#: A DH parameter within this of a pattern value (m or rad) matches it.
_DH_TOL = 1e-9
#: How far (rad or m) a pose component the structure cannot change (a SCARA's tool
#: tilt, a planar arm's off-plane offset, an arm4 hand axis off its plane) may be
#: from its only reachable value before the pose counts as outside the workspace.
POSE_TOL = 1e-6
#: Cosine of an elbow angle beyond +-1 by less than this is rounding at the
#: workspace boundary and is clipped; beyond it the target is out of reach.
_COS_TOL = 1e-9

_TWO_PI = 2.0 * math.pi


class WorkspaceError(InputError):
    """The target pose is outside the robot's workspace; the message names the target and why."""


class NoClosedFormError(WorkbenchError, LookupError):
    """The robot's structure has no closed-form inverse kinematics here; the message names the robot."""


@dataclass(frozen=True, eq=False)
class IKSolution:
    """One closed-form inverse-kinematics solution.

    Attributes
    ----------
    q
        (n,) joint values, rad or m. Revolute values are in (-pi, pi], or shifted by
        2 pi when only the shifted value lies within the joint limits.
    branch
        Label of the branch, e.g. ``"elbow-up"``, ``"front/elbow-down"``, ``"righty"``.
    within_limits
        Whether ``q`` lies within ``qlim``; solutions outside are returned, flagged.
    reproduces_pose
        Whether ``fkine(q)`` equals the target in every component (to 1e-6 m and
        rad), orientation included. False when the structure ignores a component
        the target fixes (planar2r and spherical use the position only; the arm4
        ``back`` branches reach the same point and hand axis with the hand rolled
        by pi).
    """

    q: np.ndarray
    branch: str
    within_limits: bool
    reproduces_pose: bool


# --------------------------------------------------------------------------- helpers


def _near(x: float, target: float) -> bool:
    return abs(x - target) <= _DH_TOL


def _sign(lk) -> float:
    return -1.0 if lk.flip else 1.0


def joint_values(desc: RobotDescription, q: np.ndarray) -> np.ndarray:
    """(n,) DH joint variables of ``q``: ``theta_i = +-q_i + theta`` (revolute), ``d_i = +-q_i + d`` (prismatic), - if flipped."""
    return np.array([_sign(lk) * qi + (lk.theta if lk.is_revolute else lk.d) for qi, lk in zip(q, desc.links)])


def chain_target(desc: RobotDescription, T: np.ndarray) -> np.ndarray:
    """(4, 4) pose of DH frame n in frame 0, ``base^-1 T tool^-1``, for a world tool pose ``T``."""
    return np.linalg.solve(desc.T_base, T) @ np.linalg.inv(desc.T_tool)


def chain_jacobian(desc: RobotDescription, T: np.ndarray, J_W: np.ndarray) -> np.ndarray:
    """(6, n) Jacobian of DH frame n's origin in frame-0 axes, from the world tool pose ``T`` and ``jacob0`` ``J_W``.

    ``v_n = v_E - w x r`` with ``r`` the tool origin seen from the frame-n origin.
    """
    R_W0 = desc.T_base[:3, :3]
    v, w = R_W0.T @ J_W[:3], R_W0.T @ J_W[3:]
    T_0E = np.linalg.solve(desc.T_base, T)
    r = T_0E[:3, 3] - chain_target(desc, T)[:3, 3]
    return np.vstack([v - np.cross(w.T, r).T, w])


def _wrap(angle: float) -> float:
    """Angle in [-pi, pi]."""
    return math.remainder(angle, _TWO_PI)


def _two_link(wx: float, wy: float, a1: float, a2: float) -> tuple[float, float] | None:
    """Cosine and |sine| of the elbow angle that puts a 2R chain (a1, a2) on the point (wx, wy).

    None if the point is out of reach. Uses the factored form of ``1 - c^2`` so the
    sine keeps its relative accuracy near the stretched and folded elbow.
    """
    r = math.hypot(wx, wy)
    c = (r * r - a1 * a1 - a2 * a2) / (2.0 * a1 * a2)
    if abs(c) > 1.0 + _COS_TOL:
        return None
    hi, lo = abs(a1) + abs(a2), abs(abs(a1) - abs(a2))
    s2 = (hi - r) * (hi + r) * (r - lo) * (r + lo)
    s = math.sqrt(max(s2, 0.0)) / (2.0 * abs(a1 * a2))
    return min(max(c, -1.0), 1.0), s


def _shoulder(wx: float, wy: float, a1: float, a2: float, theta2: float) -> float:
    """Shoulder angle of a 2R chain with elbow ``theta2`` reaching (wx, wy)."""
    return math.atan2(wy, wx) - math.atan2(a2 * math.sin(theta2), a1 + a2 * math.cos(theta2))


def _tilt(axis: np.ndarray, target: np.ndarray) -> float:
    """Angle (rad) between unit vectors ``axis`` and ``target``, accurate near 0."""
    return math.atan2(float(np.linalg.norm(np.cross(axis, target))), float(axis @ target))


def _fmt(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.4g}" for x in np.asarray(v, dtype=float)) + "]"


def _reach_error(name: str, p: np.ndarray, what: str, dist: float, lo: float, hi: float, extra: str = "") -> WorkspaceError:
    return WorkspaceError(
        f"{name}: target p = {_fmt(p)} m out of reach: {what} at distance {dist:.4g} m from the "
        f"shoulder axis, reachable range [{lo:.4g}, {hi:.4g}] m{extra}"
    )


# --------------------------------------------------------------------------- structures


@dataclass(frozen=True)
class ClosedForm(ABC):
    """What the workbench knows about one recognised arm structure.

    Subclasses hold the geometry read from the DH table; build them with
    :meth:`match`, or through :func:`closed_form_for`.
    """

    desc: RobotDescription = field(repr=False)

    #: Structure name, e.g. ``"scara"``.
    kind: ClassVar[str]
    #: Names of the task-space rows the structure controls (see :meth:`task_jacobian`).
    task_labels: ClassVar[tuple[str, ...]]
    #: Default weights of the numeric ``ikine`` on the pose error [x y z rx ry rz].
    ikine_mask: ClassVar[tuple[float, ...]]
    #: Which components of the target pose ``T`` :meth:`solve` uses, in words.
    pose_components: ClassVar[str]
    #: Human description of the DH pattern, used in error messages.
    pattern: ClassVar[str]

    @classmethod
    @abstractmethod
    def match(cls, desc: RobotDescription) -> "ClosedForm | None":
        """This structure with the geometry of ``desc``, or None if its DH table does not fit."""

    @abstractmethod
    def solve(self, T: np.ndarray) -> list[tuple[np.ndarray, str]]:
        """Every solution of pose ``T`` (4, 4): pairs (DH joint variables (n,), branch label).

        Raises
        ------
        WorkspaceError
            If the target is outside the workspace.
        """

    @abstractmethod
    def singular_conditions(self, theta: np.ndarray, tol: float) -> list[str]:
        """Named singular conditions that hold at DH joint variables ``theta``, in words."""

    def task_jacobian(self, J0: np.ndarray) -> np.ndarray:
        """(m, n) rows of the geometric Jacobian ``J0`` (6, n) that the structure controls."""
        return J0[list(self._task_rows)]

    _task_rows: ClassVar[tuple[int, ...]] = (0, 1, 2, 3, 4, 5)

    @property
    def length_scale(self) -> float:
        """Sum of |a| and |d| of the DH table, m: scales length tolerances."""
        return max(1.0, sum(abs(lk.a) + abs(lk.d) for lk in self.desc.links))

    def to_q(self, theta: np.ndarray) -> np.ndarray:
        """Joint values q of DH joint variables ``theta``; revolute ones wrapped, preferring the limits."""
        q = np.empty(self.desc.n)
        for i, (value, lk) in enumerate(zip(theta, self.desc.links)):
            if not lk.is_revolute:
                q[i] = _sign(lk) * (value - lk.d)
                continue
            qi = _wrap(_sign(lk) * (value - lk.theta))
            if lk.qlim is not None and not lk.qlim[0] <= qi <= lk.qlim[1]:
                for shifted in (qi - _TWO_PI, qi + _TWO_PI):
                    if lk.qlim[0] <= shifted <= lk.qlim[1]:
                        qi = shifted
                        break
            q[i] = qi
        return q


def _planar_solutions(name: str, p: np.ndarray, wx: float, wy: float, a1: float, a2: float, what: str) -> list[tuple[float, float, str]]:
    """(theta1, theta2, label) of both elbows of a 2R chain reaching (wx, wy); WorkspaceError if none."""
    cs = _two_link(wx, wy, a1, a2)
    if cs is None:
        raise _reach_error(name, p, what, math.hypot(wx, wy), abs(abs(a1) - abs(a2)), abs(a1) + abs(a2))
    c, s = cs
    out = []
    for sign, label in ((-1.0, "elbow-up"), (1.0, "elbow-down")):
        t2 = math.atan2(sign * s, c)
        out.append((_shoulder(wx, wy, a1, a2, t2), t2, label))
    return out


def _elbow_reason(joint: int, theta: float, tol: float) -> list[str]:
    if abs(math.sin(theta)) >= tol:
        return []
    if math.cos(theta) > 0:
        return [f"elbow stretched (theta{joint} = 0): the two arm links are aligned, "
                "the end cannot move along the line from the shoulder axis through the elbow"]
    return [f"elbow folded (theta{joint} = pi): the forearm lies back along the upper arm, "
            "the end cannot move along the line from the shoulder axis through the elbow"]


@dataclass(frozen=True)
class Scara(ClosedForm):
    """SCARA: two horizontal revolute links, a vertical quill (prismatic), a wrist roll.

    Position ``[a1 c1 + a2 c12, a1 s1 + a2 s12, d1 + d2 + sigma (d3 + d4)]`` and
    ``R = Rz(theta1 + theta2 + sigma (theta3 + theta4)) Rx(alpha2)``, sigma = cos(alpha2):
    the tool z is ``sigma z0`` (down for the seed's alpha2 = pi).
    Branches: ``"lefty"`` (theta2 < 0) and ``"righty"`` (theta2 > 0: seen from above,
    the elbow is right of the line from the shoulder to the wrist, as a right arm's).
    """

    a1: float = 0.0
    a2: float = 0.0
    sigma: float = -1.0
    z0: float = 0.0
    d4: float = 0.0
    theta3: float = 0.0

    kind: ClassVar[str] = "scara"
    task_labels: ClassVar[tuple[str, ...]] = ("x", "y", "z", "rz")
    _task_rows: ClassVar[tuple[int, ...]] = (0, 1, 2, 5)
    ikine_mask: ClassVar[tuple[float, ...]] = (1.0, 1.0, 1.0, 0.0, 0.0, 1.0)
    pose_components: ClassVar[str] = ("position and the tool heading (angle of x_E about z0); "
                                      "the tool z must be +-z0 as the DH table fixes it")
    pattern: ClassVar[str] = "scara (RRPR, alpha = [0, pi or 0, 0, 0], a3 = a4 = 0)"

    @classmethod
    def match(cls, desc: RobotDescription) -> "Scara | None":
        if desc.joint_types != "RRPR":
            return None
        l1, l2, l3, l4 = desc.links
        flip = _near(abs(l2.alpha), math.pi)
        if not (_near(l1.alpha, 0.0) and (flip or _near(l2.alpha, 0.0)) and _near(l3.alpha, 0.0)
                and _near(l4.alpha, 0.0) and _near(l3.a, 0.0) and _near(l4.a, 0.0)
                and abs(l1.a) > _DH_TOL and abs(l2.a) > _DH_TOL):
            return None
        return cls(desc, a1=l1.a, a2=l2.a, sigma=-1.0 if flip else 1.0,
                   z0=l1.d + l2.d, d4=l4.d, theta3=l3.theta)

    def solve(self, T: np.ndarray) -> list[tuple[np.ndarray, str]]:
        p, R = T[:3, 3], T[:3, :3]
        down = np.array([0.0, 0.0, self.sigma])
        tilt = _tilt(R[:, 2], down)
        if tilt > POSE_TOL:
            raise WorkspaceError(
                f"{self.desc.name}: target orientation out of reach: the tool z axis T[:3, 2] = {_fmt(R[:, 2])} "
                f"is tilted {tilt:.4g} rad from {_fmt(down)}; a 4-DOF SCARA cannot roll or pitch its tool, "
                f"T[:3, 2] must be {_fmt(down)} (the tool points {'down' if self.sigma < 0 else 'up'})"
            )
        heading = math.atan2(R[1, 0], R[0, 0])
        d3 = self.sigma * (p[2] - self.z0) - self.d4
        out = []
        for t1, t2, label in _planar_solutions(self.desc.name, p, p[0], p[1], self.a1, self.a2, "wrist axis"):
            t4 = self.sigma * (heading - t1 - t2) - self.theta3
            out.append((np.array([t1, t2, d3, t4]), "lefty" if label == "elbow-up" else "righty"))
        return out

    def singular_conditions(self, theta: np.ndarray, tol: float) -> list[str]:
        return _elbow_reason(2, float(theta[1]), tol)


@dataclass(frozen=True)
class _Planar(ClosedForm):
    a: tuple[float, ...] = ()
    z0: float = 0.0

    _task_rows: ClassVar[tuple[int, ...]] = (0, 1, 5)
    _joints: ClassVar[str] = "RRR"

    @classmethod
    def match(cls, desc: RobotDescription) -> "_Planar | None":
        if desc.joint_types != cls._joints:
            return None
        links = desc.links
        if not all(_near(lk.alpha, 0.0) for lk in links) or abs(links[0].a) <= _DH_TOL or abs(links[1].a) <= _DH_TOL:
            return None
        return cls(desc, a=tuple(lk.a for lk in links), z0=sum(lk.d for lk in links))

    def _check_plane(self, p: np.ndarray) -> None:
        if abs(p[2] - self.z0) > POSE_TOL:
            raise WorkspaceError(
                f"{self.desc.name}: target p = {_fmt(p)} m out of reach: it is {p[2] - self.z0:.4g} m off "
                f"the arm plane z = {self.z0:.4g} m of the base frame"
            )

    def singular_conditions(self, theta: np.ndarray, tol: float) -> list[str]:
        return _elbow_reason(2, float(theta[1]), tol)


@dataclass(frozen=True)
class Planar3R(_Planar):
    """Planar 3R arm (slides of seed 001): joint axes along base z, arm in the base x-y plane.

    Uses the position (x, y) and the in-plane angle ``alpha = atan2(R[1, 0], R[0, 0])``
    of the end frame; the wrist point is ``p - a3 [cos alpha, sin alpha]``.
    Branches (the slides' convention): ``"elbow-up"`` theta2 < 0, ``"elbow-down"``
    theta2 > 0; the elbow is literally above the shoulder-wrist line when the wrist
    is ahead of the shoulder (x > 0) and base y points up.
    """

    kind: ClassVar[str] = "planar3r"
    task_labels: ClassVar[tuple[str, ...]] = ("x", "y", "rz")
    ikine_mask: ClassVar[tuple[float, ...]] = (1.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    pose_components: ClassVar[str] = "x, y and the in-plane angle alpha of x_E; z_E must be +z0 and p on the arm plane"
    pattern: ClassVar[str] = "planar3r (RRR, every alpha = 0)"
    _joints: ClassVar[str] = "RRR"

    def solve(self, T: np.ndarray) -> list[tuple[np.ndarray, str]]:
        p, R = T[:3, 3], T[:3, :3]
        self._check_plane(p)
        tilt = _tilt(R[:, 2], np.array([0.0, 0.0, 1.0]))
        if tilt > POSE_TOL:
            raise WorkspaceError(
                f"{self.desc.name}: target orientation out of reach: T[:3, 2] = {_fmt(R[:, 2])} is tilted "
                f"{tilt:.4g} rad from z0; a planar arm's end frame keeps z along the joint axes, [0, 0, 1]"
            )
        alpha = math.atan2(R[1, 0], R[0, 0])
        a1, a2, a3 = self.a
        wx, wy = p[0] - a3 * math.cos(alpha), p[1] - a3 * math.sin(alpha)
        return [(np.array([t1, t2, alpha - t1 - t2]), label)
                for t1, t2, label in _planar_solutions(self.desc.name, p, wx, wy, a1, a2, "wrist point")]


@dataclass(frozen=True)
class Planar2R(_Planar):
    """Planar 2R arm: position-only closed form (x, y); the orientation of ``T`` is not used.

    Branches as :class:`Planar3R`.
    """

    kind: ClassVar[str] = "planar2r"
    task_labels: ClassVar[tuple[str, ...]] = ("x", "y")
    _task_rows: ClassVar[tuple[int, ...]] = (0, 1)
    ikine_mask: ClassVar[tuple[float, ...]] = (1.0, 1.0, 0.0, 0.0, 0.0, 0.0)
    pose_components: ClassVar[str] = "x and y only (2 joints cannot also set the orientation); p on the arm plane"
    pattern: ClassVar[str] = "planar2r (RR, every alpha = 0)"
    _joints: ClassVar[str] = "RR"

    def solve(self, T: np.ndarray) -> list[tuple[np.ndarray, str]]:
        p = T[:3, 3]
        self._check_plane(p)
        a1, a2 = self.a
        return [(np.array([t1, t2]), label)
                for t1, t2, label in _planar_solutions(self.desc.name, p, p[0], p[1], a1, a2, "end point")]


@dataclass(frozen=True)
class Arm4(ClosedForm):
    """4-DOF arm (slides of seed 001): base rotation, then a planar 3R chain in a vertical plane.

    ``p = [(a1 + X) c1, (a1 + X) s1, d1 + sigma Y]`` with the in-plane chain
    ``X = a2 c2 + a3 c23 + a4 c234``, ``Y = a2 s2 + a3 s23 + a4 s234``, sigma = sin(alpha1);
    hand axis ``x_E = [c1 c234, s1 c234, sigma s234]``, plane normal ``z_E = sigma [s1, -c1, 0]``.

    Uses the position and the hand axis x_E (which fixes the pitch
    alpha = theta2 + theta3 + theta4 in the arm plane); x_E must lie in the vertical
    plane through the base axis and the target. Branches: ``"front"`` (theta1 points
    the arm plane at the target) and ``"back"`` (theta1 + pi, the arm reaches over the
    base axis; same point and hand axis, hand rolled by pi, so z_E is reversed), each
    with ``"elbow-up"`` (theta3 < 0, the slides' convention) and ``"elbow-down"``.
    Branches that cannot reach the target are left out.
    """

    a1: float = 0.0
    d1: float = 0.0
    a2: float = 0.0
    a3: float = 0.0
    a4: float = 0.0
    sigma: float = 1.0

    kind: ClassVar[str] = "arm4"
    task_labels: ClassVar[tuple[str, ...]] = ("x", "y", "z", "pitch")
    ikine_mask: ClassVar[tuple[float, ...]] = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    pose_components: ClassVar[str] = "position and the hand axis x_E (the pitch in the arm plane); not the roll of the hand"
    pattern: ClassVar[str] = "arm4 (RRRR, alpha = [+-pi/2, 0, 0, 0], d2 = d3 = d4 = 0)"

    @classmethod
    def match(cls, desc: RobotDescription) -> "Arm4 | None":
        if desc.joint_types != "RRRR":
            return None
        l1, l2, l3, l4 = desc.links
        if not (_near(abs(l1.alpha), math.pi / 2) and all(_near(lk.alpha, 0.0) and _near(lk.d, 0.0) for lk in (l2, l3, l4))
                and abs(l2.a) > _DH_TOL and abs(l3.a) > _DH_TOL):
            return None
        return cls(desc, a1=l1.a, d1=l1.d, a2=l2.a, a3=l3.a, a4=l4.a, sigma=math.copysign(1.0, l1.alpha))

    def task_jacobian(self, J0: np.ndarray) -> np.ndarray:
        """Rows v_x, v_y, v_z and the pitch rate ``z1 . omega`` (z1 = joint-2 axis, a unit vector)."""
        z1 = J0[3:6, 1]
        return np.vstack([J0[0:3], z1 @ J0[3:6]])

    def solve(self, T: np.ndarray) -> list[tuple[np.ndarray, str]]:
        p, R = T[:3, 3], T[:3, :3]
        hand, normal = R[:, 0], R[:, 2]
        rho = math.hypot(p[0], p[1])
        if rho > POSE_TOL:
            psi = math.atan2(p[1], p[0])
            across = float(hand @ np.array([-math.sin(psi), math.cos(psi), 0.0]))
            if abs(across) > POSE_TOL:
                raise WorkspaceError(
                    f"{self.desc.name}: target orientation out of reach: the hand axis T[:3, 0] = {_fmt(hand)} "
                    f"leaves the vertical plane through the base axis and p = {_fmt(p)} m by "
                    f"{math.asin(min(1.0, abs(across))):.4g} rad; a 4-DOF arm keeps its hand axis in its arm plane"
                )
        elif math.hypot(hand[0], hand[1]) > POSE_TOL:
            psi = math.atan2(hand[1], hand[0])
        else:  # target on the base axis, hand vertical: theta1 is free; take it from the plane normal
            psi = math.atan2(self.sigma * normal[0], -self.sigma * normal[1])
        out: list[tuple[np.ndarray, str]] = []
        distances = []
        for t1, side in ((psi, "front"), (psi + math.pi, "back")):
            c1, s1 = math.cos(t1), math.sin(t1)
            X = c1 * p[0] + s1 * p[1] - self.a1
            Y = self.sigma * (p[2] - self.d1)
            alpha = math.atan2(self.sigma * hand[2], c1 * hand[0] + s1 * hand[1])
            wx, wy = X - self.a4 * math.cos(alpha), Y - self.a4 * math.sin(alpha)
            distances.append(math.hypot(wx, wy))
            try:
                sols = _planar_solutions(self.desc.name, p, wx, wy, self.a2, self.a3, "wrist point")
            except WorkspaceError:
                continue
            out.extend((np.array([t1, t2, t3, alpha - t2 - t3]), f"{side}/{label}") for t2, t3, label in sols)
        if not out:
            lo, hi = abs(abs(self.a2) - abs(self.a3)), abs(self.a2) + abs(self.a3)
            raise _reach_error(self.desc.name, p, "wrist point", distances[0], lo, hi,
                               f" (joint 2; reaching over the base axis it would be at {distances[1]:.4g} m)")
        return out

    def singular_conditions(self, theta: np.ndarray, tol: float) -> list[str]:
        t2, t3, t4 = theta[1], theta[2], theta[3]
        reasons = _elbow_reason(3, float(t3), tol)
        r = self.a1 + self.a2 * math.cos(t2) + self.a3 * math.cos(t2 + t3) + self.a4 * math.cos(t2 + t3 + t4)
        if abs(r) < tol * self.length_scale:
            reasons.append("end point on the base axis (its distance from joint 1 is 0): joint 1 only spins "
                           "the hand about it, the end cannot move across the arm plane")
        return reasons


@dataclass(frozen=True)
class SphericalRRP(ClosedForm):
    """Spherical RRP arm (Stanford arm without wrist, seed 004), shoulder offset d2.

    ``p = [c1 s2 d3 - d2 s1, s1 s2 d3 + d2 c1, d1 + c2 d3]``: position only (3 joints).
    With ``u = s2 d3 = +-sqrt(x^2 + y^2 - d2^2)`` and ``d3 = +-sqrt(u^2 + (z - d1)^2)``
    there are four solutions: ``"shoulder-left"``/``"shoulder-right"`` (seen from above,
    the offset d2 lies left/right of the line from the base axis to the target;
    ``"front"``/``"back"`` when d2 = 0), each also with ``"/negative-stroke"`` (boom turned
    by pi, d3 < 0), which is outside the limits of a stroke that starts at 0.
    """

    d1: float = 0.0
    d2: float = 0.0

    kind: ClassVar[str] = "spherical"
    task_labels: ClassVar[tuple[str, ...]] = ("x", "y", "z")
    _task_rows: ClassVar[tuple[int, ...]] = (0, 1, 2)
    ikine_mask: ClassVar[tuple[float, ...]] = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0)
    pose_components: ClassVar[str] = "position only (3 joints cannot also set the orientation)"
    pattern: ClassVar[str] = "spherical (RRP, alpha = [-pi/2, pi/2, any], a1 = a2 = a3 = 0)"

    @classmethod
    def match(cls, desc: RobotDescription) -> "SphericalRRP | None":
        if desc.joint_types != "RRP":
            return None
        l1, l2, l3 = desc.links
        if not (_near(l1.alpha, -math.pi / 2) and _near(l2.alpha, math.pi / 2)
                and _near(l1.a, 0.0) and _near(l2.a, 0.0) and _near(l3.a, 0.0)):
            return None
        return cls(desc, d1=l1.d, d2=l2.d)

    def solve(self, T: np.ndarray) -> list[tuple[np.ndarray, str]]:
        p = T[:3, 3]
        x, y, z = p[0], p[1], p[2] - self.d1
        rho = math.hypot(x, y)
        off = abs(self.d2)
        u2 = (rho - off) * (rho + off)
        if u2 < -_COS_TOL * max(1.0, off * off):
            raise WorkspaceError(
                f"{self.desc.name}: target p = {_fmt(p)} m out of reach: at distance {rho:.4g} m from the joint-1 axis, "
                f"reachable range [{off:.4g}, inf) m: the shoulder offset d2 = {self.d2:.4g} m keeps the tool "
                f"outside a cylinder of that radius about joint 1"
            )
        u_abs = math.sqrt(max(u2, 0.0))
        out = []
        for u_sign in (1.0, -1.0):
            u = u_sign * u_abs
            t1 = math.atan2(y, x) - math.atan2(self.d2, u)
            if self.d2 != 0.0:
                side = "shoulder-left" if self.d2 * u_sign > 0 else "shoulder-right"
            else:
                side = "front" if u_sign > 0 else "back"
            for d_sign, suffix in ((1.0, ""), (-1.0, "/negative-stroke")):
                d3 = d_sign * math.hypot(u, z)
                t2 = math.atan2(d_sign * u, d_sign * z)
                out.append((np.array([t1, t2, d3]), side + suffix))
        return out

    def singular_conditions(self, theta: np.ndarray, tol: float) -> list[str]:
        t2, d3 = float(theta[1]), float(theta[2])
        reasons = []
        if abs(math.sin(t2)) < tol:
            which = "0" if math.cos(t2) > 0 else "pi"
            reasons.append(f"boom parallel to the joint-1 axis (theta2 = {which}): joints 1 and 2 move the tool "
                           "in the same direction, it cannot move along the shoulder offset z1")
        if abs(d3) < tol * self.length_scale:
            reasons.append("boom retracted to d3 = 0: joint 2 does not move the tool")
        return reasons


#: Registry, most specific first; :func:`closed_form_for` returns the first match.
STRUCTURES: tuple[type[ClosedForm], ...] = (Scara, Planar3R, Planar2R, Arm4, SphericalRRP)


def closed_form_for(desc: RobotDescription) -> ClosedForm | None:
    """The recognised structure of ``desc`` with its geometry, or None (always None unless standard DH)."""
    if desc.convention != "standard":
        return None
    for cls in STRUCTURES:
        found = cls.match(desc)
        if found is not None:
            return found
    return None


def require_closed_form(desc: RobotDescription) -> ClosedForm:
    """As :func:`closed_form_for`, but raise :class:`NoClosedFormError` naming the robot if none fits."""
    found = closed_form_for(desc)
    if found is None and desc.convention != "standard":
        raise NoClosedFormError(
            f"robot {desc.name!r} (convention {desc.convention!r}): closed-form inverse kinematics is recognised "
            "from standard DH tables only; use the numeric ikine"
        )
    if found is None:
        known = "; ".join(cls.pattern for cls in STRUCTURES)
        raise NoClosedFormError(
            f"robot {desc.name!r} (joints {desc.joint_types}): no closed-form inverse kinematics, its DH table "
            f"matches none of the known structures ({known}); use the numeric ikine"
        )
    return found
