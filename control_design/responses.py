"""Frequency and time responses of a joint loop, as result objects (no drawing).

* :func:`margins` - gain and phase margins and their crossover frequencies of L.
* :func:`closed_loop_bandwidth` - where |r -> theta_m| falls to 1/sqrt(2) of its DC value.
* :func:`bode_response` - L(jw) on a grid with its margins (drawn by ``plots.bode_plot``).
* :func:`step_response` - unit motor-angle step: position, torque, rise/settling/overshoot.
* :func:`disturbance_rejection` - the disturbance-to-error gains (DC, peak, L1).

Continuous loops are evaluated at ``s = j w``, discrete ones at
``z = exp(j w T)`` up to the Nyquist frequency ``pi / T``; margins are found
from sign changes on a dense logarithmic grid refined with Brent's method, so
a crossing exactly at the Nyquist frequency (where the zero-order hold puts
the -180 deg crossing of a sampled PD loop) is not missed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np
import scipy.linalg
import scipy.optimize

from .errors import DesignSpecError
from .loops import JointLoop

__all__ = [
    "Margins",
    "BodeResponse",
    "StepResponse",
    "DisturbanceRejection",
    "margins",
    "closed_loop_bandwidth",
    "bode_response",
    "step_response",
    "disturbance_rejection",
    "frequency_grid",
    "power_sequence",
]

_GRID_POINTS = 3000          # points of the search grid: 6 decades -> 0.2 % spacing
_GRID_DECADES = (-3.0, 3.0)  # around the loop's reference frequency


@dataclass(frozen=True)
class Margins:
    """Stability margins of a loop transfer L.

    Attributes
    ----------
    gm
        Gain margin (factor, not dB); ``inf`` if L never crosses the negative real axis.
        With several crossings, the one closest to 0 dB.
    pm
        Phase margin, deg; the smallest over the gain crossovers (``inf`` if none).
    w_gc
        Gain-crossover frequency (|L| = 1) of ``pm``, rad/s (nan if none).
    w_pc
        Phase-crossover frequency of ``gm``, rad/s (nan if none).
    """

    gm: float
    pm: float
    w_gc: float
    w_pc: float

    @property
    def gm_db(self) -> float:
        """Gain margin in dB."""
        return 20.0 * math.log10(self.gm) if math.isfinite(self.gm) else math.inf


@dataclass(frozen=True)
class BodeResponse:
    """L(jw) of one loop on a frequency grid, with its margins.

    Attributes
    ----------
    omega
        (N,) frequencies, rad/s.
    L
        (N,) complex loop response.
    margins
        :class:`Margins` of the loop.
    dt
        Sampling period, s, or ``None`` for a continuous loop.
    label
        Legend text (joint name and kind).
    """

    omega: np.ndarray
    L: np.ndarray
    margins: Margins
    dt: float | None
    label: str = ""

    @property
    def mag_db(self) -> np.ndarray:
        """Magnitude of L in dB."""
        return 20.0 * np.log10(np.abs(self.L))

    @property
    def phase_deg(self) -> np.ndarray:
        """Unwrapped phase in degrees, starting in (-360, 0]."""
        ph = np.degrees(np.unwrap(np.angle(self.L)))
        return ph - 360.0 * math.ceil(ph[0] / 360.0)


@dataclass(frozen=True)
class StepResponse:
    """Response to a unit step of the motor-angle reference (1 rad at the motor).

    Attributes
    ----------
    t
        (N,) time, s.
    theta_m
        (N,) motor angle, rad.
    tau_m
        (N,) motor torque, N m.
    rise_time
        10 % - 90 % rise time, s.
    settling_time
        Time to stay within 2 % of the final value, s.
    overshoot
        Overshoot, percent of the final value.
    peak_tau_m
        Largest |tau_m| over the response, N m per motor rad of step.
    dt, label
        Sampling period (``None``: continuous) and legend text.
    """

    t: np.ndarray
    theta_m: np.ndarray
    tau_m: np.ndarray
    rise_time: float
    settling_time: float
    overshoot: float
    peak_tau_m: float
    dt: float | None
    label: str = ""


@dataclass(frozen=True)
class DisturbanceRejection:
    """How a motor-side disturbance torque ``d_m`` moves the position error.

    Attributes
    ----------
    dc_gain_m
        |e / d_m| at zero frequency, motor rad per N m (0 with integral action).
    peak_gain_m
        max over w of |e / d_m|, motor rad per N m.
    l1_gain_m
        Integral of |impulse response| (sum of |pulse response| when discrete),
        rad per N m: ``l1_gain_m * max|d_m|`` bounds the peak error for any d_m.
    G
        Reduction ratio, to state the same gains joint side.
    """

    dc_gain_m: float
    peak_gain_m: float
    l1_gain_m: float
    G: float

    def joint_side(self, gain_m: float) -> float:
        """A motor-side ``e_m / d_m`` gain as joint error per joint torque: divided by G^2."""
        return gain_m / (self.G * self.G)


# --------------------------------------------------------------------------- helpers
def _reference_frequency(loop: JointLoop) -> float:
    if math.isfinite(loop.wn) and loop.wn > 0:
        return float(loop.wn)
    g = loop.gains
    return math.sqrt(max(g.Kp, 1e-300) / loop.plant.J_m)


def frequency_grid(loop: JointLoop, discrete: bool = False, points: int = _GRID_POINTS) -> np.ndarray:
    """Logarithmic grid of ``points`` frequencies (rad/s), 3 decades either side of the loop's natural
    frequency; a discrete grid ends exactly at the Nyquist frequency pi / dt."""
    w0 = _reference_frequency(loop)
    lo, hi = w0 * 10 ** _GRID_DECADES[0], w0 * 10 ** _GRID_DECADES[1]
    if discrete:
        nyq = math.pi / loop.period()
        hi = nyq
        lo = min(lo, nyq * 1e-4)
    return np.logspace(math.log10(lo), math.log10(hi), points)


def _refine(f, a: float, b: float) -> float:
    return float(scipy.optimize.brentq(f, a, b, xtol=1e-12 * max(abs(a), 1.0), rtol=1e-12))


def margins(loop: JointLoop, discrete: bool = False) -> Margins:
    """Gain and phase margins of the loop transfer ``L = C P`` of ``loop``.

    Parameters
    ----------
    loop
        The joint loop.
    discrete
        Analyse the sampled loop (ZOH plant, discrete controller) instead of the continuous one.
    """
    w = frequency_grid(loop, discrete)
    L = loop.evaluate(w, "loop", discrete)

    def single(x: float) -> complex:
        return complex(loop.evaluate(np.array([x]), "loop", discrete)[0])

    # gain crossovers
    logmag = np.log(np.abs(L))
    pm, w_gc = math.inf, math.nan
    for k in np.nonzero(np.sign(logmag[:-1]) != np.sign(logmag[1:]))[0]:
        wc = _refine(lambda x: math.log(abs(single(x))), w[k], w[k + 1])
        ang = math.degrees(np.angle(single(wc)))
        pm_k = (ang + 360.0) % 360.0 - 180.0
        if pm_k < pm:
            pm, w_gc = pm_k, wc
    # phase crossovers: L crosses the negative real axis
    gm, w_pc = math.inf, math.nan
    im = L.imag
    candidates: list[float] = []
    for k in np.nonzero((np.sign(im[:-1]) != np.sign(im[1:])) & (np.minimum(L.real[:-1], L.real[1:]) < 0))[0]:
        if im[k] == 0.0:
            candidates.append(float(w[k]))
            continue
        candidates.append(_refine(lambda x: single(x).imag, w[k], w[k + 1]))
    if discrete:
        end = L[-1]  # z = -1: real for real matrices
        if end.real < 0 and abs(end.imag) <= 1e-9 * abs(end):
            candidates.append(float(w[-1]))
    for wp in candidates:
        val = single(wp)
        if val.real >= 0:
            continue
        gm_k = 1.0 / abs(val)
        if not math.isfinite(gm) or abs(math.log(gm_k)) < abs(math.log(gm)):
            gm, w_pc = gm_k, wp
    return Margins(gm=gm, pm=pm, w_gc=w_gc, w_pc=w_pc)


def closed_loop_bandwidth(loop: JointLoop, discrete: bool = False) -> float:
    """Closed-loop bandwidth, rad/s: the first frequency where |theta_m / r| falls to
    1/sqrt(2) (-3.01 dB) of its DC value; nan if it never does below the grid's end."""
    w = frequency_grid(loop, discrete)
    dc = abs(loop.evaluate(np.array([0.0]), "closed", discrete)[0])
    T = np.abs(loop.evaluate(w, "closed", discrete))
    level = dc / math.sqrt(2.0)
    below = np.nonzero(T < level)[0]
    if below.size == 0:
        return math.nan
    k = int(below[0])
    if k == 0:
        return float(w[0])
    return _refine(lambda x: abs(loop.evaluate(np.array([x]), "closed", discrete)[0]) - level, w[k - 1], w[k])


