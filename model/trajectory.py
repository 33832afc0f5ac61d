"""Trajectories in SI time: joint-space point-to-point, via points, Cartesian lines.

Every planner returns a result object holding the samples on a time grid
*and* an evaluator usable at any time, so a 10 ms plot and a 1 kHz
closed-loop simulation read the same curve:

>>> from model.trajectory import jtraj
>>> traj = jtraj([0.0, 0.0], [1.0, 2.0], T=2.0, dt=0.01)   # 201 samples for a plot
>>> traj.q.shape
(201, 2)
>>> q, qd, qdd = traj.sample(0.0105)                       # a controller's instant
>>> fast = traj.resample(1e-3)                             # the same path on a 1 kHz grid

Joint paths are piecewise quintic Hermite polynomials (:class:`JointPath`):
each piece is fixed by position, velocity and acceleration at its two ends,
so quintic, trapezoidal (piecewise quadratic) and blended via-point profiles
share one evaluator, and every boundary value is reproduced exactly (the
basis polynomials have integer coefficients, so they are exactly 0 or 1 at
the ends of a piece). Outside its time span a path holds its end positions
with zero velocity and acceleration.

Sample times are ``t0 + k * dt`` for an integer counter k, never a running
sum; a duration must be an integer multiple of ``dt``.

Units: time s; joint values rad (revolute) or m (prismatic); positions m.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from .errors import InputError
from .limits import MAX_SAMPLES

__all__ = [
    "Trajectory",
    "JointPath",
    "CartesianTrajectory",
    "CartesianPath",
    "StraightLine",
    "time_grid",
    "SampleLimitError",
    "jtraj",
    "trapezoidal",
    "via_points",
    "ctraj",
    "straight_line",
    "ptp_synchronised",
]

Array = npt.NDArray[np.float64]

#: Relative tolerance for "T is an integer multiple of dt".
_GRID_RTOL = 1e-9
#: Tolerances for accepting a homogeneous transform (orthonormality, bottom row).
_POSE_TOL = 1e-9


class SampleLimitError(InputError):
    """A time grid would hold more than :data:`model.limits.MAX_SAMPLES` samples."""


# --------------------------------------------------------------------------- validation


def _scalar(value: Any, name: str, *, positive: bool = False) -> float:
    """A finite float (``> 0`` if ``positive``); ValueError naming ``name`` otherwise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"expected a number, got {value!r}", parameter=name)
    x = float(value)
    if not math.isfinite(x):
        raise InputError(f"expected a finite number, got {value!r}", parameter=name)
    if positive and x <= 0.0:
        raise InputError(f"expected a value > 0, got {value!r}", parameter=name)
    return x


