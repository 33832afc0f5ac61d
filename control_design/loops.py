"""One joint loop as linear systems: plant, gains, sampling.

A joint seen from its motor is ``J_m theta_m'' + B_m theta_m' = tau_m + d_m``
(motor angle ``theta_m = G q``, motor torque ``tau_m``, disturbance ``d_m``
that the decoupled model leaves out). A controller of the PID family closes
the loop on the motor position and velocity::

    tau_m = Kp (r - theta_m) + Kd (r' - theta_m') + Ki int(r - theta_m) dt

For a step reference ``r' = 0`` after the step, so in the step response the
derivative acts on the measured velocity: the closed loop ``r -> theta_m`` has
no zero from ``Kd``. The same loop is the outer loop of computed torque with
``J_m = 1, B_m = 0`` (a double integrator, gains in 1/s^2 and 1/s).

Discrete loops are what the controllers of :mod:`control_design.controllers`
run: the plant is sampled with a zero-order hold (``control.sample_system``
with ``"zoh"`` gives the same matrices), position and velocity are read at
``t_k`` and the torque is applied at ``t_k`` without computation delay; the
integral uses forward Euler (``z_{k+1} = z_k + T e_k``).

Loop transfer ``L`` is broken at the plant input with the negative-feedback
sign convention (``L = C P``, stable closed loop iff the Nyquist plot of ``L``
does not encircle -1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import control
import numpy as np
import scipy.linalg

from model.errors import InputError

from .errors import DesignSpecError, SamplingRateError

__all__ = [
    "MIN_RATE_PER_BANDWIDTH_HZ",
    "JointPlant",
    "JointGains",
    "JointLoop",
    "MAX_RATE_HZ",
    "MAX_RATE_PER_BANDWIDTH",
    "check_rate",
    "gains_arrays",
    "zoh_matrices",
]

#: A loop of bandwidth f_bw = w_bw / (2 pi) Hz needs a control rate of at least
#: this many times f_bw. At the limit the zero-order hold costs about
#: w_c T / 2 = pi / 10 rad = 18 deg of phase margin (w_c ~ w_bw): still stable,
#: clearly degraded; below it the continuous design no longer describes the loop.
MIN_RATE_PER_BANDWIDTH_HZ = 10.0

#: The sampled analysis (step response, disturbance impulse response) runs over about twelve of the
#: slowest closed-loop time constants, up to 1 / (0.05 w_n) each at the lowest damping accepted: about
#: 240 / bandwidth seconds, i.e. 240 rate / bandwidth samples. Capping rate / bandwidth at 1e4 Hz per rad/s
#: bounds that to 2.4e6 samples (tens of MB, seconds); beyond it the request is refused before any work.
MAX_RATE_PER_BANDWIDTH = 1.0e4

#: Highest control rate, Hz: the closed-loop simulation keeps every control sample (a 15 s task at
#: 100 kHz is 1.5e6 samples per signal); faster loops (current loops) are not what this models.
MAX_RATE_HZ = 1.0e5


def check_rate(bandwidth: float, rate_hz: float | None) -> None:
    """Raise :class:`SamplingRateError` unless ``10 * bandwidth / (2 pi) <= rate_hz <= min(1e4 * bandwidth, 1e5)``.

    The lower bound keeps the continuous design meaningful; the upper bounds keep the sampled analysis
    and the closed-loop simulation within a few million samples.

    Parameters
    ----------
    bandwidth
        Closed-loop bandwidth, rad/s.
    rate_hz
        Control rate, Hz; ``None`` (continuous) always passes.
    """
    if rate_hz is None:
        return
    if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
        raise SamplingRateError(f"expected a positive number of Hz, got {rate_hz!r}", parameter="rate")
    if rate_hz > MAX_RATE_HZ:
        raise SamplingRateError(
            f"{rate_hz:g} Hz is above the highest control rate simulated, {MAX_RATE_HZ:g} Hz "
            "(every control sample is kept)",
        parameter="rate")
    if rate_hz > MAX_RATE_PER_BANDWIDTH * bandwidth:
        raise SamplingRateError(
            f"{bandwidth:g} rad/s at a control rate of {rate_hz:g} Hz needs about "
            f"{240.0 * rate_hz / bandwidth:.2g} samples to analyse the sampled loop (limit "
            f"{240.0 * MAX_RATE_PER_BANDWIDTH:.2g}): raise the bandwidth to >= {rate_hz / MAX_RATE_PER_BANDWIDTH:.3g} rad/s "
            f"or lower the rate to <= {MAX_RATE_PER_BANDWIDTH * bandwidth:.3g} Hz",
        parameter="bandwidth")
    need = MIN_RATE_PER_BANDWIDTH_HZ * bandwidth / (2.0 * math.pi)
    if rate_hz < need:
        raise SamplingRateError(
            f"{rate_hz:g} Hz is too low for a bandwidth of {bandwidth:g} rad/s "
            f"({bandwidth / (2 * math.pi):.3g} Hz): expected >= {MIN_RATE_PER_BANDWIDTH_HZ:g} x bandwidth in Hz "
            f"= {need:.4g} Hz", parameter="rate")


def zoh_matrices(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation ``(Ad, Bd)`` of ``x' = A x + B u`` with period ``dt`` (s)."""
    nx, nu = B.shape
    M = np.zeros((nx + nu, nx + nu))
    M[:nx, :nx] = A
    M[:nx, nx:] = B
    E = scipy.linalg.expm(M * dt)
    return E[:nx, :nx], E[:nx, nx:]


