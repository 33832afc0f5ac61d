"""Excitation trajectories: finite Fourier series optimised for the condition number of the base regressor.

Each joint follows a finite Fourier series of period ``T = 2 pi / w_f`` with ``L`` harmonics
(Swevers, Ganseman, Tukel, De Schutter, Van Brussel, "Optimal robot excitation and identification",
IEEE Trans. Robotics and Automation 13(5), 1997)::

    qd_j(t)  = sum_l  a_jl cos(l w_f t) + b_jl sin(l w_f t)
    q_j(t)   = q_start_j + sum_l  a_jl / (l w_f) sin(l w_f t) + b_jl / (l w_f) (1 - cos(l w_f t))
    qdd_j(t) = sum_l -a_jl l w_f sin(l w_f t) + b_jl l w_f cos(l w_f t)

so ``q(0) = q_start``; the two linear conditions ``sum_l a_jl = 0`` and ``sum_l l b_jl = 0`` make
``qd(0) = qdd(0) = 0``, and the series being periodic, the arm starts and ends every period at rest at
``q_start`` (the robot's rest pose, moved inside the position box if needed). q, qd and qdd are
linear in the coefficients ``x = (a, b)``.

The coefficients minimise ``log cond(W_b(x))``, ``W_b`` the base regressor (every base parameter:
inertial, rotor, friction and offset, :mod:`model.identification.base`) stacked at ``samples`` instants of
one period, with IPOPT (the one CasADi ships) and a limited-memory Hessian. The objective is a CasADi
callback: its value from a singular value decomposition of the compiled, batch-evaluated regressor, its
gradient exact, ``d log cond = u_1^T dW v_1 / s_1 - u_r^T dW v_r / s_r``, through the compiled
regressor's reverse-mode derivative (``regressor_vjp``) and the linear Fourier maps. Constraints at the
``constraint_samples`` instants of a period: the joint positions within the box, the speeds and
accelerations within their limits (linear), and, for the joints whose motors the robot file rates
(``torque_limit``), the torques of the full inverse dynamics (motors and friction) within ``|G|`` times
the rating times ``torque_margin`` (nonlinear, exact Jacobians).

Limits. The position box is the file's ``qlim`` (a joint without one: [-pi, pi] rad or [-1, 1] m,
:func:`model.tasks.finite_limits`), shrunk by :data:`POSITION_MARGIN` of its range at each end. Robot files
state no speed or acceleration limits: the defaults :data:`DEFAULT_QD_MAX` and :data:`DEFAULT_QDD_MAX`
(moderate, safe for a first run on an unknown arm) are used and :attr:`ExcitationLimits.notes` says so.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import casadi as ca
import numpy as np
import numpy.typing as npt
from threadpoolctl import threadpool_limits

from ..errors import InputError, NumericalError
from ..tasks import finite_limits
from ..trajectory import JointPath, Trajectory
from .base import BaseParameters, base_parameters
from .parameters import standard_parameters
from .regressor import Regressor

__all__ = [
    "DEFAULT_HARMONICS",
    "DEFAULT_PERIOD",
    "DEFAULT_QD_MAX",
    "DEFAULT_QDD_MAX",
    "POSITION_MARGIN",
    "ExcitationLimits",
    "ExcitationResult",
    "FourierTrajectory",
    "excitation_limits",
    "optimise_excitation",
]

Array = npt.NDArray[np.float64]

#: Period of the series, s (Swevers et al. 1997: 10 s, a fundamental of 0.1 Hz).
DEFAULT_PERIOD = 10.0
#: Harmonics per joint (Swevers et al. 1997: 5, so the fastest is 0.5 Hz).
DEFAULT_HARMONICS = 5
#: Speed limits when the robot file states none: (revolute rad/s, prismatic m/s).
DEFAULT_QD_MAX = (1.0, 0.25)
#: Acceleration limits when the robot file states none: (revolute rad/s^2, prismatic m/s^2).
DEFAULT_QDD_MAX = (4.0, 1.0)
#: Fraction of each joint's range left free at each end of the position box.
POSITION_MARGIN = 0.05
#: The optimiser stops when the best condition number improved by less than this fraction ...
STALL_IMPROVEMENT = 0.005
#: ... over this many iterations.
STALL_ITERATIONS = 25
#: Share of each limit the optimiser may use at its grid points (the output is checked against the full limit).
_GRID_MARGIN = 0.99


@dataclass(frozen=True)
class ExcitationLimits:
    """The limits an excitation keeps (joint side, SI units).

    Attributes
    ----------
    q_min, q_max
        (n,) position box, rad or m (already shrunk by the margin).
    qd_max, qdd_max
        (n,) speed and acceleration limits.
    tau_max
        (n,) joint torque limits (``|G|`` times the motor rating times the margin), ``inf`` where unrated.
    notes
        One line per default used (for the user's console).
    """

    q_min: Array
    q_max: Array
    qd_max: Array
    qdd_max: Array
    tau_max: Array
    notes: tuple[str, ...] = ()


def _per_joint(value: float | Sequence[float] | None, n: int, name: str) -> Array | None:
    if value is None:
        return None
    arr = np.atleast_1d(np.asarray(value, dtype=float))
    if arr.size == 1:
        arr = np.full(n, float(arr[0]))
    if arr.shape != (n,) or not np.all(arr > 0):
        raise InputError(f"expected one positive number or {n}, one per joint, got {np.asarray(value).tolist()}",
                         parameter=name)
    return arr


def _joint_limits(desc: Any, given: Array | None, field: str, defaults: tuple[float, float], what: str,
                  units: tuple[str, str], notes: list[str]) -> Array:
    """Per joint: the given limit, else the robot file's ``field`` (``velocity_limit``, ``acceleration_limit``),
    else the default for its kind; a note names the joints that took the default. Every limit must be finite:
    an excitation is scaled to its limits."""
    n = desc.n
    revolute = np.array([lk.is_revolute for lk in desc.links])
    stated = np.array([np.nan if getattr(lk, field) is None else getattr(lk, field) for lk in desc.links])
    default = np.where(revolute, defaults[0], defaults[1])
    chosen = given if given is not None else np.where(np.isnan(stated), default, stated)
    if given is None and np.isnan(stated).any():
        joints = [desc.joint_names[j] for j in range(n) if np.isnan(stated[j])]
        notes.append(f"{desc.name} states no joint {what} limit for {', '.join(joints)}: using {defaults[0]:g} "
                     f"{units[0]} (revolute) and {defaults[1]:g} {units[1]} (prismatic)")
    if not np.all(np.isfinite(chosen)):
        j = int(np.argmin(np.isfinite(chosen)))
        raise InputError(f"joint {desc.joint_names[j]}: expected a finite {what} limit (an excitation is scaled to "
                         f"its limits), got {chosen[j]!r}", parameter=field)
    return chosen


def excitation_limits(desc: Any, qd_max: float | Sequence[float] | None = None,
                      qdd_max: float | Sequence[float] | None = None, torque_margin: float = 0.9) -> ExcitationLimits:
    """The :class:`ExcitationLimits` of a robot description: its box; per joint the given speed and
    acceleration limits, else the robot file's ``velocity_limit`` and ``acceleration_limit``, else
    :data:`DEFAULT_QD_MAX` and :data:`DEFAULT_QDD_MAX`; its motor ratings times ``torque_margin``."""
    n = desc.n
    if not 0 < torque_margin <= 1:
        raise InputError(f"expected a fraction in (0, 1], got {torque_margin!r}", parameter="torque_margin")
    lim = finite_limits(desc)
    span = lim[1] - lim[0]
    q_min, q_max = lim[0] + POSITION_MARGIN * span, lim[1] - POSITION_MARGIN * span
    notes: list[str] = []
    qd = _joint_limits(desc, _per_joint(qd_max, n, "velocity_limit"), "velocity_limit", DEFAULT_QD_MAX, "speed",
                       ("rad/s", "m/s"), notes)
    given = _joint_limits(desc, _per_joint(qdd_max, n, "acceleration_limit"), "acceleration_limit", DEFAULT_QDD_MAX,
                          "acceleration", ("rad/s^2", "m/s^2"), notes)
    tau = np.array([math.inf if lk.torque_limit is None else abs(lk.gear_ratio) * lk.torque_limit * torque_margin
                    for lk in desc.links])
    return ExcitationLimits(q_min=q_min, q_max=q_max, qd_max=qd, qdd_max=given, tau_max=tau, notes=tuple(notes))


@dataclass(frozen=True, eq=False)
class FourierTrajectory:
    """A finite Fourier series per joint (see the module docstring), starting and ending at rest.

    Attributes
    ----------
    period
        s.
    q_start
        (n,) position at t = 0 and at every multiple of the period.
    a, b
        (n, L) coefficients of ``cos`` and ``sin`` in the joint velocities, rad/s or m/s.
    """

    period: float
    q_start: Array
    a: Array
    b: Array

    @property
    def harmonics(self) -> int:
        return int(self.a.shape[1])

    def evaluate(self, t: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """``(q, qd, qdd)`` at the times ``t`` (N,), each (N, n)."""
        Pq, Pqd, Pqdd = _basis(np.asarray(t, dtype=float), self.period, self.harmonics)
        x = np.hstack([self.a, self.b])  # (n, 2L)
        return self.q_start + Pq @ x.T, Pqd @ x.T, Pqdd @ x.T

    def sample(self, rate_hz: float, periods: int = 1) -> tuple[Array, Array, Array, Array]:
        """``(t, q, qd, qdd)`` on the grid ``k / rate_hz`` over ``periods`` periods, both ends included."""
        steps = int(round(self.period * periods * rate_hz))
        t = np.arange(steps + 1) / rate_hz
        return (t, *self.evaluate(t))

    def trajectory(self, rate_hz: float, periods: int = 1) -> Trajectory:
        """The series as a :class:`model.trajectory.Trajectory` on the grid of :meth:`sample` (for the closed
        loops): quintic pieces between the samples, matching q, qd and qdd at each (the path departs from the
        series between samples by a relative error of order ``(w_L h)^6``, ``w_L`` the highest harmonic and ``h``
        the sample period: 1e-15 at 1 kHz for the defaults)."""
        t, q, qd, qdd = self.sample(rate_hz, periods)
        path = JointPath(t, q, qd, qdd[:-1], qdd[1:])
        return Trajectory(t=t, q=q, qd=qd, qdd=qdd, path=path, t_via=t[[0, -1]], q_via=q[[0, -1]],
                          dt=1.0 / rate_hz, name="excitation")


def _basis(t: Array, period: float, L: int) -> tuple[Array, Array, Array]:
    """(N, 2L) maps from one joint's coefficients ``[a_1..a_L, b_1..b_L]`` to ``q - q_start``, qd, qdd."""
    w = 2 * math.pi / period * np.arange(1, L + 1)
    wt = np.outer(t, w)
    s, c = np.sin(wt), np.cos(wt)
    return np.hstack([s / w, (1 - c) / w]), np.hstack([c, s]), np.hstack([-s * w, c * w])


@dataclass(frozen=True, eq=False)
class ExcitationResult:
    """An optimised excitation and what the optimiser did.

    Attributes
    ----------
    trajectory
        The Fourier series.
    limits
        The limits it keeps.
    base
        The base parameters whose regressor it conditions.
    condition_number
        ``cond(W_b)`` at the optimum (``samples`` instants of one period); ``initial_condition_number`` at the start.
    iterations, seconds
        IPOPT iterations and wall time.
    status
        IPOPT's return status.
    samples
        Instants of one period in the condition number.
    history
        The condition number at each objective evaluation.
    notes
        What was adjusted (a start moved into the box, a joint scaled to its limits), one line each.
    """

    trajectory: FourierTrajectory
    limits: ExcitationLimits
    base: BaseParameters
    condition_number: float
    initial_condition_number: float
    iterations: int
    seconds: float
    status: str
    samples: int = 0
    history: tuple[float, ...] = field(default=(), repr=False)
    notes: tuple[str, ...] = ()


class _NumpyFunction(ca.Callback):
    """A CasADi Function of dense inputs computed in numpy: ``fn(x)`` of the first input (the others are the
    nominal outputs CasADi passes to a Jacobian), with an exact Jacobian ``jacobian(x)`` when given."""

    def __init__(self, name: str, in_shapes: Sequence[tuple[int, int]], out_shape: tuple[int, int],
                 fn: Callable[[Array], Array], jacobian: Callable[[Array], Array] | None = None,
                 opts: dict | None = None) -> None:
        ca.Callback.__init__(self)
        self.in_shapes, self.out_shape, self.fn, self.jac = list(in_shapes), out_shape, fn, jacobian
        self.construct(name, opts or {})

    def get_n_in(self) -> int:
        return len(self.in_shapes)

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(*self.in_shapes[i])

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(*self.out_shape)

    def eval(self, arg: list) -> list:
        return [np.reshape(self.fn(np.array(arg[0]).ravel()), self.out_shape)]

    def has_jacobian(self) -> bool:
        return self.jac is not None

    def get_jacobian(self, name: str, inames: list, onames: list, opts: dict) -> ca.Function:
        rows = self.out_shape[0] * self.out_shape[1]
        self._jacobian = _NumpyFunction(name, [self.in_shapes[0], self.out_shape], (rows, self.in_shapes[0][0]),
                                        self.jac, None, opts)  # kept: CasADi holds no Python reference
        return self._jacobian


class _Torques:
    """``x -> tau`` of the rated joints at the constraint instants, ``Y(q, qd, qdd) pi`` (the reflected-motor
    inverse dynamics with the robot's own parameters), with its exact Jacobian from ``regressor_vjp``."""

    def __init__(self, regressor: Regressor, pi: Array, q_start: Array, grid: tuple[Array, Array, Array],
                 joints: Array) -> None:
        self.regressor, self.pi, self.q_start, self.grid, self.joints = regressor, pi, q_start, grid, joints
        self.n, self.nx, self.N = regressor.n, grid[0].shape[1] * regressor.n, grid[0].shape[0]

    def function(self) -> _NumpyFunction:
        """The CasADi Function ``x -> tau`` (rows joint-major) with its Jacobian."""
        return _NumpyFunction("torques", [(self.nx, 1)], (self.N * len(self.joints), 1), self.value, self.jacobian)

    def states(self, x: Array) -> tuple[Array, Array, Array]:
        X = x.reshape(self.n, -1)
        Pq, Pqd, Pqdd = self.grid
        return self.q_start + Pq @ X.T, Pqd @ X.T, Pqdd @ X.T

    def value(self, x: Array) -> Array:
        Y = self.regressor.batch(*self.states(x))
        return (Y @ self.pi)[:, self.joints].T.ravel()

    def jacobian(self, x: Array) -> Array:
        """(N * rated, nx) d tau / d x, rows joint-major as :meth:`value`."""
        Q, QD, QDD = self.states(x)
        Pq, Pqd, Pqdd = self.grid
        J = np.zeros((len(self.joints), self.N, self.n, Pq.shape[1]))
        for r, j in enumerate(self.joints):
            seed = np.zeros((self.N, self.n, self.pi.size))
            seed[:, j, :] = self.pi
            gq, gqd, gqdd = self.regressor.vjp_batch(Q, QD, QDD, seed)
            J[r] = gq[:, :, None] * Pq[:, None, :] + gqd[:, :, None] * Pqd[:, None, :] + gqdd[:, :, None] * Pqdd[:, None, :]
        return J.reshape(len(self.joints) * self.N, -1)


class _Stall(ca.Callback):
    """IPOPT's iteration callback: stop once the best condition number has improved by less than
    :data:`STALL_IMPROVEMENT` over the last :data:`STALL_ITERATIONS` iterations (the objective is not smooth
    where two singular values cross, so IPOPT's own optimality test rarely fires)."""

    def __init__(self, nx: int, ng: int) -> None:
        ca.Callback.__init__(self)
        self.nx, self.ng = nx, ng
        self.best: list[float] = []
        self.construct("stall", {})

    def get_n_in(self) -> int:
        return ca.nlpsol_n_out()

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return ca.nlpsol_out(i)

    def get_name_out(self, i: int) -> str:
        return "ret"

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        name = ca.nlpsol_out(i)
        if name in ("f",):
            return ca.Sparsity.dense(1, 1)
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx, 1)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng, 1)
        return ca.Sparsity(0, 0)

    def eval(self, arg: list) -> list:
        f = float(arg[ca.nlpsol_out().index("f")])
        self.best.append(min(f, self.best[-1]) if self.best else f)
        k = len(self.best)
        stop = k > 2 * STALL_ITERATIONS and self.best[-STALL_ITERATIONS - 1] - self.best[-1] < math.log1p(STALL_IMPROVEMENT)
        return [1 if stop else 0]