def _vector(value: Any, name: str, n: int | None = None) -> Array:
    """A finite 1-D float array (of length ``n`` if given); ValueError naming ``name``."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"expected a vector of numbers, got {value!r}", parameter=name) from exc
    if arr.ndim != 1 or arr.size == 0:
        raise InputError(f"expected a 1-D vector, got an array of shape {arr.shape}", parameter=name)
    if n is not None and arr.shape != (n,):
        raise InputError(f"expected {n} values, got {arr.size}", parameter=name)
    if not np.all(np.isfinite(arr)):
        raise InputError(f"expected finite values, got {arr.tolist()}", parameter=name)
    return arr


def _times(value: Any, name: str = "t") -> Array:
    """Strictly increasing finite sample times, 1-D."""
    arr = _vector(value, name)
    if arr.size > 1 and not np.all(np.diff(arr) > 0):
        raise InputError("expected strictly increasing sample times", parameter=name)
    return arr


def _readonly(arr: Array) -> Array:
    out = np.array(arr, dtype=float)
    out.setflags(write=False)
    return out


def time_grid(T: float, dt: float, t0: float = 0.0) -> Array:
    """Uniform sample times ``t0 + k * dt``, ``k = 0 .. T/dt`` (both ends included).

    Parameters
    ----------
    T
        Duration, s (> 0); must be an integer multiple of ``dt`` (relative tolerance 1e-9).
    dt
        Sampling period, s (> 0).
    t0
        Start time, s.

    Returns
    -------
    (N,) array, N = T/dt + 1.

    Raises
    ------
    model.errors.InputError
        If a value is not finite or not positive, or T is not a multiple of dt.
    SampleLimitError
        If the grid would hold more than :data:`model.limits.MAX_SAMPLES` samples (checked before any is made).
    """
    T = _scalar(T, "T", positive=True)
    dt = _scalar(dt, "dt", positive=True)
    t0 = _scalar(t0, "t0")
    steps = T / dt
    if steps + 1 > MAX_SAMPLES:
        raise SampleLimitError(f"T = {T:g} s sampled every {dt:g} s: {steps + 1:.4g} samples, more than the sample "
                               f"limit of {MAX_SAMPLES}")
    m = round(steps)
    if m < 1 or abs(steps - m) > _GRID_RTOL * max(1.0, steps):
        raise InputError(f"T = {T!r} s is not an integer multiple of dt = {dt!r} s (T/dt = {steps!r})", parameter="dt")
    return t0 + np.arange(m + 1) * dt


def _sample_times(T: float, dt: float | None, t: Any, t0: float) -> tuple[Array, float | None]:
    if (dt is None) == (t is None):
        raise InputError("dt, t: give exactly one of dt (sampling period, s) or t (sample times, s), "
                         "or a sample count or a time vector in place of T")
    if t is not None:
        return _times(t), None
    return time_grid(T, dt, t0), float(dt)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- quintic Hermite basis
#
# On a piece of duration h with normalised time s in [0, 1], a quintic is fixed by
# position, velocity and acceleration at both ends:
#   q(s) = (1 - p) q_a + p q_b + h (g0 v_a + g1 v_b) + h^2 (k0 a_a + k1 a_b)
# with p = 10 s^3 - 15 s^4 + 6 s^5 and the basis below; derivatives are taken in s
# and divided by h per order. All coefficients are integers (or halves), so at
# s = 0 and s = 1 every basis value is exactly 0 or 1 in floating point.


def _basis(s: Array) -> tuple[Array, ...]:
    """Values and first/second s-derivatives of the six Hermite basis polynomials."""
    s2 = s * s
    p = s2 * s * (10.0 + s * (-15.0 + 6.0 * s))
    dp = s2 * (30.0 + s * (-60.0 + 30.0 * s))
    ddp = s * (60.0 + s * (-180.0 + 120.0 * s))
    g0 = s + s2 * s * (-6.0 + s * (8.0 - 3.0 * s))
    dg0 = 1.0 + s2 * (-18.0 + s * (32.0 - 15.0 * s))
    ddg0 = s * (-36.0 + s * (96.0 - 60.0 * s))
    g1 = s2 * s * (-4.0 + s * (7.0 - 3.0 * s))
    dg1 = s2 * (-12.0 + s * (28.0 - 15.0 * s))
    ddg1 = s * (-24.0 + s * (84.0 - 60.0 * s))
    k0 = 0.5 * (s2 + s2 * s * (-3.0 + s * (3.0 - s)))
    dk0 = 0.5 * (2.0 * s + s2 * (-9.0 + s * (12.0 - 5.0 * s)))
    ddk0 = 0.5 * (2.0 + s * (-18.0 + s * (36.0 - 20.0 * s)))
    k1 = 0.5 * s2 * s * (1.0 + s * (-2.0 + s))
    dk1 = 0.5 * s2 * (3.0 + s * (-8.0 + 5.0 * s))
    ddk1 = 0.5 * s * (6.0 + s * (-24.0 + 20.0 * s))
    return p, dp, ddp, g0, dg0, ddg0, g1, dg1, ddg1, k0, dk0, ddk0, k1, dk1, ddk1


class JointPath:
    """A C1 piecewise quintic path q(t), evaluable at any time.

    Piece k spans ``[breaks[k], breaks[k+1]]`` and is the quintic with position
    ``q[k] -> q[k+1]``, velocity ``qd[k] -> qd[k+1]`` and acceleration
    ``qdd_start[k] -> qdd_end[k]``: positions and velocities are continuous at the
    breaks, accelerations may jump (trapezoidal profiles). Before the first
    break the path holds ``q[0]``, after the last one ``q[-1]``, with zero
    velocity and acceleration.

    Parameters
    ----------
    breaks
        (K+1,) strictly increasing times, s.
    q, qd
        (K+1, n) positions (rad or m) and velocities (rad/s or m/s) at the breaks.
    qdd_start, qdd_end
        (K, n) accelerations at the start and the end of each piece, rad/s^2 or m/s^2.
    """

    def __init__(self, breaks: npt.ArrayLike, q: npt.ArrayLike, qd: npt.ArrayLike,
                 qdd_start: npt.ArrayLike, qdd_end: npt.ArrayLike) -> None:
        b = _times(breaks, "breaks")
        if b.size < 2:
            raise InputError(f"expected at least 2 times, got {b.size}", parameter="breaks")
        K = b.size - 1
        arrays = {}
        for name, value, rows in (("q", q, K + 1), ("qd", qd, K + 1), ("qdd_start", qdd_start, K), ("qdd_end", qdd_end, K)):
            arr = np.array(value, dtype=float)
            if arr.ndim != 2 or arr.shape[0] != rows:
                raise InputError(f"expected shape ({rows}, n), got {arr.shape}", parameter=name)
            if not np.all(np.isfinite(arr)):
                raise InputError("expected finite values", parameter=name)
            arrays[name] = arr
        n = arrays["q"].shape[1]
        for name, arr in arrays.items():
            if arr.shape[1] != n:
                raise InputError(f"expected {n} columns like q, got {arr.shape[1]}", parameter=name)
        self.breaks = _readonly(b)
        self.q = _readonly(arrays["q"])
        self.qd = _readonly(arrays["qd"])
        self.qdd_start = _readonly(arrays["qdd_start"])
        self.qdd_end = _readonly(arrays["qdd_end"])
        self._h = np.diff(b)
        self._breaks = b.tolist()

    def __repr__(self) -> str:
        return f"JointPath(n={self.n}, pieces={self.breaks.size - 1}, t=[{self.t_start:g}, {self.t_end:g}] s)"

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q.shape[1])

    @property
    def t_start(self) -> float:
        """Start time, s."""
        return float(self.breaks[0])

    @property
    def t_end(self) -> float:
        """End time, s."""
        return float(self.breaks[-1])

    @property
    def duration(self) -> float:
        """``t_end - t_start``, s."""
        return self.t_end - self.t_start

    def _piece(self, k: Any, h: Any, basis: tuple[Any, ...]) -> tuple[Array, Array, Array]:
        """Position, velocity and acceleration on piece(s) ``k`` of length(s) ``h`` from the ``basis`` values.

        The arithmetic of :meth:`__call__` (``k`` an int, ``h`` and the basis values
        floats) and of :meth:`batch` (``k`` an (N,) index array, ``h`` and the basis
        values (N, 1) columns).
        """
        p, dp, ddp, g0, dg0, ddg0, g1, dg1, ddg1, k0, dk0, ddk0, k1, dk1, ddk1 = basis
        qa, qb = self.q[k], self.q[k + 1]
        va, vb = self.qd[k], self.qd[k + 1]
        aa, ab = self.qdd_start[k], self.qdd_end[k]
        dq = qb - qa
        q = (1.0 - p) * qa + p * qb + h * (g0 * va + g1 * vb) + h * h * (k0 * aa + k1 * ab)
        qd = dp * dq / h + dg0 * va + dg1 * vb + h * (dk0 * aa + dk1 * ab)
        qdd = ddp * dq / (h * h) + (ddg0 * va + ddg1 * vb) / h + ddk0 * aa + ddk1 * ab
        return q, qd, qdd

    def __call__(self, t: float) -> tuple[Array, Array, Array]:
        """Position, velocity and acceleration at time ``t`` (s), each of shape (n,).

        The scalar form of :meth:`batch` (same arithmetic), cheap enough for a
        controller calling it every step.
        """
        tt = _scalar(t, "t")
        if tt < self._breaks[0] or tt > self._breaks[-1]:
            end = self.q[0] if tt < self._breaks[0] else self.q[-1]
            return end.copy(), np.zeros(self.n), np.zeros(self.n)
        k = min(bisect.bisect_right(self._breaks, tt) - 1, len(self._breaks) - 2)
        h = float(self._h[k])
        s = min(max((tt - self._breaks[k]) / h, 0.0), 1.0)
        return self._piece(k, h, _basis(s))  # type: ignore[arg-type]

    def batch(self, t: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """Position, velocity and acceleration at the (N,) times ``t`` (s), each of shape (N, n)."""
        tt = np.array(t, dtype=float)
        if tt.ndim != 1:
            raise InputError(f"expected a 1-D array of times, got shape {tt.shape}", parameter="t")
        if not np.all(np.isfinite(tt)):
            raise InputError("expected finite times", parameter="t")
        b = self.breaks
        k = np.clip(np.searchsorted(b, tt, side="right") - 1, 0, b.size - 2)
        h = self._h[k][:, None]
        s = np.clip((tt - b[k]) / self._h[k], 0.0, 1.0)
        Q, QD, QDD = self._piece(k, h, tuple(x[:, None] for x in _basis(s)))
        outside = (tt < b[0]) | (tt > b[-1])
        if np.any(outside):
            Q[tt < b[0]] = self.q[0]
            Q[tt > b[-1]] = self.q[-1]
            QD[outside] = 0.0
            QDD[outside] = 0.0
        return Q, QD, QDD


# --------------------------------------------------------------------------- result object


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A joint trajectory sampled in time, with the path it was sampled from.

    Attributes
    ----------
    t
        (N,) sample times, s.
    q, qd, qdd
        (N, n) positions (rad or m), velocities (/s) and accelerations (/s^2).
    path
        The :class:`JointPath` evaluator (any time, any rate).
    t_via
        (K+1,) times of the segment boundaries (start, via points, end), s.
    q_via
        (K+1, n) positions at those times.
    dt
        Sampling period, s, if ``t`` is a uniform grid ``t0 + k dt``; else None.
    name
        The planner that made it (``"jtraj"``, ``"trapezoidal"``, ``"via_points"``).
    """

    t: Array
    q: Array
    qd: Array
    qdd: Array
    path: JointPath
    t_via: Array
    q_via: Array
    dt: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        for name in ("t", "q", "qd", "qdd", "t_via", "q_via"):
            object.__setattr__(self, name, _readonly(getattr(self, name)))

    def __repr__(self) -> str:
        return (f"Trajectory({self.name!r}, N={self.t.size}, n={self.n}, segments={self.n_segments}, "
                f"t=[{self.path.t_start:g}, {self.path.t_end:g}] s, dt={self.dt})")

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q.shape[1])

    @property
    def n_segments(self) -> int:
        """Number of segments between via points (1 for a point-to-point move)."""
        return int(self.t_via.size - 1)

    @property
    def duration(self) -> float:
        """Duration of the path, s."""
        return self.path.duration

    def sample(self, t: float) -> tuple[Array, Array, Array]:
        """``(q, qd, qdd)`` at time ``t`` (s), each (n,), from the path (not interpolated samples)."""
        return self.path(t)

    def resample(self, dt: float) -> "Trajectory":
        """The same path on the grid ``t_start + k dt`` (e.g. 1 ms for a closed-loop simulation)."""
        t = time_grid(self.path.duration, dt, self.path.t_start)
        return _sampled(self.path, t, float(dt), self.t_via, self.q_via, self.name)


