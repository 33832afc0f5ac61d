"""Inverse kinematics: closed form (:func:`ikine_a`) and numeric Levenberg-Marquardt (:func:`ikine`).

Poses are ``T_WE``, the tool frame E in the world frame W (4, 4), m and rad, as ``fkine`` returns
them (W is the robot's frame 0 when it states no ``base`` pose). The
closed forms and the per-structure knowledge live in :mod:`model.closed_form`;
closed-loop inverse kinematics along a path is in :mod:`model.clik`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from .closed_form import (
    IKSolution,
    NoClosedFormError,
    WorkspaceError,
    chain_target,
    closed_form_for,
    require_closed_form,
)
from .errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from .arm import KinematicArm

__all__ = [
    "IKSolution",
    "IKResult",
    "WorkspaceError",
    "NoClosedFormError",
    "ikine_a",
    "ikine",
    "pose_error",
    "default_mask",
    "POSE_COMPONENTS",
]

_REPRODUCE_TOL = 1e-6
#: Span of the random restarts of a joint without limits: rad (revolute) or m (prismatic).
_FREE_SPAN = {True: (-math.pi, math.pi), False: (-1.0, 1.0)}


def _check_pose(T: Any) -> np.ndarray:
    arr = np.asarray(T, dtype=float)
    if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
        raise InputError(f"expected a finite (4, 4) homogeneous transform, got shape {arr.shape}", parameter="T")
    R = arr[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise InputError("expected a rotation block with orthonormal columns and det +1 (tolerance 1e-6)",
                         parameter="T")
    return arr


def pose_error(T: np.ndarray, T_d: np.ndarray) -> np.ndarray:
    """(6,) error of pose ``T`` from the desired ``T_d``, both (4, 4) in the world frame W.

    ``[p_d - p; w]`` with ``w`` the rotation vector (angle-axis, log map) of
    ``R_d R^T``: the rotation that takes ``R`` to ``R_d``, W axes. m, rad.
    """
    from scipy.spatial.transform import Rotation  # scipy is imported by the functions that use it

    e = np.empty(6)
    e[:3] = T_d[:3, 3] - T[:3, 3]
    e[3:] = Rotation.from_matrix(T_d[:3, :3] @ T[:3, :3].T).as_rotvec()
    return e


# --------------------------------------------------------------------------- closed form


def ikine_a(robot: "KinematicArm", T: np.ndarray) -> list[IKSolution]:
    """Every closed-form inverse-kinematics solution of pose ``T``.

    Parameters
    ----------
    robot
        A robot whose DH table matches a structure of :mod:`model.closed_form`
        (scara, planar3r, planar2r, arm4, spherical, or the same geometry).
    T
        (4, 4) target pose ``T_0E``, m. Which of its components are used depends on
        the structure (``ClosedForm.pose_components``): scara position and tool
        heading; planar3r x, y and in-plane angle; arm4 position and hand axis;
        planar2r and spherical the position only.

    Returns
    -------
    list of IKSolution
        One per branch, in a fixed order with fixed labels. Solutions outside the
        joint limits are kept, with ``within_limits=False``. At the boundary of
        the workspace two branches coincide and both are returned.

    Raises
    ------
    NoClosedFormError
        The robot matches no known structure.
    WorkspaceError
        The target is out of reach; the message says which distance or angle is
        outside which range.
    """
    T = _check_pose(T)
    form = require_closed_form(robot.description)
    qlim = robot.qlim
    out = []
    for theta, label in form.solve(chain_target(robot.description, T)):
        q = form.to_q(theta)
        within = bool(np.all(q >= qlim[0]) and np.all(q <= qlim[1]))
        reproduced = float(np.abs(pose_error(robot.fkine(q), T)).max()) <= _REPRODUCE_TOL
        out.append(IKSolution(q=q, branch=label, within_limits=within, reproduces_pose=reproduced))
    return out


# --------------------------------------------------------------------------- numeric


#: Names of the six pose-error components, in the order of :func:`pose_error` and of ``mask``:
#: position error along the world x, y, z axes (m), then the rotation-vector components about
#: them (rad; for small errors the roll, pitch and yaw errors).
POSE_COMPONENTS: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")


def _component_list(names: Sequence[str], values: np.ndarray) -> str:
    units = {"x": "m", "y": "m", "z": "m"}
    return ", ".join(f"{k} {v:.3g} {units.get(k, 'rad')}" for k, v in zip(names, values))


@dataclass(frozen=True, eq=False)
class IKResult:
    """Outcome of the numeric :func:`ikine`.

    Attributes
    ----------
    q
        (n,) best joint values found, rad or m.
    success
        With the default mask (``mask_given`` False): whether the *full* pose is reached,
        ``|error| < tol`` over all six components, so a target the structure cannot reach
        (a tilted SCARA pose) is not a success. With a mask given: whether the weighted
        residual over the masked components fell below ``tol``; the other components are
        named in :attr:`ignored` and their miss is in :attr:`error`.
    iterations
        Levenberg-Marquardt iterations, summed over all searches.
    searches
        Searches started (the first from ``q0``, then seeded random restarts).
    residual
        ``sqrt(e^T W e)`` at ``q``: the masked pose error (m and rad mixed).
    reason
        ``"converged"`` when every component is solved and reached; otherwise what was
        solved, what was ignored and by how much it is missed, or why the search failed.
    mask
        (6,) weights used on :data:`POSE_COMPONENTS`.
    mask_given
        Whether the caller passed ``mask`` (False: the structure's default, :func:`default_mask`).
    error
        (6,) full pose error :func:`pose_error` at ``q`` on :data:`POSE_COMPONENTS`, m and rad,
        ignored components included.
    """

    q: np.ndarray
    success: bool
    iterations: int
    searches: int
    residual: float
    reason: str
    mask: np.ndarray
    mask_given: bool
    error: np.ndarray

    @property
    def solved(self) -> tuple[str, ...]:
        """Names of the components the search solved for (weight > 0), e.g. ``("x", "y", "z", "rz")``."""
        return tuple(k for k, w in zip(POSE_COMPONENTS, self.mask) if w > 0)

    @property
    def ignored(self) -> tuple[str, ...]:
        """Names of the components the mask ignored (weight 0), e.g. ``("rx", "ry")`` for a SCARA."""
        return tuple(k for k, w in zip(POSE_COMPONENTS, self.mask) if w == 0)

    @property
    def ignored_error(self) -> dict[str, float]:
        """Signed error of each ignored component at ``q``: m (x, y, z) or rad (rx, ry, rz)."""
        return {k: float(e) for k, e, w in zip(POSE_COMPONENTS, self.error, self.mask) if w == 0}

    @property
    def position_error(self) -> float:
        """``|p_d - p|`` over all three axes, m (ignored axes included)."""
        return float(np.linalg.norm(self.error[:3]))

    @property
    def rotation_error(self) -> float:
        """Angle of the rotation from the reached to the target orientation, rad (ignored axes included)."""
        return float(np.linalg.norm(self.error[3:]))

    def summary(self) -> str:
        """One line for a person: success or not, then :attr:`reason`."""
        return f"ikine {'succeeded' if self.success else 'failed'}: {self.reason}"


def _aligned(desc) -> bool:
    """Whether the structure's task rows are world rows: no tool, base turned about z at most."""
    return bool(np.array_equal(desc.T_tool, np.eye(4)) and np.allclose(desc.T_base[:3, 2], [0.0, 0.0, 1.0], atol=1e-12))


def default_mask(robot: "KinematicArm") -> np.ndarray:
    """(6,) default ``ikine`` weights on [x y z rx ry rz] for ``robot``.

    The task of a recognised structure (e.g. x, y, z, yaw for a SCARA) when its rows are
    world rows (no tool, base turned about z at most), all six for any robot with 6 or more joints.

    Raises
    ------
    model.errors.InputError
        Fewer than 6 joints and no recognised structure: give a mask.
    """
    form = closed_form_for(robot.description)
    if form is not None and _aligned(robot.description):
        return np.array(form.ikine_mask)
    if robot.n >= 6:
        return np.ones(6)
    raise InputError(
        f"robot {robot.name!r} has {robot.n} joints and no recognised structure aligned with the world axes, "
        f"so there is no default; "
        f"give 6 weights on [x y z rx ry rz] that select the components to solve (at most {robot.n})",
    parameter="mask")


def _check_mask(mask: Sequence[float]) -> np.ndarray:
    w = np.asarray(mask, dtype=float).reshape(-1)
    if w.shape != (6,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not np.any(w > 0):
        raise InputError(f"expected 6 finite weights >= 0 on [x y z rx ry rz], not all 0; got {mask!r}",
                         parameter="mask")
    return w


def ikine(
    robot: "KinematicArm",
    T: np.ndarray,
    q0: np.ndarray | None = None,
    mask: Sequence[float] | None = None,
    *,
    ilimit: int = 60,
    slimit: int = 30,
    tol: float = 1e-10,
    damping: float = 1e-2,
    joint_limits: bool = True,
    seed: int = 0,
) -> IKResult:
    """Numeric inverse kinematics by Levenberg-Marquardt (damped least squares) with restarts.

    Minimises ``e^T W e`` with ``e`` = :func:`pose_error` of ``fkine(q)`` from ``T``
    (world frame) and ``W = diag(mask)``. Step ``dq = (J^T W J + lambda I)^-1 J^T W e``
    with ``J = jacob0(q)``; lambda starts at ``damping`` and is divided by 10 after a
    step that lowers the error, multiplied by 10 after one that does not.

    Parameters
    ----------
    robot
        The robot.
    T
        (4, 4) target pose ``T_0E``, m.
    q0
        (n,) first initial guess, rad or m; default the robot's rest configuration.
    mask
        6 weights >= 0 on the error components :data:`POSE_COMPONENTS` (x y z rx ry rz);
        components of weight 0 are ignored by the search. Default :func:`default_mask`
        (the components the structure controls, e.g. x, y, z, rz for a SCARA).
    ilimit
        Iterations per search.
    slimit
        Searches: the first from ``q0``, the others from seeded uniform random
        configurations within ``qlim`` (+-pi rad or +-1 m where a joint has none).
    tol
        Tolerance, m and rad: on ``sqrt(e^T W e)`` for the search, and with the default
        mask also on ``|e|`` over all six components for success.
    damping
        Initial Levenberg-Marquardt damping lambda (units of J^T W J).
    joint_limits
        Project every iterate into ``qlim``.
    seed
        Seed of the random restarts.

    Returns
    -------
    IKResult
        ``success`` means the full pose is reached (default mask) or the masked
        components are (mask given); :attr:`IKResult.ignored` names the components a
        mask ignored and :attr:`IKResult.error` gives their miss. A search that solves
        the masked components but misses the ignored ones (a branch with another
        orientation) is restarted while searches remain, unless the structure fixes
        those components (every joint axis along the world z axis: a SCARA's roll and
        pitch, a planar arm's z), which proves the target unreachable at once. Without success the reason
        says why: the masked components converged but the target is outside what the
        structure can reach (with the misses), or the best residual, joints at a
        limit, likely out of reach.
    """
    T = _check_pose(T)
    n = robot.n
    mask_given = mask is not None
    W = _check_mask(default_mask(robot) if mask is None else mask)
    q_start = robot.q_rest if q0 is None else np.asarray(q0, dtype=float).reshape(n)
    qlim = robot.qlim
    lo = np.where(np.isfinite(qlim[0]), qlim[0], [(_FREE_SPAN[lk.is_revolute][0]) for lk in robot.description.links])
    hi = np.where(np.isfinite(qlim[1]), qlim[1], [(_FREE_SPAN[lk.is_revolute][1]) for lk in robot.description.links])
    rng = np.random.default_rng(seed)

    def project(q: np.ndarray) -> np.ndarray:
        return np.clip(q, qlim[0], qlim[1]) if joint_limits else q

    def weighted(q: np.ndarray) -> tuple[np.ndarray, float]:
        e = pose_error(robot.fkine(q), T)
        return e, float(e @ (W * e))

    def result(q: np.ndarray, e: np.ndarray, E: float, success: bool, searches: int, reason: str) -> IKResult:
        return IKResult(q=q, success=success, iterations=iterations, searches=searches, residual=math.sqrt(E),
                        reason=reason, mask=W.copy(), mask_given=mask_given, error=e)

    best_q, best_E = project(q_start), math.inf
    # With the default mask, the masked solution closest to the full pose (its q, e, E).
    partial: tuple[np.ndarray, np.ndarray, float] | None = None
    iterations = 0
    for search in range(max(1, slimit)):
        q = project(q_start if search == 0 else rng.uniform(lo, hi))
        e, E = weighted(q)
        lam = damping
        for _ in range(ilimit):
            if math.sqrt(E) < tol:
                break
            iterations += 1
            J = robot.jacob0(q)
            JtW = J.T * W
            dq = np.linalg.solve(JtW @ J + lam * np.eye(n), JtW @ e)
            q_new = project(q + dq)
            e_new, E_new = weighted(q_new)
            if E_new < E:
                q, e, E = q_new, e_new, E_new
                lam = max(lam / 10.0, 1e-12)
            else:
                lam = min(lam * 10.0, 1e12)
        if E < best_E:
            best_q, best_E = q, E
        if math.sqrt(E) < tol:
            q = _tidy(robot, q, joint_limits)
            full = float(np.linalg.norm(e))
            if mask_given or full < tol:
                return result(q, e, E, True, search + 1, _converged_reason(W, e, mask_given))
            if partial is None or full < float(np.linalg.norm(partial[1])):
                partial = (q, e, E)
            if _fixed_by_structure(robot.jacob0(q), W):
                return result(*partial, False, search + 1,
                              _unreachable_reason(robot, W, partial[1], tol, search + 1, proven=True))
    searches = max(1, slimit)
    if partial is not None:
        q, e, E = partial
        return result(q, e, E, False, searches, _unreachable_reason(robot, W, e, tol, searches))
    e, _ = weighted(best_q)
    return result(best_q, e, best_E, False, searches,
                  _failure_reason(robot, best_q, W, e, best_E, tol, slimit, ilimit))


def _tidy(robot: "KinematicArm", q: np.ndarray, joint_limits: bool) -> np.ndarray:
    """Revolute joints without limits wrapped to [-pi, pi]; others as found."""
    q = q.copy()
    for i, lk in enumerate(robot.description.links):
        if lk.is_revolute and (lk.qlim is None or not joint_limits):
            q[i] = math.remainder(q[i], 2.0 * math.pi)
    return q


def _names(W: np.ndarray, solved: bool) -> list[str]:
    return [k for k, w in zip(POSE_COMPONENTS, W) if (w > 0) == solved]


def _converged_reason(W: np.ndarray, e: np.ndarray, mask_given: bool) -> str:
    ignored = _names(W, solved=False)
    if not ignored:
        return "converged"
    misses = _component_list(ignored, np.abs(e[W == 0]))
    if not mask_given:  # the full pose is reached: the ignored components agree within tol
        return f"converged on {', '.join(_names(W, True))}; the default mask ignored {', '.join(ignored)} ({misses})"
    return (f"converged on the masked components {', '.join(_names(W, True))}; "
            f"ignored by the given mask: {', '.join(ignored)}, missed by {misses}")


#: A Jacobian entry at most this large counts as zero in :func:`_fixed_by_structure` (m or rad per
#: joint unit): over joint ranges of a few rad or m it moves a component by ~1e-11, below ``tol``.
_ZERO_ROW = 1e-12


def _fixed_by_structure(J: np.ndarray, W: np.ndarray) -> bool:
    """Whether no configuration changes the ignored components, so restarts cannot reach the full pose.

    Shown from ``J = jacob0(q)`` at one q: rows w_x and w_y zero means every revolute axis is
    along the world z axis here, hence everywhere (each axis is turned only by the joints before
    it, all about z). The orientation is then ``Rz(phi) R_c``: a target reachable in orientation
    gives rx = ry = 0 at *every* q, so a miss in rx or ry proves it unreachable; and row v_z zero
    means z is constant. Any other ignored component (x, y, rz: a branch may change it) -> False.
    """
    if np.abs(J[3:5]).max() > _ZERO_ROW:
        return False
    ignored = np.flatnonzero(W == 0)
    return all(k in (3, 4) or (k == 2 and np.abs(J[2]).max() <= _ZERO_ROW) for k in ignored)


def _unreachable_reason(robot: "KinematicArm", W: np.ndarray, e: np.ndarray, tol: float, searches: int,
                        proven: bool = False) -> str:
    ignored = _names(W, solved=False)
    form = closed_form_for(robot.description)
    structure = f"the {form.kind} structure of {robot.name!r}" if form is not None else repr(robot.name)
    why = ("no configuration changes them: every joint axis is along the world z axis"
           if proven else f"best of {searches} searches")
    return (f"the target pose is outside what {structure} can reach: the search solved "
            f"{', '.join(_names(W, True))} (residual < {tol:g}), but the components it cannot control, "
            f"{', '.join(ignored)}, are missed by {_component_list(ignored, np.abs(e[W == 0]))} "
            f"({why}); pass mask={W.tolist()} to accept a solution of the controlled components only")


def _failure_reason(robot: "KinematicArm", q: np.ndarray, W: np.ndarray, e: np.ndarray, E: float,
                    tol: float, slimit: int, ilimit: int) -> str:
    pos = float(np.linalg.norm(np.sqrt(W[:3]) * e[:3]))
    rot = float(np.linalg.norm(np.sqrt(W[3:]) * e[3:]))
    text = (f"no solution with residual < {tol:g} in {slimit} searches of {ilimit} iterations "
            f"(from q0 and seeded random starts): best residual {math.sqrt(E):.3g}, "
            f"position error {pos:.3g} m, rotation error {rot:.3g} rad on the masked components")
    ignored = _names(W, solved=False)
    if ignored:
        text += f" ({', '.join(_names(W, True))}); ignored: {_component_list(ignored, np.abs(e[W == 0]))}"
    qlim = robot.qlim
    at_limit = [i + 1 for i in range(robot.n)
                if np.isfinite(qlim[0, i]) and (abs(q[i] - qlim[0, i]) < 1e-9 or abs(q[i] - qlim[1, i]) < 1e-9)]
    if at_limit:
        text += f"; joints {at_limit} end at a limit"
    if math.sqrt(E) > 1e-3:
        text += "; the target is probably outside the workspace"
    return text