class _Problem:
    """The objective's data: the regressor, the base columns, the Fourier maps at the sample instants."""

    def __init__(self, regressor: Regressor, base: BaseParameters, q_start: Array, period: float, L: int,
                 samples: int, progress: Callable[[str], None] | None) -> None:
        self.regressor, self.base, self.q_start = regressor, base, q_start
        self.n, self.L = regressor.n, L
        self.nx = 2 * L * self.n
        t = np.arange(samples) * (period / samples)
        self.Pq, self.Pqd, self.Pqdd = _basis(t, period, L)
        self.cols = list(base.independent)
        self._cache: tuple[bytes, float, Array] | None = None
        self.evaluations = 0
        self.history: list[float] = []
        self._progress, self._last = progress, time.perf_counter()

    def states(self, x: Array) -> tuple[Array, Array, Array]:
        X = x.reshape(self.n, 2 * self.L)
        return self.q_start + self.Pq @ X.T, self.Pqd @ X.T, self.Pqdd @ X.T

    def condition(self, x: Array) -> float:
        Y = self.regressor.batch(*self.states(x))
        s = np.linalg.svd(Y[:, :, self.cols].reshape(-1, len(self.cols)), compute_uv=False)
        return float(s[0] / s[-1]) if s[-1] > 0 else math.inf

    def value_and_gradient(self, x: Array) -> tuple[float, Array]:
        key = x.tobytes()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1], self._cache[2]
        Q, QD, QDD = self.states(x)
        Y = self.regressor.batch(Q, QD, QDD)
        N, n, nb = Y.shape[0], self.n, len(self.cols)
        W = Y[:, :, self.cols].reshape(N * n, nb)
        U, s, Vt = np.linalg.svd(W, full_matrices=False)
        if not s[-1] > 0:
            value, grad = 1e3, np.zeros_like(x)  # a regressor of lower rank: far worse than any real optimum
        else:
            value = float(np.log(s[0] / s[-1]))
            Wbar = np.outer(U[:, 0], Vt[0]) / s[0] - np.outer(U[:, -1], Vt[-1]) / s[-1]
            Ybar = np.zeros_like(Y)
            Ybar[:, :, self.cols] = Wbar.reshape(N, n, nb)
            gq, gqd, gqdd = self.regressor.vjp_batch(Q, QD, QDD, Ybar)
            grad = (gq.T @ self.Pq + gqd.T @ self.Pqd + gqdd.T @ self.Pqdd).ravel()
        self._cache = (key, value, grad)
        self.evaluations += 1
        self.history.append(math.exp(value) if value < 700.0 else math.inf)  # a rank-deficient start: infinite
        now = time.perf_counter()
        if self._progress is not None and now - self._last > 2.0:
            self._last = now
            self._progress(f"evaluation {self.evaluations}: cond {self.history[-1]:.4g} (best {min(self.history):.4g})")
        return value, grad