def _sampled(path: JointPath, t: Array, dt: float | None, t_via: Array, q_via: Array, name: str) -> Trajectory:
    q, qd, qdd = path.batch(t)
    return Trajectory(t=t, q=q, qd=qd, qdd=qdd, path=path, t_via=t_via, q_via=q_via, dt=dt, name=name)


# --------------------------------------------------------------------------- joint planners


def jtraj(q0: npt.ArrayLike, qf: npt.ArrayLike, T: Any, dt: float | None = None, *,
          t: npt.ArrayLike | None = None, t0: float = 0.0,
          qd0: npt.ArrayLike | None = None, qd1: npt.ArrayLike | None = None,
          qdf: npt.ArrayLike | None = None) -> Trajectory:
    """Quintic point-to-point joint trajectory, in SI time or in the Robotics Toolbox's forms.

    Each joint follows the quintic with the given boundary positions and
    velocities and zero boundary accelerations; with zero boundary velocities
    it is ``q0 + (qf - q0) (10 s^3 - 15 s^4 + 6 s^5)``, ``s = (t - t0)/T``.

    The third argument reads as in the Robotics Toolbox when neither ``dt`` nor ``t`` is given:

    * ``jtraj(q0, qf, 50)``, an integer: 50 samples on the normalised time ``t = 0 .. 1``
      (velocities and accelerations per unit of that time, as the toolbox's; its ``.t``
      is the same grid scaled by the count, ours is the grid itself);
    * ``jtraj(q0, qf, tv)``, a 1-D time vector, s: the path runs from 0 to ``max(tv)`` and is
      sampled at ``tv``.

    Otherwise it is the duration ``T`` in seconds, sampled every ``dt`` or at ``t``.

    Parameters
    ----------
    q0, qf
        (n,) start and end positions, rad or m.
    T
        Duration, s (> 0), with ``dt`` or ``t``; or, alone, a sample count (int >= 2) or a
        time vector (s) as above.
    dt
        Sampling period, s: samples at ``t0 + k dt``. Give either ``dt`` or ``t``.
    t
        (N,) sample times, s, strictly increasing.
    t0
        Start time, s.
    qd0, qd1
        (n,) start and end velocities, rad/s or m/s (default zero); ``qdf`` is another name
        for ``qd1``.

    Returns
    -------
    Trajectory
        ``.t`` (N,), ``.q``, ``.qd``, ``.qdd`` (N, n).

    Raises
    ------
    model.errors.InputError
        Naming the argument: shapes differ, a value is NaN/inf, ``T <= 0``,
        ``T`` not a multiple of ``dt``, a count below 2.
    """
    if qd1 is not None and qdf is not None:
        raise InputError("qd1, qdf: two names for the end velocity; give one")
    qd_end = qd1 if qd1 is not None else qdf
    if dt is None and t is None:
        if isinstance(T, (int, np.integer)) and not isinstance(T, (bool, np.bool_)):
            if T < 2:
                raise InputError(f"expected a sample count >= 2 (the toolbox's form), got {T!r}", parameter="T")
            return jtraj(q0, qf, 1.0, t=np.linspace(0.0, 1.0, int(T)), qd0=qd0, qd1=qd_end)
        if isinstance(T, (list, tuple, np.ndarray)) and np.ndim(T) == 1:
            times = _times(T, "T")
            if times[0] < 0.0:
                raise InputError(f"expected a time vector from 0 s on (the toolbox's form), got {times[0]!r} s first",
                                 parameter="T")
            return jtraj(q0, qf, float(times[-1]), t=times, qd0=qd0, qd1=qd_end)
    a = _vector(q0, "q0")
    n = a.size
    b = _vector(qf, "qf", n)
    T = _scalar(T, "T", positive=True)
    t0 = _scalar(t0, "t0")
    va = np.zeros(n) if qd0 is None else _vector(qd0, "qd0", n)
    vb = np.zeros(n) if qd_end is None else _vector(qd_end, "qd1" if qd1 is not None else "qdf", n)
    times, step = _sample_times(T, dt, t, t0)
    zero = np.zeros((1, n))
    path = JointPath([t0, t0 + T], np.vstack([a, b]), np.vstack([va, vb]), zero, zero)
    return _sampled(path, times, step, path.breaks, path.q, "jtraj")


