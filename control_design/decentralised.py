"""Independent-joint loop design: PD, PD + gravity compensation, PID, PD + feed-forward.

Each joint is designed on its decoupled motor-side plant
``1 / (J_m s^2 + B_m s)`` (see :mod:`control_design.joint_model`) from a
closed-loop bandwidth (rad/s, where ``|theta_m / r|`` falls to 1/sqrt(2) of
its DC value) and a damping ratio, or a phase margin instead of the damping.

* PD (and 'pd-g', 'pd-ff', which add gravity compensation or feed-forward to
  the same feedback): ``Kp = J wn^2``, ``Kd = 2 zeta wn J - B``, which makes
  the step closed loop exactly ``wn^2 / (s^2 + 2 zeta wn s + wn^2)``; its
  bandwidth is ``wn * beta(zeta)`` with
  ``beta = sqrt(1 - 2 zeta^2 + sqrt(4 zeta^4 - 4 zeta^2 + 2))`` (1 at zeta = 1/sqrt 2).
* PID: the three closed-loop poles are ``wn`` with damping ``zeta`` and a real
  pole at ``integral_ratio * wn``:
  ``J s^3 + (B + Kd) s^2 + Kp s + Ki = J (s^2 + 2 zeta wn s + wn^2)(s + p wn)``.
  The closed loop is then a fixed shape scaled by ``wn``, so the bandwidth is
  ``wn`` times a number computed once per (zeta, p).

The controller kinds differ only in what they add to this feedback (gravity
compensation, feed-forward); the loop, hence the margins, is the same.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import scipy.optimize

from .errors import DesignSpecError, UnknownControllerError
from .loops import JointGains, JointLoop, JointPlant, check_rate
from .responses import closed_loop_bandwidth, disturbance_rejection, margins, step_response

__all__ = [
    "DECENTRALISED_KINDS",
    "DEFAULT_BANDWIDTH",
    "DEFAULT_DAMPING",
    "DEFAULT_INTEGRAL_RATIO",
    "JointReport",
    "second_order_bandwidth_ratio",
    "pid_bandwidth_ratio",
    "pd_gains",
    "pid_gains",
    "check_spec",
    "design_joint",
    "analyse_joint",
]

DECENTRALISED_KINDS: tuple[str, ...] = ("pd", "pd-g", "pid", "pd-ff")
#: Default closed-loop bandwidth, rad/s (8 Hz: an order below the 1 kHz control
#: rate's 100 Hz limit, an order above the 3 s segments of the pick-and-place).
DEFAULT_BANDWIDTH = 50.0
#: Default damping ratio: 0.7, about 5 % overshoot for the PD loops.
DEFAULT_DAMPING = 0.7
#: PID: the integral pole sits at this multiple of wn.
DEFAULT_INTEGRAL_RATIO = 1.0


def second_order_bandwidth_ratio(damping: float) -> float:
    """``w_bw / wn`` of ``wn^2 / (s^2 + 2 zeta wn s + wn^2)`` (the -3.01 dB point), closed form."""
    z2 = damping * damping
    return math.sqrt(1.0 - 2.0 * z2 + math.sqrt(4.0 * z2 * z2 - 4.0 * z2 + 2.0))


def pid_bandwidth_ratio(damping: float, integral_ratio: float) -> float:
    """``w_bw / wn`` of the PID closed loop ``((1+2 zeta p) wn^2 s + p wn^3) / ((s^2+2 zeta wn s+wn^2)(s+p wn))``."""
    z, p = damping, integral_ratio
    num = np.array([1.0 + 2.0 * z * p, p])
    den = np.polymul([1.0, 2.0 * z, 1.0], [1.0, p])

    def mag(x: float) -> float:
        s = 1j * x
        return abs(np.polyval(num, s) / np.polyval(den, s))

    level = 1.0 / math.sqrt(2.0)
    x = np.logspace(-3, 3, 3000)
    m = np.array([mag(v) for v in x])
    k = int(np.nonzero(m < level)[0][0])
    return float(scipy.optimize.brentq(lambda v: mag(v) - level, x[k - 1], x[k], xtol=1e-14, rtol=1e-13))


def _kd_or_fail(plant: JointPlant, kd: float, damping: float, wn: float) -> float:
    if kd < 0.0:
        natural = plant.B_m / (2.0 * plant.J_m * wn)
        raise DesignSpecError(
            f"{damping:g} is below what friction alone gives joint {plant.name or '?'} at wn = {wn:.4g} rad/s "
            f"(B_m / (2 J_m wn) = {natural:.4g}); expected a damping >= {natural:.4g} or a higher bandwidth",
        parameter="damping")
    return kd


def pd_gains(plant: JointPlant, wn: float, damping: float) -> JointGains:
    """PD gains placing the closed-loop poles at natural frequency ``wn`` (rad/s) and ``damping``."""
    J, B = plant.J_m, plant.B_m
    kd = _kd_or_fail(plant, 2.0 * damping * wn * J - B, damping, wn)
    return JointGains(Kp=J * wn * wn, Kd=kd)


def pid_gains(plant: JointPlant, wn: float, damping: float, integral_ratio: float = DEFAULT_INTEGRAL_RATIO) -> JointGains:
    """PID gains placing poles ``wn``/``damping`` and a real pole at ``integral_ratio * wn``."""
    J, B, p = plant.J_m, plant.B_m, integral_ratio
    kd = _kd_or_fail(plant, J * (2.0 * damping + p) * wn - B, damping, wn)
    return JointGains(Kp=J * (1.0 + 2.0 * damping * p) * wn * wn, Kd=kd, Ki=J * p * wn ** 3)


def check_spec(kind: str, bandwidth: float, damping: float | None, phase_margin: float | None,
               rate_hz: float | None, kinds: tuple[str, ...] = DECENTRALISED_KINDS + ("ct",)) -> None:
    """Validate a design request; raise a :class:`~control_design.errors.ControlDesignError` naming the bad argument."""
    if kind not in kinds:
        raise UnknownControllerError(f"expected one of {', '.join(kinds)}, got {kind!r}", parameter="controller")
    if not (isinstance(bandwidth, (int, float)) and math.isfinite(bandwidth) and bandwidth > 0):
        raise DesignSpecError(f"expected a positive number of rad/s, got {bandwidth!r}", parameter="bandwidth")
    if damping is not None and phase_margin is not None:
        raise DesignSpecError(f"give a damping ({damping!r}) or a phase margin ({phase_margin!r}), not both",
                              parameter="damping")
    if damping is not None and not (math.isfinite(damping) and 0.05 <= damping <= 5.0):
        raise DesignSpecError(f"expected a damping ratio in [0.05, 5], got {damping!r}", parameter="damping")
    if phase_margin is not None and not (math.isfinite(phase_margin) and 5.0 <= phase_margin < 90.0):
        raise DesignSpecError(f"expected a phase margin in [5, 90) deg, got {phase_margin!r}", parameter="phase_margin")
    check_rate(bandwidth, rate_hz)


def _loop_for(plant: JointPlant, kind: str, bandwidth: float, damping: float, dt: float | None, integral_ratio: float) -> JointLoop:
    if kind == "pid":
        wn = bandwidth / pid_bandwidth_ratio(damping, integral_ratio)
        gains = pid_gains(plant, wn, damping, integral_ratio)
    else:
        wn = bandwidth / second_order_bandwidth_ratio(damping)
        gains = pd_gains(plant, wn, damping)
    return JointLoop(kind=kind, plant=plant, gains=gains, dt=dt, wn=wn, damping=damping, bandwidth_target=bandwidth)


def design_joint(plant: JointPlant, kind: str = "pd", bandwidth: float = DEFAULT_BANDWIDTH, damping: float | None = None, *,
                 phase_margin: float | None = None, rate_hz: float | None = None,
                 integral_ratio: float = DEFAULT_INTEGRAL_RATIO) -> JointLoop:
    """Design one joint loop for a closed-loop bandwidth and a damping (or phase margin).

    Parameters
    ----------
    plant
        Decoupled motor-side plant of the joint.
    kind
        'pd', 'pd-g', 'pid', 'pd-ff' (or 'ct' for a computed-torque outer loop on ``J_m = 1, B_m = 0``).
    bandwidth
        Closed-loop bandwidth of ``theta_m / r``, rad/s.
    damping
        Damping ratio of the designed poles (default :data:`DEFAULT_DAMPING`).
    phase_margin
        Continuous-loop phase margin, deg, instead of ``damping`` (the damping is solved for).
    rate_hz
        Control rate, Hz (``None``: continuous design only).
    integral_ratio
        PID only: integral pole at ``integral_ratio * wn``.

    Returns
    -------
    JointLoop

    Raises
    ------
    DesignSpecError, SamplingRateError, UnknownControllerError
    """
    check_spec(kind, bandwidth, damping, phase_margin, rate_hz)
    dt = None if rate_hz is None else 1.0 / rate_hz
    if phase_margin is None:
        return _loop_for(plant, kind, bandwidth, DEFAULT_DAMPING if damping is None else damping, dt, integral_ratio)

    def excess(z: float) -> float:
        return margins(_loop_for(plant, kind, bandwidth, z, None, integral_ratio)).pm - phase_margin

    lo, hi = 0.05, 5.0
    try:
        f_lo, f_hi = excess(lo), excess(hi)
    except DesignSpecError as exc:
        raise DesignSpecError(f"{phase_margin:g} deg cannot be met: {exc}", parameter="phase_margin") from exc
    if f_lo * f_hi > 0:
        raise DesignSpecError(
            f"expected a value between {f_lo + phase_margin:.1f} and {f_hi + phase_margin:.1f} deg "
            f"for a {kind} loop at {bandwidth:g} rad/s, got {phase_margin:g}",
        parameter="phase_margin")
    z = float(scipy.optimize.brentq(excess, lo, hi, xtol=1e-10))
    return _loop_for(plant, kind, bandwidth, z, dt, integral_ratio)


@dataclass(frozen=True)
class JointReport:
    """Numbers of one designed joint loop (continuous, and sampled when ``dt`` is set).

    Gains are motor side (N m/rad, N m s/rad, N m/(rad s)); ``*_j`` fields are joint side
    (per joint rad or m); frequencies in rad/s, times in s, margins: gain factor and deg.
    Fields ending in ``_d`` are the sampled loop's. A PID loop is conditionally stable
    (two integrators: the phase starts near -180 deg), so its gain margin is below 1:
    the factor by which the gain may *drop* before instability.
    ``step_peak_tau_m_per_unit_j`` is the peak motor torque of a 1 rad (or 1 m) joint step.
    """

    name: str
    kind: str
    unit: str
    G: float
    J_m: float
    B_m: float
    Kp_m: float
    Kd_m: float
    Ki_m: float
    Kp_j: float
    Kd_j: float
    Ki_j: float
    wn: float
    damping: float
    bandwidth_target: float
    crossover: float
    gain_margin: float
    phase_margin: float
    bandwidth: float
    rise_time: float
    overshoot: float
    settling_time: float
    step_peak_tau_m_per_unit_j: float
    dist_dc_gain_j: float
    dist_l1_gain_j: float
    coupling_tau_m: float
    coupling_error_static_j: float
    coupling_error_bound_j: float
    dt: float | None = None
    crossover_d: float = math.nan
    gain_margin_d: float = math.nan
    phase_margin_d: float = math.nan
    phase_margin_loss: float = math.nan
    phase_margin_loss_zoh: float = math.nan
    bandwidth_d: float = math.nan
    rise_time_d: float = math.nan
    overshoot_d: float = math.nan
    settling_time_d: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; infinities become the string 'inf', nan becomes None."""
        out: dict[str, Any] = {}
        for key, value in asdict(self).items():
            if isinstance(value, float) and math.isnan(value):
                value = None
            elif isinstance(value, float) and math.isinf(value):
                value = "inf" if value > 0 else "-inf"
            out[key] = value
        return out