def _start_position(desc: Any, limits: ExcitationLimits) -> tuple[Array, list[str]]:
    rest = desc.q_rest
    q = np.clip(rest, limits.q_min, limits.q_max)
    notes = [f"joint {j + 1}: rest {rest[j]:.6g} is outside the excitation box [{limits.q_min[j]:.6g}, "
             f"{limits.q_max[j]:.6g}]: the excitation starts at {q[j]:.6g}" for j in np.flatnonzero(q != rest)]
    return q, notes


def _initial_guess(rng: np.random.Generator, n: int, L: int, q_start: Array, limits: ExcitationLimits,
                   grid: tuple[Array, Array, Array]) -> Array:
    """Random coefficients meeting the equality conditions, scaled per joint to half of its limits."""
    l = np.arange(1, L + 1, dtype=float)
    X = rng.normal(size=(n, 2 * L))
    a, b = X[:, :L], X[:, L:]
    a -= a.mean(axis=1, keepdims=True)  # sum a = 0
    b -= np.outer(b @ l / (l @ l), l)  # sum l b = 0
    Pq, Pqd, Pqdd = grid
    for j in range(n):
        dq, qd, qdd = Pq @ X[j], Pqd @ X[j], Pqdd @ X[j]
        room_hi, room_lo = limits.q_max[j] - q_start[j], q_start[j] - limits.q_min[j]
        with np.errstate(over="ignore"):  # a limit of 1e308 over a small peak: inf, as good as no limit
            ratios = [limits.qd_max[j] / max(np.abs(qd).max(), 1e-300),
                      limits.qdd_max[j] / max(np.abs(qdd).max(), 1e-300)]
        if dq.max() > 0:
            ratios.append(room_hi / dq.max())
        if dq.min() < 0:
            ratios.append(room_lo / -dq.min())
        X[j] *= 0.5 * min(ratios)
    return X.ravel()