def _trapezoid_fraction(delta: Array, T: float, cruise_fraction: float | None, v_max: Any, where: str) -> float:
    """Fraction of ``T`` spent at cruise velocity, from ``cruise_fraction`` or ``v_max``."""
    if cruise_fraction is not None and v_max is not None:
        raise InputError("cruise_fraction, v_max: give at most one of them")
    if v_max is None:
        c = 1.0 / 3.0 if cruise_fraction is None else _scalar(cruise_fraction, "cruise_fraction")
        if not 0.0 <= c < 1.0:
            raise InputError(f"expected a fraction of T in [0, 1), got {cruise_fraction!r}",
                             parameter="cruise_fraction")
        return c
    if np.ndim(v_max) == 0:
        vm = np.full(delta.shape, _scalar(v_max, "v_max", positive=True))
    else:
        vm = _vector(v_max, "v_max", delta.size)
        if np.any(vm <= 0):
            raise InputError(f"expected velocities > 0, got {vm.tolist()}", parameter="v_max")
    moving = np.abs(delta) > 0
    if not np.any(moving):
        return 0.0
    # Synchronised profile: every joint reaches its cruise velocity 2|delta|/((1 + c) T)
    # at the same instant; the most demanding joint fixes the ratio cruise/mean.
    ratio = vm[moving] * T / np.abs(delta[moving])
    j = int(np.flatnonzero(moving)[np.argmin(ratio)])
    if ratio.min() <= 1.0:
        raise InputError(
            f"joint {j + 1}{where} must move {abs(delta[j]):.6g} in T = {T:.6g} s, which needs a cruise "
            f"velocity above its mean velocity |qf - q0|/T = {abs(delta[j]) / T:.6g} (rad/s or m/s); "
            f"got v_max = {vm[j]:.6g}",
        parameter="v_max")
    return max(0.0, 2.0 / min(2.0, float(ratio.min())) - 1.0)


def _trapezoid_pieces(qa: Array, qb: Array, T: float, c: float) -> tuple[list[float], list[Array], list[Array], list[Array], list[Array]]:
    """Break offsets (from the segment start), positions, velocities, piece accelerations."""
    delta = qb - qa
    ta = 0.5 * (1.0 - c) * T
    V = 2.0 * delta / ((1.0 + c) * T)
    A = V / ta
    zero = np.zeros_like(qa)
    if c > 1e-12:  # a shorter cruise would make two breaks coincide in floating point
        offsets = [0.0, ta, T - ta, T]
        q = [qa, qa + 0.5 * V * ta, qb - 0.5 * V * ta, qb]
        qd = [zero, V, V, zero]
        acc = [A, zero, -A]
    else:
        offsets = [0.0, ta, T]
        q = [qa, qa + 0.5 * V * ta, qb]
        qd = [zero, V, zero]
        acc = [A, -A]
    return offsets, q, qd, acc, acc