@dataclass(frozen=True)
class JointPlant:
    """Decoupled model of one joint seen from its motor.

    Attributes
    ----------
    J_m
        Effective inertia at the motor, kg m^2 (rotor plus reflected link inertia).
    B_m
        Viscous friction at the motor, N m s/rad.
    G
        Reduction ratio (motor angle = G q); 1 for a loop already on the joint side.
    name, unit
        Joint name and the unit of q ('rad' or 'm').
    """

    J_m: float
    B_m: float = 0.0
    G: float = 1.0
    name: str = ""
    unit: str = "rad"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.J_m) and self.J_m > 0):
            raise DesignSpecError(f"expected a positive inertia in kg m^2, got {self.J_m!r}", parameter="J_m")
        if not (math.isfinite(self.B_m) and self.B_m >= 0):
            raise DesignSpecError(f"expected a friction >= 0 in N m s/rad, got {self.B_m!r}", parameter="B_m")
        if not (math.isfinite(self.G) and self.G != 0):
            raise DesignSpecError(f"expected a non-zero reduction ratio, got {self.G!r}", parameter="G")

    def transfer_function(self) -> control.TransferFunction:
        """``theta_m / tau_m = 1 / (J_m s^2 + B_m s)``."""
        return control.tf([1.0], [self.J_m, self.B_m, 0.0])

    def state_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A, B)`` of ``x = [theta_m, omega_m]`` with input ``tau_m``."""
        A = np.array([[0.0, 1.0], [0.0, -self.B_m / self.J_m]])
        B = np.array([[0.0], [1.0 / self.J_m]])
        return A, B


@dataclass(frozen=True)
class JointGains:
    """PID gains on the motor side: Kp N m/rad, Kd N m s/rad, Ki N m/(rad s).

    For a computed-torque outer loop (``J_m = 1``) the units are 1/s^2, 1/s, 1/s^3.
    """

    Kp: float
    Kd: float
    Ki: float = 0.0

    def joint_side(self, G: float) -> "JointGains":
        """The same gains seen from the joint: torque per joint rad (or force per m) scales by G^2."""
        g2 = G * G
        return JointGains(self.Kp * g2, self.Kd * g2, self.Ki * g2)


@dataclass(frozen=True)
class JointLoop:
    """A designed joint loop: plant, gains, sampling period and the design targets.

    Attributes
    ----------
    kind
        Controller kind ('pd', 'pd-g', 'pid', 'pd-ff' or 'ct').
    plant, gains
        The decoupled plant and the gains (both motor side).
    dt
        Control period, s; ``None`` for a continuous-time loop only.
    wn, damping
        Natural frequency (rad/s) and damping of the designed closed-loop poles.
    bandwidth_target
        The requested closed-loop bandwidth, rad/s.
    """

    kind: str
    plant: JointPlant
    gains: JointGains
    dt: float | None = None
    wn: float = math.nan
    damping: float = math.nan
    bandwidth_target: float = math.nan

    @property
    def has_integral(self) -> bool:
        """True for a loop with integral action (Ki != 0)."""
        return self.gains.Ki != 0.0

    # ----------------------------------------------------------- loop transfer
    def loop_matrices(self, discrete: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C, D)`` of L (plant input -> controller output, sign flipped)."""
        A, B = self.plant.state_matrices()
        g = self.gains
        if discrete:
            dt = self.period()
            A, B = zoh_matrices(A, B, dt)
        if not self.has_integral:
            return A, B, np.array([[g.Kp, g.Kd]]), np.zeros((1, 1))
        # w = integral of theta: w' = theta, or w_{k+1} = w_k + T theta_k.
        Aw = np.zeros((3, 3))
        Aw[:2, :2] = A
        Aw[2, :] = [self.period() if discrete else 1.0, 0.0, 1.0 if discrete else 0.0]
        Bw = np.vstack([B, [[0.0]]])
        return Aw, Bw, np.array([[g.Kp, g.Kd, g.Ki]]), np.zeros((1, 1))

    def loop(self, discrete: bool = False) -> control.StateSpace:
        """The loop transfer L as a python-control StateSpace (dt set when discrete)."""
        A, B, C, D = self.loop_matrices(discrete)
        return control.ss(A, B, C, D, self.period() if discrete else 0)

    # ------------------------------------------------------------ closed loop
    def closed_loop_matrices(self, discrete: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A, B, C, D)`` of the closed loop: inputs [r, d_m], outputs [theta_m, e, tau_m]."""
        A, B = self.plant.state_matrices()
        g = self.gains
        K = np.array([[g.Kp, g.Kd]])
        if discrete:
            dt = self.period()
            A, B = zoh_matrices(A, B, dt)
        nx = 3 if self.has_integral else 2
        Acl = np.zeros((nx, nx))
        Bcl = np.zeros((nx, 2))
        Acl[:2, :2] = A - B @ K
        Bcl[:2, 0:1] = B * g.Kp
        Bcl[:2, 1:2] = B
        C = np.zeros((3, nx))
        D = np.zeros((3, 2))
        C[0, 0] = 1.0
        C[1, 0] = -1.0
        D[1, 0] = 1.0
        C[2, :2] = -K[0]
        D[2, 0] = g.Kp
        if self.has_integral:
            # z = integral of the error; tau_m gains Ki z.
            Acl[:2, 2:3] = B * g.Ki
            if discrete:
                Acl[2, :] = [-self.period(), 0.0, 1.0]
                Bcl[2, 0] = self.period()
            else:
                Acl[2, 0] = -1.0
                Bcl[2, 0] = 1.0
            C[2, 2] = g.Ki
        return Acl, Bcl, C, D

    def closed_loop(self, discrete: bool = False) -> control.StateSpace:
        """Closed loop as a StateSpace, inputs ['r', 'd_m'], outputs ['theta_m', 'e', 'tau_m']."""
        A, B, C, D = self.closed_loop_matrices(discrete)
        return control.ss(A, B, C, D, self.period() if discrete else 0,
                          inputs=["r", "d_m"], outputs=["theta_m", "e", "tau_m"])

    def evaluate(self, omega: np.ndarray, which: str = "loop", discrete: bool = False,
                 output: int = 0, input: int = 0) -> np.ndarray:
        """Complex frequency response at ``omega`` (rad/s) of the loop or one closed-loop channel.

        Parameters
        ----------
        omega
            Frequencies, rad/s (for a discrete loop, at most pi / dt).
        which
            'loop' for L, 'closed' for the closed loop channel (output, input).
        """
        if which == "loop":
            A, B, C, D = self.loop_matrices(discrete)
        elif which == "closed":
            A, B, C, D = self.closed_loop_matrices(discrete)
        else:
            raise InputError(f"expected 'loop' or 'closed', got {which!r}", parameter="which")
        b = B[:, input]
        c = C[output, :]
        d = D[output, input]
        w = np.atleast_1d(np.asarray(omega, dtype=float))
        s = np.exp(1j * w * self.period()) if discrete else 1j * w
        eye = np.eye(A.shape[0])
        return np.array([c @ np.linalg.solve(sk * eye - A, b) + d for sk in s])

    def period(self) -> float:
        """The control period dt, s; ValueError for a continuous-only loop."""
        if self.dt is None:
            raise InputError(f"this {self.kind!r} loop is continuous-time (dt=None); a discrete analysis needs a "
                             "control period",
                             parameter="dt")
        return float(self.dt)


def gains_arrays(loops: Sequence[JointLoop]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Kp, Kd, Ki) arrays with one entry per loop (motor side, or 1/s^2, 1/s, 1/s^3 for outer loops)."""
    return (np.array([lp.gains.Kp for lp in loops]), np.array([lp.gains.Kd for lp in loops]),
            np.array([lp.gains.Ki for lp in loops]))