def bode_response(loop: JointLoop, discrete: bool = False, omega: np.ndarray | None = None, label: str = "") -> BodeResponse:
    """L(jw) of ``loop`` with its :class:`Margins` (a discrete grid stops at pi / dt)."""
    w = frequency_grid(loop, discrete, 800) if omega is None else np.asarray(omega, dtype=float)
    return BodeResponse(omega=w, L=loop.evaluate(w, "loop", discrete), margins=margins(loop, discrete),
                        dt=loop.dt if discrete else None, label=label or f"{loop.plant.name} ({loop.kind})")


def _slowest_time_constant(loop: JointLoop, A: np.ndarray, dt: float | None) -> float:
    """The slowest time constant of the closed loop ``A`` (s); a design error if it is not asymptotically stable."""
    eig = np.linalg.eigvals(A)
    if dt is None:
        sigma = float(np.min(-eig.real))
    else:
        sigma = float(np.min(-np.log(np.maximum(np.abs(eig), 1e-300)))) / dt
    if not sigma > 0:
        which = "continuous" if dt is None else f"sampled ({1.0 / dt:g} Hz)"
        raise DesignSpecError(f"joint {loop.plant.name}: the {which} closed loop of this {loop.kind} design is not "
                              f"asymptotically stable (slowest decay rate {sigma:.3g} 1/s): expected targets the loop "
                              "can meet (a lower bandwidth or phase margin, or a higher rate)")
    return 1.0 / sigma