def trapezoidal(q0: npt.ArrayLike, qf: npt.ArrayLike, T: float, dt: float | None = None, *,
                t: npt.ArrayLike | None = None, t0: float = 0.0,
                cruise_fraction: float | None = None, v_max: float | npt.ArrayLike | None = None) -> Trajectory:
    """Trapezoidal-velocity (linear segment with parabolic blends) joint trajectory.

    The joints are synchronised: all accelerate for the same time ``ta``, cruise,
    and decelerate for ``ta``; joint j cruises at ``V_j = (qf_j - q0_j) / (T - ta)``
    with acceleration ``V_j / ta``. The cruise lasts ``cruise_fraction * T``, so
    ``ta = (1 - cruise_fraction) T / 2``.

    Parameters
    ----------
    q0, qf
        (n,) start and end positions, rad or m.
    T
        Duration, s (> 0).
    dt, t, t0
        Sampling, as in :func:`jtraj`.
    cruise_fraction
        Fraction of ``T`` at cruise velocity, in [0, 1); 0 is the triangular
        profile. Default 1/3 (equal thirds: cruise at 1.5 times the mean velocity).
    v_max
        Per-joint velocity limit, rad/s or m/s (scalar or (n,)), instead of
        ``cruise_fraction``: the profile cruises at the highest synchronised
        velocity within the limits (the least acceleration), triangular if the
        limits allow it. Infeasible if a joint's limit does not exceed its mean
        velocity ``|qf - q0| / T``.

    Returns
    -------
    Trajectory
        ``path`` has a break at each switch, where the acceleration jumps.

    Raises
    ------
    model.errors.InputError
        Naming the argument: shapes, NaN/inf, ``T <= 0``, a fraction outside
        [0, 1), an infeasible ``v_max`` (naming the joint and the least velocity).
    """
    a = _vector(q0, "q0")
    b = _vector(qf, "qf", a.size)
    T = _scalar(T, "T", positive=True)
    t0 = _scalar(t0, "t0")
    c = _trapezoid_fraction(b - a, T, cruise_fraction, v_max, "")
    times, step = _sample_times(T, dt, t, t0)
    offsets, q, qd, acc0, acc1 = _trapezoid_pieces(a, b, T, c)
    path = JointPath(t0 + np.array(offsets), q, qd, acc0, acc1)
    return _sampled(path, times, step, np.array([t0, t0 + T]), np.vstack([a, b]), "trapezoidal")


def _heuristic_via_velocities(points: Array, durations: Array) -> Array:
    """Mean velocity of the two adjacent segments, zero where the joint reverses or rests."""
    slopes = np.diff(points, axis=0) / durations[:, None]
    before, after = slopes[:-1], slopes[1:]
    same_direction = np.sign(before) == np.sign(after)
    return np.where(same_direction, 0.5 * (before + after), 0.0)


