"""Kinematic singularities: manipulability and a worded singularity report.

The task rows a robot can control come from :mod:`model.closed_form` when its
structure is recognised (a SCARA controls x, y, z and yaw, never roll and pitch,
so its full 6 x 4 Jacobian is rank-deficient everywhere and is not the measure);
otherwise all six rows of ``jacob0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .closed_form import chain_jacobian, closed_form_for, joint_values
from .errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from .arm import KinematicArm

__all__ = ["SingularityReport", "manipulability", "singularities", "task_jacobian", "AXES"]

_ROW_NAMES = ("x", "y", "z", "rx", "ry", "rz")
#: Row selections of ``jacob0`` by name.
AXES = {"all": (0, 1, 2, 3, 4, 5), "trans": (0, 1, 2), "rot": (3, 4, 5)}


def task_jacobian(robot: "KinematicArm", q: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
    """(m, n) task Jacobian at ``q`` and the names of its m rows.

    The recognised structure's task rows (e.g. ``("x", "y", "z", "rz")`` for a
    SCARA, ``("x", "y", "z", "pitch")`` for arm4) of the frame-0 Jacobian of DH frame n
    (:func:`model.closed_form.chain_jacobian`: base and tool removed), else all six rows of ``jacob0``.
    """
    J0 = robot.jacob0(q)
    form = closed_form_for(robot.description)
    if form is None:
        return J0, _ROW_NAMES
    return form.task_jacobian(chain_jacobian(robot.description, robot.fkine(q), J0)), form.task_labels


def _rows(robot: "KinematicArm", q: np.ndarray, axes: Sequence[bool] | str) -> np.ndarray:
    if isinstance(axes, str):
        if axes == "task":
            return task_jacobian(robot, q)[0]
        if axes not in AXES:
            raise InputError(f"expected 'all', 'trans', 'rot', 'task' or 6 booleans, got {axes!r}", parameter="axes")
        return robot.jacob0(q)[list(AXES[axes])]
    mask = np.asarray(axes)
    if mask.shape != (6,) or mask.dtype.kind not in "bi" or not np.all((mask == 0) | (mask == 1)) or not mask.any():
        raise InputError(f"expected 6 booleans selecting rows of [x y z rx ry rz], at least one true; got {axes!r}",
                         parameter="axes")
    return robot.jacob0(q)[mask.astype(bool)]


def manipulability(robot: "KinematicArm", q: np.ndarray, axes: Sequence[bool] | str = "task") -> float:
    """Yoshikawa manipulability ``sqrt(det(J J^T))`` of selected rows J of ``jacob0(q)``.

    Parameters
    ----------
    robot
        The robot.
    q
        (n,) joint values, rad or m.
    axes
        ``"all"`` (6 rows), ``"trans"`` (v, m/s), ``"rot"`` (omega, rad/s), ``"task"``
        (the rows the structure controls, see :func:`task_jacobian`), or 6
        booleans on [x y z rx ry rz].

    Returns
    -------
    float
        The product of the singular values of J when it has no more rows than
        joints; 0 when it has more (``J J^T`` is then singular), e.g. ``"all"`` for
        a robot with fewer than 6 joints. Units: product of the rows' units.
    """
    J = _rows(robot, q, axes)
    m, n = J.shape
    if m > n:
        return 0.0
    return float(np.prod(np.linalg.svd(J, compute_uv=False)))


@dataclass(frozen=True, eq=False)
class SingularityReport:
    """Whether a configuration is singular, and why.

    Attributes
    ----------
    singular
        ``rank < min(m, n)`` of the task Jacobian.
    rank
        Singular values above ``tol`` times the largest.
    task
        Names of the m task rows used.
    singular_values
        (min(m, n),) singular values of the task Jacobian, descending.
    manipulability
        Product of those singular values (``sqrt(det(J J^T))`` for m <= n).
    null_space
        (k, n) unit joint motions that move no task coordinate (to first order);
        k = 0 rows when the task Jacobian has full row rank and m >= n.
    reasons
        Empty when not singular; otherwise the rank deficiency, then every named
        condition of the structure that holds (e.g. "elbow stretched (theta2 = 0) ...").
    """

    singular: bool
    rank: int
    task: tuple[str, ...]
    singular_values: np.ndarray
    manipulability: float
    null_space: np.ndarray
    reasons: list[str]


def singularities(robot: "KinematicArm", q: np.ndarray, tol: float = 1e-6) -> SingularityReport:
    """Singularity report of ``robot`` at ``q`` (n,), rad or m.

    A singular value counts as zero when it is at most ``tol`` times the largest.
    The same ``tol`` bounds the named conditions: ``|sin(angle)| < tol`` and
    lengths below ``tol`` times the robot's size.
    """
    J, labels = task_jacobian(robot, q)
    m, n = J.shape
    U, S, Vt = np.linalg.svd(J)
    threshold = tol * (S[0] if S.size else 0.0)
    rank = int(np.sum(S > threshold)) if S.size and S[0] > 0 else 0
    null = Vt[rank:]
    singular = rank < min(m, n)
    reasons: list[str] = []
    if singular:
        motion = ", ".join(f"{v:+.3g}" for v in null[0])
        reasons.append(
            f"task Jacobian ({m} x {n}, rows {' '.join(labels)}) has rank {rank} < {min(m, n)}: smallest singular "
            f"value {S[-1]:.3g} <= {tol:g} x largest {S[0]:.3g}; joint motion [{motion}] moves no task coordinate"
        )
        form = closed_form_for(robot.description)
        if form is not None:
            reasons.extend(form.singular_conditions(joint_values(robot.description, q), tol))
    return SingularityReport(
        singular=singular, rank=rank, task=labels, singular_values=S,
        manipulability=float(np.prod(S)), null_space=null, reasons=reasons,
    )
