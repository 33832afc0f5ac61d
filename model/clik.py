"""Closed-loop inverse kinematics (CLIK) of a tool position along a path.

``qd = J#(q) (pd_d + K e)``, ``e = p_d - p(q)``, integrated by forward Euler at
times ``t0 + k dt`` (integer k), as in the seed report 004 (spherical RRP arm
on a straight segment). ``J`` is the position part of ``jacob0``, world frame
(the base frame when the robot states no base pose).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Sequence

import numpy as np

from .trajectory import straight_line
from .errors import InputError, NumericalError

if TYPE_CHECKING:  # pragma: no cover
    from .robot import Robot

__all__ = [
    "CLIKResult",
    "clik",
    "seed_clik_task",
    "INVERSIONS",
    "SEED_Q0",
    "SEED_P_FINAL",
    "SEED_TF",
    "SEED_DT",
    "SEED_K",
    "SEED_DAMPING",
]

#: Ways to invert the task Jacobian: inverse (square J), Moore-Penrose pseudo-inverse,
#: transpose (``qd = J^T K e``, no feed-forward) and damped least squares.
INVERSIONS = ("inverse", "pinv", "transpose", "dls")

#: Seed 004: initial configuration [theta1 rad, theta2 rad, d3 m].
SEED_Q0 = (0.0, math.pi / 4, 0.5)
#: Seed 004: end point of the segment, m (reached only at q = [pi/4, 0, 0.1], a singularity).
SEED_P_FINAL = (-math.sqrt(2) / 2, math.sqrt(2) / 2, 0.1)
#: Seed 004: duration of the segment, s.
SEED_TF = 4.0
#: Seed 004: Euler step, s.
SEED_DT = 2e-3
#: CLIK gain, 1/s. Assumed (the seed's excerpt gives none): K dt = 0.1, a tenth of
#: the Euler stability limit K dt < 2, error time constant 20 ms << t_f.
SEED_K = 50.0
#: Damping of the damped least squares (added to J J^T), m^2. Assumed: chosen as
#: (0.05 m)^2, so directions with singular value below 5 cm/rad are damped.
SEED_DAMPING = 2.5e-3


@dataclass(frozen=True, eq=False)
class CLIKResult:
    """Samples of a CLIK run on the grid ``t = t0 + k dt``, k = 0..N.

    Attributes
    ----------
    t
        (N+1,) time, s.
    q, qd
        (N+1, n) joint values (rad or m) and the commanded joint rates (rad/s or m/s).
    p, p_d
        (N+1, 3) tool position and desired position, world frame, m.
    error_norm
        (N+1,) ``|p_d - p|`` over the masked components, m.
    inversion
        The inversion used.
    mask
        (3,) booleans: the position components [x y z] the loop controlled; the others are
        named in :attr:`ignored`, and their miss is in :attr:`error` (``p_d - p``, all three).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    p: np.ndarray
    p_d: np.ndarray
    error_norm: np.ndarray
    inversion: str
    mask: np.ndarray

    @property
    def solved(self) -> tuple[str, ...]:
        """Names of the controlled components, e.g. ``("x", "y", "z")``."""
        return tuple(k for k, m in zip("xyz", self.mask) if m)

    @property
    def ignored(self) -> tuple[str, ...]:
        """Names of the position components the mask left uncontrolled."""
        return tuple(k for k, m in zip("xyz", self.mask) if not m)

    @property
    def error(self) -> np.ndarray:
        """(N+1, 3) position error ``p_d - p`` on all three axes, world frame, m (ignored axes included)."""
        return self.p_d - self.p

    @property
    def ignored_error_max(self) -> dict[str, float]:
        """Largest |error| over the run of each ignored component, m."""
        err = np.abs(self.error).max(axis=0)
        return {k: float(e) for k, e, m in zip("xyz", err, self.mask) if not m}

    @property
    def qd_max(self) -> np.ndarray:
        """(n,) largest |qd| of each joint over the run, rad/s or m/s."""
        return np.abs(self.qd).max(axis=0)

    @property
    def peak_joint_speed(self) -> float:
        """Largest |qd| of any joint over the run, rad/s or m/s (mixed units if joints differ)."""
        return float(self.qd_max.max())


def _gain(K: Any, m: int) -> np.ndarray:
    arr = np.asarray(K, dtype=float)
    if arr.ndim == 0:
        arr = arr * np.eye(m)
    elif arr.shape == (m,):
        arr = np.diag(arr)
    if arr.shape != (m, m) or not np.all(np.isfinite(arr)):
        raise InputError(f"expected a scalar, {m} values or an ({m}, {m}) matrix of gains in 1/s, got shape "
                         f"{np.shape(K)}", parameter="K")
    return arr