def via_points(points: npt.ArrayLike, segment_times: float | npt.ArrayLike, dt: float | None = None, *,
               t: npt.ArrayLike | None = None, t0: float = 0.0, profile: str = "quintic",
               via_velocities: str | npt.ArrayLike = "stop",
               cruise_fraction: float | None = None, v_max: float | npt.ArrayLike | None = None) -> Trajectory:
    """Multi-segment joint trajectory through via points (``mstraj``-like), one duration per segment.

    Unlike the Robotics Toolbox's ``mstraj``, whose parabolic blends cut the
    corners, this path passes through every via point at the segment boundary.

    Parameters
    ----------
    points
        (K+1, n) positions: start, K-1 via points, end; rad or m.
    segment_times
        Duration of each segment, s: a scalar for all, or (K,).
    dt, t, t0
        Sampling, as in :func:`jtraj`; the boundaries fall on the grid when every
        segment time is a multiple of ``dt``.
    profile
        ``"quintic"`` (zero acceleration at every boundary) or ``"trapezoidal"``
        (see :func:`trapezoidal`; ``cruise_fraction`` or ``v_max`` apply per segment).
    via_velocities
        ``"stop"``: zero velocity at every via point (as the seed's pick-and-place);
        ``"heuristic"``: the mean of the two adjacent segment velocities, zero where
        a joint reverses, so the arm does not stop; or a (K-1, n) array, rad/s or m/s.
        Only ``"stop"`` is valid with ``profile="trapezoidal"``.

    Returns
    -------
    Trajectory
        ``t_via`` and ``q_via`` are the segment boundaries and ``points``.

    Raises
    ------
    model.errors.InputError
        Naming the argument and value.
    """
    P = np.array(points, dtype=float)
    if P.ndim != 2 or P.shape[0] < 2:
        raise InputError(f"expected a (K+1, n) array with at least 2 rows, got shape {P.shape}", parameter="points")
    if not np.all(np.isfinite(P)):
        bad = np.argwhere(~np.isfinite(P))[0]
        raise InputError(f"row {bad[0] + 1}, joint {bad[1] + 1}: expected a finite value, got {float(P[tuple(bad)])!r}",
                         parameter="points")
    K, n = P.shape[0] - 1, P.shape[1]
    if np.ndim(segment_times) == 0:
        durations = np.full(K, _scalar(segment_times, "segment_times", positive=True))
    else:
        durations = _vector(segment_times, "segment_times", K)
        if np.any(durations <= 0):
            raise InputError(f"expected durations > 0 s, got {durations.tolist()}", parameter="segment_times")
    t0 = _scalar(t0, "t0")
    if profile not in ("quintic", "trapezoidal"):
        raise InputError(f"expected 'quintic' or 'trapezoidal', got {profile!r}", parameter="profile")
    if isinstance(via_velocities, str):
        if via_velocities == "stop":
            V = np.zeros((K + 1, n))
        elif via_velocities == "heuristic":
            V = np.vstack([np.zeros(n), _heuristic_via_velocities(P, durations), np.zeros(n)])
        else:
            raise InputError(f"expected 'stop', 'heuristic' or a ({K - 1}, {n}) array, got {via_velocities!r}",
                             parameter="via_velocities")
    else:
        inner = np.array(via_velocities, dtype=float)
        if inner.shape != (K - 1, n) or not np.all(np.isfinite(inner)):
            raise InputError(f"expected a finite ({K - 1}, {n}) array, got shape {inner.shape}",
                             parameter="via_velocities")
        V = np.vstack([np.zeros(n), inner, np.zeros(n)])
    if profile == "trapezoidal" and np.any(V != 0.0):
        raise InputError(f"profile 'trapezoidal' stops at every via point; got {via_velocities!r}",
                         parameter="via_velocities")

    # Segment boundaries: t0 plus an exact (fsum) partial sum of the durations.
    if not math.isfinite(t0 + sum(durations.tolist())):  # a Python sum: inf on overflow, without a warning
        raise InputError(f"the {K} segments of {durations.max():g} s at most last longer than any finite time",
                         parameter="segment_times")
    t_via = np.array([t0 + math.fsum(durations[:k]) for k in range(K + 1)])
    if dt is not None:
        step = _scalar(dt, "dt", positive=True)
        for k, d in enumerate(durations.tolist()):
            if abs(d / step - round(d / step)) > _GRID_RTOL * max(1.0, d / step):
                raise InputError(f"segment {k + 1} lasts {d!r} s, not a multiple of dt = {step!r} s",
                                 parameter="segment_times")
    times, step = _sample_times(float(t_via[-1] - t0), dt, t, t0)

    if profile == "quintic":
        zero = np.zeros((K, n))
        path = JointPath(t_via, P, V, zero, zero)
    else:
        breaks, q, qd, acc0, acc1 = [t_via[0]], [P[0]], [V[0]], [], []
        for k in range(K):
            c = _trapezoid_fraction(P[k + 1] - P[k], float(durations[k]), cruise_fraction, v_max, f" in segment {k + 1}")
            offsets, qs, qds, a0s, a1s = _trapezoid_pieces(P[k], P[k + 1], float(durations[k]), c)
            breaks += [t_via[k] + o for o in offsets[1:-1]] + [t_via[k + 1]]
            q += qs[1:]
            qd += qds[1:]
            acc0 += a0s
            acc1 += a1s
        path = JointPath(breaks, q, qd, acc0, acc1)
    return _sampled(path, times, step, t_via, P, "via_points")


# --------------------------------------------------------------------------- Cartesian paths


def _time_law(T: float, t0: float, profile: str) -> JointPath:
    """Scalar time scaling s(t) from 0 to 1 over ``[t0, t0 + T]`` as a one-joint path."""
    if profile == "quintic":
        zero = np.zeros((1, 1))
        return JointPath([t0, t0 + T], [[0.0], [1.0]], [[0.0], [0.0]], zero, zero)
    if profile == "linear":
        zero = np.zeros((1, 1))
        return JointPath([t0, t0 + T], [[0.0], [1.0]], [[1.0 / T], [1.0 / T]], zero, zero)
    if profile == "trapezoidal":
        offsets, q, qd, acc0, acc1 = _trapezoid_pieces(np.zeros(1), np.ones(1), T, 1.0 / 3.0)
        return JointPath(t0 + np.array(offsets), q, qd, acc0, acc1)
    raise InputError(f"expected 'quintic', 'trapezoidal' or 'linear', got {profile!r}", parameter="profile")