def optimise_excitation(robot: Any, *, period: float = DEFAULT_PERIOD, harmonics: int = DEFAULT_HARMONICS,
                        limits: ExcitationLimits | None = None, samples: int = 200, constraint_samples: int = 200,
                        max_iter: int = 300, seed: int = 0, regressor: Regressor | None = None,
                        base: BaseParameters | None = None,
                        progress: Callable[[str], None] | None = None) -> ExcitationResult:
    """The excitation of ``robot`` (a :class:`model.Robot`) that minimises the base regressor's condition number.

    Parameters
    ----------
    robot
        The robot: its regressor, its limits and (for the torque constraints) its inverse dynamics.
    period, harmonics
        The Fourier series: period (s) and harmonics per joint.
    limits
        Default :func:`excitation_limits` of the robot (default speed and acceleration limits).
    samples
        Instants of one period at which the regressor is stacked for the condition number.
    constraint_samples
        Instants of one period at which the limits are imposed (the output grid is checked afterwards).
    max_iter
        IPOPT's iteration limit.
    seed
        Seed of the random initial coefficients.
    regressor, base
        The robot's compiled regressor and base parameters, when the caller has them.
    progress
        Called with one line every few seconds of optimisation.

    Raises
    ------
    InputError
        A bad period, number of harmonics or sample count.
    NumericalError
        IPOPT ends without a point inside the limits.
    """
    desc = robot.description
    n = desc.n
    if not (math.isfinite(period) and period > 0):
        raise InputError(f"period: expected a positive number of seconds, got {period!r}")
    if not (isinstance(harmonics, int) and 1 <= harmonics <= 50):
        raise InputError(f"harmonics: expected a whole number from 1 to 50, got {harmonics!r}")
    reg = regressor if regressor is not None else Regressor(desc)
    base = base if base is not None else base_parameters(reg)
    lim = limits if limits is not None else excitation_limits(desc)
    samples = max(int(samples), -(-2 * base.n_base // n))
    q_start, start_notes = _start_position(desc, lim)
    L = harmonics
    problem = _Problem(reg, base, q_start, period, L, samples, progress)
    t_g = np.arange(constraint_samples) * (period / constraint_samples)
    grid = _basis(t_g, period, L)
    x0 = _initial_guess(np.random.default_rng(seed), n, L, q_start, lim, grid)

    x = ca.MX.sym("x", problem.nx)
    X = ca.reshape(x, 2 * L, n).T  # row j: joint j's [a, b] (x is joint-major, as the numpy reshape)
    Pq, Pqd, Pqdd = (ca.DM(P) for P in grid)
    Q, QD, QDD = Pq @ X.T, Pqd @ X.T, Pqdd @ X.T  # (N_g, n)
    l = ca.DM(np.arange(1, L + 1, dtype=float))
    g, lbg, ubg = [], [], []
    g.append(ca.vec(X[:, :L] @ ca.DM.ones(L, 1)))  # sum a = 0
    g.append(ca.vec(X[:, L:] @ l))  # sum l b = 0
    lbg += [np.zeros(2 * n)]
    ubg += [np.zeros(2 * n)]
    ones = np.ones(constraint_samples)
    for M, lo, hi in ((Q, _GRID_MARGIN * (lim.q_min - q_start), _GRID_MARGIN * (lim.q_max - q_start)), (QD, -_GRID_MARGIN * lim.qd_max, _GRID_MARGIN * lim.qd_max),
                      (QDD, -_GRID_MARGIN * lim.qdd_max, _GRID_MARGIN * lim.qdd_max)):
        g.append(ca.vec(M))
        lbg.append(np.concatenate([lo[j] * ones for j in range(n)]))
        ubg.append(np.concatenate([hi[j] * ones for j in range(n)]))
    rated = np.flatnonzero(np.isfinite(lim.tau_max))
    torques = None  # the callbacks must outlive the solver: CasADi holds no Python reference
    if rated.size:
        torques = _Torques(reg, standard_parameters(desc), q_start, grid, rated).function()
        g.append(torques(x))
        lbg.append(np.concatenate([-_GRID_MARGIN * lim.tau_max[j] * ones for j in rated]))
        ubg.append(np.concatenate([_GRID_MARGIN * lim.tau_max[j] * ones for j in rated]))
    objective = _NumpyFunction("log_cond", [(problem.nx, 1)], (1, 1), lambda v: problem.value_and_gradient(v)[0],
                               lambda v: problem.value_and_gradient(v)[1][None, :])
    g_all = ca.vertcat(*g)
    stall = _Stall(problem.nx, g_all.numel())
    nlp = {"x": x, "f": objective(x), "g": g_all}
    opts = {"ipopt.hessian_approximation": "limited-memory", "ipopt.max_iter": int(max_iter), "ipopt.tol": 1e-6,
            "ipopt.acceptable_tol": 1e-4, "ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False, "iteration_callback": stall}
    solver = ca.nlpsol("excitation", "ipopt", nlp, opts)
    t0 = time.perf_counter()
    with threadpool_limits(1, user_api="blas"):  # small dense algebra: threads only contend (100x slower on a busy machine)
        initial = problem.condition(x0)
        sol = solver(x0=x0, lbg=np.concatenate(lbg), ubg=np.concatenate(ubg))
    seconds = time.perf_counter() - t0
    stats = solver.stats()
    xs = np.array(sol["x"]).ravel()
    g_val = np.array(sol["g"]).ravel()
    lo_all, hi_all = np.concatenate(lbg), np.concatenate(ubg)
    scale = np.maximum(1.0, np.abs(hi_all))
    if np.any(g_val < lo_all - 1e-6 * scale) or np.any(g_val > hi_all + 1e-6 * scale):
        raise NumericalError(f"excitation of {desc.name!r}: IPOPT ended ({stats['return_status']}) outside the limits")
    Xs = xs.reshape(n, 2 * L)
    Xs, notes = _fit_fine_grid(Xs, q_start, period, L, lim)
    traj = FourierTrajectory(period=float(period), q_start=q_start, a=Xs[:, :L].copy(), b=Xs[:, L:].copy())
    return ExcitationResult(trajectory=traj, limits=lim, base=base, condition_number=problem.condition(Xs.ravel()),
                            initial_condition_number=initial, iterations=int(stats.get("iter_count", 0)),
                            seconds=seconds, status=str(stats["return_status"]), samples=samples,
                            history=tuple(problem.history), notes=(*start_notes, *notes))


#: Instants per period of the final check of the position, speed and acceleration limits.
CHECK_SAMPLES = 20_000


def _fit_fine_grid(X: Array, q_start: Array, period: float, L: int, lim: ExcitationLimits) -> tuple[Array, list[str]]:
    """Scale each joint's coefficients down where the series crosses a limit between the optimiser's instants
    (checked at :data:`CHECK_SAMPLES` instants of a period); scaling keeps q(0) = q_start and the rest conditions."""
    Pq, Pqd, Pqdd = _basis(np.arange(CHECK_SAMPLES) * (period / CHECK_SAMPLES), period, L)
    X = X.copy()
    notes = []
    for j in range(X.shape[0]):
        dq, qd, qdd = Pq @ X[j], Pqd @ X[j], Pqdd @ X[j]
        ratios = [1.0] + [bound / peak for bound, peak in ((lim.qd_max[j], np.abs(qd).max()),
                                                           (lim.qdd_max[j], np.abs(qdd).max())) if peak > 0]
        if dq.max() > 0:
            ratios.append((lim.q_max[j] - q_start[j]) / dq.max())
        if dq.min() < 0:
            ratios.append((lim.q_min[j] - q_start[j]) / dq.min())
        s = min(ratios)
        if s < 1.0:
            X[j] *= s * (1 - 1e-9)
            notes.append(f"joint {j + 1}: scaled by {s:.6f} to keep its limits between the optimiser's instants")
    return X, notes