def power_sequence(A: np.ndarray, v: np.ndarray, count: int) -> np.ndarray:
    """``[v, A v, A^2 v, ..., A^(count-1) v]`` as columns of an (len(v), count) array.

    Built by doubling (the next block is ``A^m`` times the block so far), so a sequence of millions of
    samples costs about log2(count) matrix products instead of a Python loop per sample.
    """
    out = np.empty((v.shape[0], count))
    if count == 0:
        return out
    out[:, 0] = v
    filled, A_m = 1, A  # A_m = A^filled whenever another block follows
    while filled < count:
        take = min(filled, count - filled)  # a block shorter than ``filled`` is the last one
        out[:, filled:filled + take] = A_m @ out[:, :take]
        filled += take
        A_m = A_m @ A_m
    return out


def _discrete_step(A: np.ndarray, b: np.ndarray, C: np.ndarray, D: np.ndarray, samples: int) -> np.ndarray:
    """(rows of C, samples) outputs of ``x+ = A x + b u, y = C x + D u`` for a unit step u from x = 0:
    ``x_k = sum_{j<k} A^j b``, the cumulative sum of the power sequence."""
    x = np.zeros((b.shape[0], samples))
    x[:, 1:] = np.cumsum(power_sequence(A, b, samples - 1), axis=1)
    return C @ x + D[:, None]


def step_response(loop: JointLoop, discrete: bool = False, label: str = "") -> StepResponse:
    """Unit step of the motor-angle reference through the closed loop (continuous or sampled).

    The response is computed until ten times the slowest closed-loop time
    constant (the tail is then below e^-10 of its start). Rise time is
    10 %-90 %, settling within 2 %, as ``control.step_info``.
    """
    A, B, C, D = loop.closed_loop_matrices(discrete)
    dt = loop.period() if discrete else None
    t_end = 10.0 * _slowest_time_constant(loop, A, dt)
    if discrete:
        t = np.arange(0, int(math.ceil(t_end / dt)) + 1) * dt
        y = _discrete_step(A, B[:, 0], C[[0, 2], :], D[[0, 2], 0], t.size)
    else:
        t = np.linspace(0.0, t_end, 5001)
        resp = control.step_response(control.ss(A, B[:, :1], C[[0, 2], :], D[[0, 2], :1]), timepts=t)
        y = np.asarray(resp.outputs).reshape(2, -1)
    theta, tau = y[0], y[1]
    dc = float(loop.evaluate(np.array([0.0]), "closed", discrete)[0].real)  # exact final value, not the last sample
    info = control.step_info(theta, timepts=t, final_output=dc, SettlingTimeThreshold=0.02, RiseTimeLimits=(0.1, 0.9))
    return StepResponse(t=t, theta_m=theta, tau_m=tau, rise_time=float(info["RiseTime"]),
                        settling_time=float(info["SettlingTime"]), overshoot=float(info["Overshoot"]),
                        peak_tau_m=float(np.max(np.abs(tau))), dt=dt,
                        label=label or f"{loop.plant.name} ({loop.kind})")


def disturbance_rejection(loop: JointLoop, discrete: bool = False) -> DisturbanceRejection:
    """DC, peak and L1 gains from a motor-side disturbance torque ``d_m`` to the position error."""
    A, B, C, D = loop.closed_loop_matrices(discrete)
    b, c = B[:, 1], C[1, :]
    # With integral action the static gain is exactly zero (evaluating it would give rounding noise).
    dc = 0.0 if loop.has_integral else abs(loop.evaluate(np.array([0.0]), "closed", discrete, output=1, input=1)[0])
    w = frequency_grid(loop, discrete)
    peak = float(np.max(np.abs(loop.evaluate(w, "closed", discrete, output=1, input=1))))
    peak = max(peak, dc)
    dt = loop.period() if discrete else None
    t_end = 12.0 * _slowest_time_constant(loop, A, dt)
    if discrete:
        h = np.empty(int(math.ceil(t_end / dt)) + 1)
        h[0] = 0.0  # D[1, 1] = 0: the held disturbance shows one sample later
        h[1:] = c @ power_sequence(A, b, h.size - 1)
        l1 = float(np.sum(np.abs(h)))
    else:
        # h(t) = c expm(A t) b, propagated exactly on a uniform grid of 20000 steps.
        steps = 20000
        step = t_end / steps
        Phi = scipy.linalg.expm(A * step)
        h = np.empty(steps + 1)
        x = b.copy()
        for k in range(steps + 1):
            h[k] = c @ x
            x = Phi @ x
        absh = np.abs(h)
        l1 = float(step * (absh.sum() - 0.5 * (absh[0] + absh[-1])))
    return DisturbanceRejection(dc_gain_m=float(dc), peak_gain_m=peak, l1_gain_m=l1, G=loop.plant.G)