class StraightLine:
    """Point moving on the segment ``p0 -> pf`` in ``[t0, t0 + T]``; a callable ``segment(t) -> (p_d, pdot_d)``.

    ``p(t) = (1 - s) p0 + s pf`` with the time scaling s(t) of ``profile``
    (``"quintic"``: zero velocity and acceleration at both ends; ``"trapezoidal"``:
    thirds; ``"linear"``: constant velocity ``(pf - p0)/T``, which jumps at the ends).
    Outside the interval the point rests at the nearer end.

    Parameters
    ----------
    p0, pf
        (m,) start and end points, m (m = 3 for a position).
    T
        Duration, s (> 0).
    t0
        Start time, s.
    profile
        ``"quintic"``, ``"trapezoidal"`` or ``"linear"``.
    """

    def __init__(self, p0: npt.ArrayLike, pf: npt.ArrayLike, T: float, t0: float = 0.0, profile: str = "quintic") -> None:
        self.p0 = _readonly(_vector(p0, "p0"))
        self.pf = _readonly(_vector(pf, "pf", self.p0.size))
        self.T = _scalar(T, "T", positive=True)
        self.t0 = _scalar(t0, "t0")
        self.profile = profile
        self.law = _time_law(self.T, self.t0, profile)

    def __repr__(self) -> str:
        return f"StraightLine(p0={self.p0.tolist()}, pf={self.pf.tolist()}, T={self.T:g}, t0={self.t0:g}, profile={self.profile!r})"

    @property
    def length(self) -> float:
        """Length of the segment, m."""
        return float(np.linalg.norm(self.pf - self.p0))

    def __call__(self, t: float) -> tuple[Array, Array]:
        """Desired point ``p_d`` (m,) and its velocity ``pdot_d`` (m,) at time ``t`` (s)."""
        P, PD, _ = self.batch(np.array([_scalar(t, "t")]))
        return P[0], PD[0]

    def acceleration(self, t: float) -> Array:
        """Desired acceleration (m,), m/s^2, at time ``t`` (s)."""
        return self.batch(np.array([_scalar(t, "t")]))[2][0]

    def batch(self, t: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """Points, velocities and accelerations at the (N,) times ``t``, each (N, m)."""
        s, sd, sdd = self.law.batch(t)
        delta = self.pf - self.p0
        return (1.0 - s) * self.p0 + s * self.pf, sd * delta, sdd * delta


def straight_line(p0: npt.ArrayLike, pf: npt.ArrayLike, T: float, t0: float = 0.0, profile: str = "quintic") -> StraightLine:
    """Straight segment from ``p0`` to ``pf`` (m) in ``T`` s: a callable ``segment(t) -> (p_d, pdot_d)``.

    See :class:`StraightLine`; e.g. the desired motion of a CLIK loop.
    """
    return StraightLine(p0, pf, T, t0, profile)


def _as_pose(value: Any, name: str) -> Array:
    T = np.array(value, dtype=float)
    if T.shape != (4, 4):
        raise InputError(f"expected a (4, 4) homogeneous transform, got shape {T.shape}", parameter=name)
    if not np.all(np.isfinite(T)):
        raise InputError("expected finite values", parameter=name)
    R = T[:3, :3]
    if (np.abs(T[3] - [0.0, 0.0, 0.0, 1.0]).max() > _POSE_TOL
            or np.abs(R.T @ R - np.eye(3)).max() > _POSE_TOL or np.linalg.det(R) < 0):
        raise InputError("expected a rigid transform (orthonormal rotation, det +1, last row [0, 0, 0, 1])",
                         parameter=name)
    return T


class CartesianPath:
    """Straight-line pose path between two poses, evaluable at any time.

    The origin moves on the segment (:class:`StraightLine`); the orientation turns
    about the fixed axis of ``R0^T R1`` (angle-axis, i.e. SLERP) with the same time
    scaling s(t): ``R(t) = R0 exp(s(t) [r]x)``, ``r = log(R0^T R1)``, so the angular
    velocity is ``w = R0 r sdot`` (in the poses' frame, the world frame W of ``fkine``). At the ends the given poses are
    returned exactly.
    """

    def __init__(self, T0: npt.ArrayLike, T1: npt.ArrayLike, T: float, t0: float = 0.0, profile: str = "quintic") -> None:
        self.T0 = _readonly(_as_pose(T0, "T0"))
        self.T1 = _readonly(_as_pose(T1, "T1"))
        self.line = StraightLine(self.T0[:3, 3], self.T1[:3, 3], T, t0, profile)
        from scipy.spatial.transform import Rotation  # scipy is imported by the functions that use it

        R0, R1 = self.T0[:3, :3], self.T1[:3, :3]
        self._r = Rotation.from_matrix(R0.T @ R1).as_rotvec()  # rotation vector in frame 0 axes, rad
        self._r_0 = R0 @ self._r  # the same axis in base axes

    @property
    def angle(self) -> float:
        """Total rotation angle, rad (in [0, pi])."""
        return float(np.linalg.norm(self._r))

    def __call__(self, t: float) -> tuple[Array, Array, Array]:
        """Pose (4, 4), linear velocity (3,) m/s and angular velocity (3,) rad/s, in the poses' frame, at ``t`` (s)."""
        poses, v, w, _, _ = self.batch(np.array([_scalar(t, "t")]))
        return poses[0], v[0], w[0]

    def batch(self, t: npt.ArrayLike) -> tuple[Array, Array, Array, Array, Array]:
        """At the (N,) times ``t``: poses (N, 4, 4), v, w (N, 3), and their derivatives vd, wd (N, 3)."""
        p, v, vd = self.line.batch(t)
        s, sd, sdd = self.line.law.batch(t)
        from scipy.spatial.transform import Rotation

        R0, R1 = self.T0[:3, :3], self.T1[:3, :3]
        R = R0 @ Rotation.from_rotvec(s * self._r).as_matrix()
        R[s[:, 0] == 0.0] = R0
        R[s[:, 0] == 1.0] = R1
        poses = np.zeros((p.shape[0], 4, 4))
        poses[:, :3, :3] = R
        poses[:, :3, 3] = p
        poses[:, 3, 3] = 1.0
        return poses, v, sd * self._r_0, vd, sdd * self._r_0


@dataclass(frozen=True, eq=False)
class CartesianTrajectory:
    """A Cartesian pose trajectory sampled in time (base-frame quantities).

    Attributes
    ----------
    t
        (N,) sample times, s.
    poses
        (N, 4, 4) poses ``T_0E``.
    v, w
        (N, 3) linear (m/s) and angular (rad/s) velocity.
    vd, wd
        (N, 3) linear (m/s^2) and angular (rad/s^2) acceleration.
    path
        The :class:`CartesianPath` evaluator.
    dt
        Sampling period, s, for a uniform grid; else None.
    """

    t: Array
    poses: Array
    v: Array
    w: Array
    vd: Array
    wd: Array
    path: CartesianPath = field(repr=False)
    dt: float | None = None

    def __post_init__(self) -> None:
        for name in ("t", "poses", "v", "w", "vd", "wd"):
            object.__setattr__(self, name, _readonly(getattr(self, name)))

    @property
    def p(self) -> Array:
        """(N, 3) positions of the frame origin, m."""
        return self.poses[:, :3, 3]

    def sample(self, t: float) -> tuple[Array, Array, Array]:
        """Pose (4, 4), v (3,), w (3,) at time ``t`` (s)."""
        return self.path(t)


def ctraj(T0: npt.ArrayLike, T1: npt.ArrayLike, T: float, dt: float | None = None, *,
          t: npt.ArrayLike | None = None, t0: float = 0.0, profile: str = "quintic") -> CartesianTrajectory:
    """Straight-line Cartesian trajectory from pose ``T0`` to pose ``T1``.

    The origin moves on the straight segment and the orientation turns about one
    fixed axis (angle-axis / SLERP), both with the time scaling of ``profile``
    (default quintic: zero velocity and acceleration at both ends).

    Parameters
    ----------
    T0, T1
        (4, 4) start and end poses (m), in the world frame W of ``fkine`` for a robot's tool.
    T
        Duration, s (> 0).
    dt, t, t0
        Sampling, as in :func:`jtraj`.
    profile
        ``"quintic"``, ``"trapezoidal"`` or ``"linear"`` time scaling.

    Returns
    -------
    CartesianTrajectory

    Raises
    ------
    model.errors.InputError
        A pose is not a rigid transform, or as in :func:`jtraj`.
    """
    path = CartesianPath(T0, T1, T, t0, profile)
    times, step = _sample_times(path.line.T, dt, t, path.line.t0)
    poses, v, w, vd, wd = path.batch(times)
    return CartesianTrajectory(t=times, poses=poses, v=v, w=w, vd=vd, wd=wd, path=path, dt=step)


def ptp_synchronised(q0: npt.ArrayLike, qf: npt.ArrayLike, qd_max: npt.ArrayLike, qdd_max: npt.ArrayLike,
                     dt: float | None = None, *, t0: float = 0.0, hold: float = 0.0) -> Trajectory:
    """The synchronised time-optimal point-to-point motion (Modelica's ``KinematicPTP2``), then ``hold`` s at rest.

    One path parameter ``s`` in [0, 1] for every joint, ``q = q0 + (qf - q0) s``, with the trapezoidal
    time law of the slowest joint: ``sd_max = 1 / max_j(|dq_j| / qd_max_j)``,
    ``sdd_max = 1 / max_j(|dq_j| / qdd_max_j)``; accelerate for ``Ta2 = sd_max / sdd_max``, cruise until
    ``Tv = 1 / sd_max``, brake until ``Te = Tv + Ta2``; without room for a cruise (``Ta2 >= sqrt(1 / sdd_max)``)
    ``Tv = sqrt(1 / sdd_max)``, ``Te = 2 Tv``. Joints that do not move (``dq = 0``) do not limit it.

    Parameters
    ----------
    q0, qf
        (n,) start and end positions, rad or m.
    qd_max, qdd_max
        (n,) joint speed (rad/s or m/s) and acceleration limits (/s^2), > 0 each.
    dt, t0
        Sampling period and start time, s.
    hold
        Time at rest at ``qf`` after the motion, s (>= 0); with ``dt`` lengthened to end on the grid.
    """
    a = _vector(q0, "q0")
    b = _vector(qf, "qf", a.size)
    vmax = _vector(qd_max, "qd_max", a.size)
    amax = _vector(qdd_max, "qdd_max", a.size)
    for name, lim in (("qd_max", vmax), ("qdd_max", amax)):
        if np.any(lim <= 0):
            raise InputError(f"expected limits > 0, got {lim.tolist()}", parameter=name)
    hold = _scalar(hold, "hold")
    if hold < 0:
        raise InputError(f"expected a time >= 0 (s), got {hold}", parameter="hold")
    delta = b - a
    if not np.any(delta != 0):
        raise InputError("expected a motion: the start and end positions are equal", parameter="qf")
    sd_max = 1.0 / float(np.max(np.abs(delta) / vmax))
    sdd_max = 1.0 / float(np.max(np.abs(delta) / amax))
    ta1 = math.sqrt(1.0 / sdd_max)
    ta2 = sd_max / sdd_max
    zero = np.zeros_like(a)
    if ta2 >= ta1:  # no cruise: accelerate to half way, brake
        tv, te = ta1, 2.0 * ta1
        offsets = [0.0, tv, te]
        s = [0.0, 0.5, 1.0]
        sd = [0.0, sdd_max * ta1, 0.0]
        acc0, acc1 = [sdd_max, -sdd_max], [sdd_max, -sdd_max]
    else:
        tv, te = 1.0 / sd_max, 1.0 / sd_max + ta2
        s1 = 0.5 * sdd_max * ta2 * ta2
        offsets = [0.0, ta2, tv, te]
        s = [0.0, s1, s1 + sd_max * (tv - ta2), 1.0]
        sd = [0.0, sd_max, sd_max, 0.0]
        acc0, acc1 = [sdd_max, 0.0, -sdd_max], [sdd_max, 0.0, -sdd_max]
    q = [b if v == 1.0 else a + delta * v for v in s]  # the end exactly
    qd = [delta * v for v in sd]
    qdd0 = [delta * v for v in acc0]
    qdd1 = [delta * v for v in acc1]
    if dt is not None:  # the hold ends on the sampling grid (at least ``hold`` s after Te)
        dt = _scalar(dt, "dt", positive=True)
        hold = math.ceil((te + hold) / dt - 1e-9) * dt - te
    if hold > 1e-12:
        offsets.append(te + hold)
        q.append(b)
        qd.append(zero)
        qdd0.append(zero)
        qdd1.append(zero)
    path = JointPath(t0 + np.array(offsets), q, qd, qdd0, qdd1)
    T = offsets[-1]
    times, step = _sample_times(T, dt, None, t0)
    return _sampled(path, times, step, np.array([t0, t0 + te]), np.vstack([a, b]), "ptp")