def analyse_joint(loop: JointLoop, coupling_tau_m: float = 0.0) -> JointReport:
    """Margins, bandwidth, step metrics and coupling rejection of ``loop``.

    Parameters
    ----------
    loop
        A designed loop; with ``loop.dt`` set the sampled loop is analysed too and
        the phase margin lost to sampling is compared with the ZOH estimate ``w_c T / 2``.
    coupling_tau_m
        Largest coupling torque seen at the motor, N m (joint-side coupling / |G|).
        ``coupling_error_static_j`` is its static error, ``coupling_error_bound_j`` the
        worst-case peak error (L1 gain times the peak), both joint side.
    """
    G = loop.plant.G
    m = margins(loop)
    st = step_response(loop)
    rej = disturbance_rejection(loop, discrete=loop.dt is not None)
    jg = loop.gains.joint_side(G)
    fields: dict[str, Any] = dict(
        name=loop.plant.name, kind=loop.kind, unit=loop.plant.unit, G=G, J_m=loop.plant.J_m, B_m=loop.plant.B_m,
        Kp_m=loop.gains.Kp, Kd_m=loop.gains.Kd, Ki_m=loop.gains.Ki, Kp_j=jg.Kp, Kd_j=jg.Kd, Ki_j=jg.Ki,
        wn=loop.wn, damping=loop.damping, bandwidth_target=loop.bandwidth_target,
        crossover=m.w_gc, gain_margin=m.gm, phase_margin=m.pm, bandwidth=closed_loop_bandwidth(loop),
        rise_time=st.rise_time, overshoot=st.overshoot, settling_time=st.settling_time,
        step_peak_tau_m_per_unit_j=st.peak_tau_m * abs(G),
        dist_dc_gain_j=rej.joint_side(rej.dc_gain_m), dist_l1_gain_j=rej.joint_side(rej.l1_gain_m),
        coupling_tau_m=coupling_tau_m,
        coupling_error_static_j=rej.dc_gain_m * coupling_tau_m / abs(G),
        coupling_error_bound_j=rej.l1_gain_m * coupling_tau_m / abs(G),
        dt=loop.dt,
    )
    if loop.dt is not None:
        md = margins(loop, discrete=True)
        sd = step_response(loop, discrete=True)
        fields.update(
            crossover_d=md.w_gc, gain_margin_d=md.gm, phase_margin_d=md.pm, phase_margin_loss=m.pm - md.pm,
            phase_margin_loss_zoh=math.degrees(m.w_gc * loop.dt / 2.0), bandwidth_d=closed_loop_bandwidth(loop, True),
            rise_time_d=sd.rise_time, overshoot_d=sd.overshoot, settling_time_d=sd.settling_time,
        )
    return JointReport(**fields)