def clik(
    robot: "Robot",
    path: Callable[[float], tuple[np.ndarray, np.ndarray]],
    q0: Sequence[float],
    *,
    dt: float,
    K: Any,
    tf: float | None = None,
    t0: float | None = None,
    inversion: str = "pinv",
    damping: float = SEED_DAMPING,
    mask: Sequence[bool] = (True, True, True),
) -> CLIKResult:
    """Closed-loop inverse kinematics of the tool position along ``path``.

    Parameters
    ----------
    robot
        The robot; its end-frame origin is the tool point.
    path
        ``path(t) -> (p_d, pd_d)``: desired position (3,) m and velocity (3,) m/s, base
        frame, e.g. :func:`model.trajectory.straight_line`.
    q0
        (n,) initial joint values, rad or m.
    dt
        Euler step, s.
    K
        Gain, 1/s: scalar, (m,) or (m, m) over the masked components.
    tf, t0
        End and start time, s; default ``path.t0 + path.T`` and ``path.t0`` (0 if the
        path has no ``t0``). ``tf - t0`` must be an integer multiple of ``dt``.
    inversion
        ``"inverse"`` (needs as many masked components as joints), ``"pinv"``,
        ``"transpose"`` or ``"dls"`` (``J^T (J J^T + damping I)^-1``).
    damping
        Added to ``J J^T`` by ``"dls"``, m^2.
    mask
        3 booleans selecting the controlled components of [x y z].

    Returns
    -------
    CLIKResult

    Raises
    ------
    model.errors.InputError
        Bad arguments (a ``ValueError``; ``parameter`` names the argument).
    model.errors.NumericalError
        ``"inverse"`` meeting an exactly singular Jacobian.
    """
    if inversion not in INVERSIONS:
        raise InputError(f"expected one of {INVERSIONS}, got {inversion!r}", parameter="inversion")
    sel = np.asarray(mask, dtype=bool).reshape(-1)
    if sel.shape != (3,) or not sel.any():
        raise InputError(f"expected 3 booleans on [x y z], at least one true; got {mask!r}", parameter="mask")
    m, n = int(sel.sum()), robot.n
    if inversion == "inverse" and m != n:
        raise InputError(f"'inverse' needs a square task Jacobian, got {m} components for {n} joints; use 'pinv' "
                         "or 'dls'", parameter="inversion")
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise InputError(f"expected a step > 0 s, got {dt!r}", parameter="dt")
    if not damping >= 0:
        raise InputError(f"expected a value >= 0 m^2, got {damping!r}", parameter="damping")
    start = float(getattr(path, "t0", 0.0) if t0 is None else t0)
    if tf is None:
        if not hasattr(path, "T"):
            raise InputError("the path has no duration attribute T; give tf (s)", parameter="tf")
        tf = start + float(path.T)  # type: ignore[attr-defined]
    steps_float = (tf - start) / dt
    N = int(round(steps_float))
    if N < 1 or abs(steps_float - N) > 1e-9 * max(1.0, steps_float):
        raise InputError(f"tf - t0 = {tf - start!r} s: expected a positive integer multiple of dt = {dt!r} s")
    gain = _gain(K, m)
    q = np.asarray(q0, dtype=float).reshape(n).copy()
    t = start + dt * np.arange(N + 1)
    Q, QD = np.empty((N + 1, n)), np.empty((N + 1, n))
    P, PD, E = np.empty((N + 1, 3)), np.empty((N + 1, 3)), np.empty(N + 1)
    eye = np.eye(m)
    for k in range(N + 1):
        p_d, v_d = path(float(t[k]))
        p = robot.fkine(q)[:3, 3]
        J = robot.jacob0(q)[:3][sel]
        e = (np.asarray(p_d, dtype=float) - p)[sel]
        v = np.asarray(v_d, dtype=float)[sel] + gain @ e
        if inversion == "inverse":
            try:
                qd = np.linalg.solve(J, v)
            except np.linalg.LinAlgError as exc:
                raise NumericalError(f"inversion 'inverse': singular Jacobian at t = {t[k]:.6g} s, q = {q.tolist()}"
                                     ) from exc
        elif inversion == "pinv":
            qd = np.linalg.pinv(J) @ v
        elif inversion == "transpose":
            qd = J.T @ (gain @ e)
        else:
            qd = J.T @ np.linalg.solve(J @ J.T + damping * eye, v)
        Q[k], QD[k], P[k], PD[k], E[k] = q, qd, p, p_d, np.linalg.norm(e)
        q = q + dt * qd
    return CLIKResult(t=t, q=Q, qd=QD, p=P, p_d=PD, error_norm=E, inversion=inversion,
                      mask=sel.copy())


def seed_clik_task(
    inversion: str = "inverse",
    *,
    K: float = SEED_K,
    damping: float = SEED_DAMPING,
    dt: float = SEED_DT,
    profile: str = "quintic",
    robot: "Robot | None" = None,
) -> CLIKResult:
    """The CLIK task of seed report 004 on the built-in ``spherical`` arm.

    Straight segment from the tool position at ``q(0) = [0, pi/4, 0.5]``
    (``[sqrt(2)/4, 1, sqrt(2)/4]`` m) to ``p_f = [-sqrt(2)/2, sqrt(2)/2, 0.1]`` m in
    ``t_f = 4 s`` (time law ``profile``, default quintic: the excerpt does not say),
    Euler step 2 ms. Note that most of the segment (from 10.3 % of its length on)
    passes inside the cylinder of radius d2 = 1 m about joint 1, which the arm cannot
    reach; ``p_f`` itself is on that cylinder, at the singularity theta2 = 0.
    """
    from .robot import load_robot

    arm = load_robot("spherical") if robot is None else robot
    q0 = np.array(SEED_Q0)
    p0 = arm.fkine(q0)[:3, 3]
    segment = straight_line(p0, np.array(SEED_P_FINAL), SEED_TF, profile=profile)
    return clik(arm, segment, q0, dt=dt, K=K, tf=SEED_TF, t0=0.0, inversion=inversion, damping=damping)
