"""Independent-joint design: gains meet the specification, margins match closed forms, sampling costs w_c T / 2.

Hand-made plants (inertia, friction) test the per-joint design; the SCARA
tests check the decoupled joint models against the robot description.
"""

from __future__ import annotations

import math
from pathlib import Path

import control
import numpy as np
import pytest

from control_design.decentralised import (analyse_joint, design_joint, pd_gains, pid_bandwidth_ratio,
                                          second_order_bandwidth_ratio)
from control_design.errors import DesignSpecError, SamplingRateError, UnknownControllerError
from control_design.joint_model import (TORQUE_LIMIT_FACTOR, decoupled_model, effective_inertia_m,
                                        sample_configurations, torque_limits)
from control_design.loops import JointGains, JointLoop, JointPlant, check_rate, zoh_matrices
from control_design.reference import reference_task
from control_design.responses import (closed_loop_bandwidth, disturbance_rejection, margins, step_response)
from model.robot import load_robot

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

# Named plants: (J_m kg m^2, B_m N m s/rad) - a heavy shoulder, a light wrist, a friction-dominated joint.
PLANTS = {
    "shoulder": JointPlant(J_m=0.07, B_m=1.48e-3, G=-62.6, name="shoulder"),
    "wrist": JointPlant(J_m=3.3e-5, B_m=7.1e-5, G=76.0, name="wrist"),
    "sticky": JointPlant(J_m=2e-3, B_m=0.05, G=10.0, name="sticky"),
}

# Design tolerance: the bandwidth is found by Brent's method on |T(jw)| with xtol ~1e-12 relative,
# so the closed-loop bandwidth must match the request to 1e-8 relative (rounding, not method error).
BW_RTOL = 1e-8


def closed_loop_poles(loop: JointLoop) -> np.ndarray:
    A, *_ = loop.closed_loop_matrices()
    return np.linalg.eigvals(A)


@pytest.mark.parametrize("plant", PLANTS.values(), ids=PLANTS.keys())
@pytest.mark.parametrize("damping", [0.5, 1 / math.sqrt(2), 1.0])
def test_pd_meets_bandwidth_and_damping(plant, damping):
    loop = design_joint(plant, "pd", bandwidth=40.0, damping=damping)
    assert closed_loop_bandwidth(loop) == pytest.approx(40.0, rel=BW_RTOL)
    # Characteristic polynomial J s^2 + (B + Kd) s + Kp = J (s^2 + 2 zeta wn s + wn^2): exact algebra.
    wn = math.sqrt(loop.gains.Kp / plant.J_m)
    zeta = (plant.B_m + loop.gains.Kd) / (2 * plant.J_m * wn)
    assert zeta == pytest.approx(damping, rel=1e-12)
    assert wn == pytest.approx(loop.wn, rel=1e-12)
    assert np.allclose(np.abs(closed_loop_poles(loop)), wn, rtol=1e-6)  # repeated root at zeta = 1: sqrt(eps) accuracy


def test_bandwidth_ratio_closed_form_against_python_control():
    for zeta in (0.3, 0.7, 1 / math.sqrt(2), 1.0, 2.0):
        T = control.tf([1.0], [1.0, 2 * zeta, 1.0])
        # control.bandwidth uses a -3 dB drop; ours 1/sqrt(2) (-3.0103 dB): 0.35 % apart at most.
        assert second_order_bandwidth_ratio(zeta) == pytest.approx(control.bandwidth(T, dbdrop=20 * math.log10(1 / math.sqrt(2))), rel=1e-6)
    assert second_order_bandwidth_ratio(1 / math.sqrt(2)) == pytest.approx(1.0, abs=1e-15)


@pytest.mark.parametrize("plant", PLANTS.values(), ids=PLANTS.keys())
def test_pid_meets_bandwidth_and_places_three_poles(plant):
    loop = design_joint(plant, "pid", bandwidth=30.0, damping=0.8, integral_ratio=0.5)
    assert closed_loop_bandwidth(loop) == pytest.approx(30.0, rel=BW_RTOL)
    wn = loop.wn
    expected = np.sort_complex(np.roots(np.polymul([1, 2 * 0.8 * wn, wn * wn], [1, 0.5 * wn])))
    assert np.allclose(np.sort_complex(closed_loop_poles(loop)), expected, rtol=1e-8)
    assert wn == pytest.approx(30.0 / pid_bandwidth_ratio(0.8, 0.5), rel=1e-12)


def test_phase_margin_specification_is_met():
    loop = design_joint(PLANTS["shoulder"], "pd", bandwidth=50.0, phase_margin=55.0)
    assert margins(loop).pm == pytest.approx(55.0, abs=1e-6)  # brentq on the damping, xtol 1e-10
    assert closed_loop_bandwidth(loop) == pytest.approx(50.0, rel=BW_RTOL)


def pd_margins_closed_form(J: float, B: float, Kp: float, Kd: float) -> tuple[float, float]:
    """Crossover and phase margin (deg) of L = (Kp + Kd s) / (J s^2 + B s), derived by hand.

    |L(jw)| = 1  <=>  Kp^2 + w^2 Kd^2 = w^2 (w^2 J^2 + B^2), a quadratic in x = w^2:
    J^2 x^2 + (B^2 - Kd^2) x - Kp^2 = 0. Phase: atan(w Kd / Kp) - 90 - atan(w J / B).
    """
    a, b, c = J * J, B * B - Kd * Kd, -Kp * Kp
    x = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    w = math.sqrt(x)
    pm = 90.0 + math.degrees(math.atan(w * Kd / Kp)) - math.degrees(math.atan2(w * J, B))
    return w, pm


@pytest.mark.parametrize("plant", PLANTS.values(), ids=PLANTS.keys())
@pytest.mark.parametrize("damping", [0.4, 0.7, 1.5])
def test_pd_margins_match_closed_form_and_python_control(plant, damping):
    loop = design_joint(plant, "pd", bandwidth=60.0, damping=damping)
    m = margins(loop)
    w, pm = pd_margins_closed_form(plant.J_m, plant.B_m, loop.gains.Kp, loop.gains.Kd)
    assert m.w_gc == pytest.approx(w, rel=1e-9)
    assert m.pm == pytest.approx(pm, abs=1e-7)
    assert m.gm == math.inf  # phase stays above -180 deg: no phase crossover
    L = control.tf([loop.gains.Kd, loop.gains.Kp], [plant.J_m, plant.B_m, 0.0])
    gm_c, pm_c, _, _, wgc_c, _ = control.stability_margins(L)
    assert pm_c == pytest.approx(pm, abs=1e-5) and wgc_c == pytest.approx(w, rel=1e-6)


def test_zoh_matrices_agree_with_python_control_sample_system():
    plant = PLANTS["shoulder"]
    A, B = plant.state_matrices()
    Ad, Bd = zoh_matrices(A, B, 1e-3)
    sd = control.sample_system(control.ss(A, B, np.eye(2), np.zeros((2, 1))), 1e-3, "zoh")
    assert np.allclose(Ad, sd.A, rtol=1e-12, atol=1e-15) and np.allclose(Bd, sd.B, rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize("rate_hz", [500.0, 1000.0, 4000.0])
def test_sampling_loses_phase_margin_like_the_zoh_delay(rate_hz):
    plant = PLANTS["shoulder"]
    loop = design_joint(plant, "pd", bandwidth=50.0, damping=0.7, rate_hz=rate_hz)
    mc, md = margins(loop), margins(loop, discrete=True)
    T = 1.0 / rate_hz
    predicted = math.degrees(mc.w_gc * T / 2.0)  # ZOH ~ exp(-s T / 2): a w T / 2 phase lag
    # The half-sample delay is the first term of the ZOH's phase; the rest is O((w_c T)^2) relative,
    # below 3 % for w_c T <= 0.16 (here <= 0.153).
    assert mc.w_gc * T <= 0.16
    assert mc.pm - md.pm == pytest.approx(predicted, rel=0.03)
    # Gain margin of the sampled loop: its phase reaches -180 deg at the Nyquist frequency, z = -1;
    # evaluate L(-1) independently with python-control's sampled plant.
    Pd = control.sample_system(control.ss(*plant.state_matrices(), np.eye(2), np.zeros((2, 1))), T, "zoh")
    L_minus1 = np.array([[loop.gains.Kp, loop.gains.Kd]]) @ np.linalg.solve(-np.eye(2) - Pd.A, Pd.B)
    assert md.w_pc == pytest.approx(math.pi / T, rel=1e-12)
    assert md.gm == pytest.approx(1.0 / abs(L_minus1[0, 0]), rel=1e-9)


def test_step_metrics_match_second_order_formulas():
    loop = design_joint(PLANTS["wrist"], "pd", bandwidth=50.0, damping=0.6)
    st = step_response(loop)
    zeta = 0.6
    overshoot = 100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta * zeta))
    # 5001 time points over 10 time constants: the peak is sampled within ~1e-5 of its value.
    assert st.overshoot == pytest.approx(overshoot, abs=1e-3)
    assert st.peak_tau_m == pytest.approx(loop.gains.Kp, rel=1e-9)  # u(0+) = Kp r: derivative on the measurement
    assert 0 < st.rise_time < st.settling_time


def test_disturbance_rejection_pd_and_pid():
    plant = PLANTS["shoulder"]
    pd = design_joint(plant, "pd", bandwidth=50.0)
    rej = disturbance_rejection(pd)
    assert rej.dc_gain_m == pytest.approx(1.0 / pd.gains.Kp, rel=1e-12)  # static: e = d / Kp
    assert rej.l1_gain_m >= rej.dc_gain_m * (1 - 1e-6)  # the L1 gain bounds every other gain
    assert rej.joint_side(rej.dc_gain_m) == pytest.approx(1.0 / (pd.gains.Kp * plant.G ** 2), rel=1e-12)
    pid = design_joint(plant, "pid", bandwidth=50.0)
    assert disturbance_rejection(pid).dc_gain_m == 0.0  # integral action: no static error
    # ... since at low frequency e / d_m = -s / (J s^3 + (B + Kd) s^2 + Kp s + Ki) -> -s / Ki (1e-4 rel. at w = 1e-3).
    low = pid.evaluate(np.array([1e-3]), "closed", output=1, input=1)[0]
    assert abs(low) == pytest.approx(1e-3 / pid.gains.Ki, rel=1e-4)
    rep = analyse_joint(pd, coupling_tau_m=2.0)
    assert rep.coupling_error_static_j == pytest.approx(2.0 / (pd.gains.Kp * abs(plant.G)), rel=1e-12)


def test_rate_rule_is_ten_times_the_bandwidth_in_hz():
    need = 10 * 100.0 / (2 * math.pi)  # 159.15 Hz for 100 rad/s
    check_rate(100.0, need * 1.001)
    with pytest.raises(SamplingRateError, match=r"rate: 150 Hz is too low for a bandwidth of 100 rad/s .* >= .*159\.2 Hz"):
        check_rate(100.0, 150.0)
    with pytest.raises(SamplingRateError, match="rate: 150 Hz"):
        design_joint(PLANTS["shoulder"], "pd", bandwidth=100.0, rate_hz=150.0)


@pytest.mark.parametrize("kwargs, message", [
    ({"bandwidth": -5.0}, r"bandwidth: expected a positive number of rad/s, got -5\.0"),
    ({"bandwidth": math.nan}, r"bandwidth: expected a positive number"),
    ({"damping": 0.0}, r"damping: expected a damping ratio in \[0\.05, 5\], got 0\.0"),
    ({"phase_margin": 95.0}, r"phase_margin: expected a phase margin in \[5, 90\) deg, got 95\.0"),
    ({"damping": 0.7, "phase_margin": 60.0}, r"damping: give a damping .* or a phase margin"),
])
def test_bad_specifications_are_named(kwargs, message):
    args = {"bandwidth": 50.0, **kwargs}
    with pytest.raises(DesignSpecError, match=message):
        design_joint(PLANTS["shoulder"], "pd", **args)


def test_unknown_kind_and_friction_above_the_requested_damping():
    with pytest.raises(UnknownControllerError, match="controller: expected one of .* got 'lqr'"):
        design_joint(PLANTS["shoulder"], "lqr")
    with pytest.raises(DesignSpecError, match="damping: 0.1 is below what friction alone gives joint sticky"):
        design_joint(PLANTS["sticky"], "pd", bandwidth=5.0, damping=0.1)  # B / (2 J wn) ~ 2.5 > 0.1


def test_gains_joint_side_scale_with_g_squared():
    g = JointGains(2.0, 0.1, 5.0).joint_side(-50.0)
    assert (g.Kp, g.Kd, g.Ki) == (5000.0, 250.0, 12500.0)
    assert pd_gains(JointPlant(1.0), 10.0, 0.5) == JointGains(Kp=100.0, Kd=10.0)


# ----------------------------------------------------------------------------- SCARA joint models

@pytest.fixture(scope="module")
def scara():
    return load_robot("scara")


@pytest.fixture(scope="module")
def scara_model(scara):
    return decoupled_model(scara, reference_task(scara))


def test_effective_inertia_of_scara_quill_and_wrist_from_the_description(scara, scara_model):
    # The quill (prismatic, vertical) carries links 3 and 4 as point masses along its axis; the
    # wrist turns link 4 about its own z axis: both are constant and follow from the data file.
    links = scara.description.links
    quill = links[2].motor_inertia + (links[2].mass + links[3].mass) / links[2].gear_ratio ** 2
    wrist = links[3].motor_inertia + links[3].inertia[2] / links[3].gear_ratio ** 2
    j = scara_model.joints
    for got, want in ((j[2], quill), (j[3], wrist)):
        assert got.J_eff_m_min == pytest.approx(want, rel=1e-12) and got.J_eff_m_max == pytest.approx(want, rel=1e-12)
    # The shoulder's reflected inertia depends on the elbow angle: a wide range, max when stretched (q2 = 0).
    assert j[0].J_eff_m_max / j[0].J_eff_m_min > 4.0
    stretched = effective_inertia_m(scara, np.array([[0.3, 0.0, 1.0, 0.0]]))[0, 0]
    assert j[0].J_eff_m_max == pytest.approx(stretched, rel=1e-12)  # the reference task passes q2 = 0
    assert j[0].J_eff_m == j[0].J_eff_m_max and j[0].rule == "max"


def test_coupling_parts_add_up_to_the_inverse_dynamics(scara_model):
    c = scara_model.coupling
    scale = np.max(np.abs(c.total))
    assert np.max(np.abs(c.parts_sum() - c.total)) < 1e-10 * scale  # two evaluations of the same torque
    # Gravity acts on the quill only: m g with the two carried links.
    assert scara_model.joints[2].coupling_peak_j["gravity"] == pytest.approx((6.0 + 0.5) * 9.81, rel=1e-12)
    # The shoulder turns about the vertical: zero up to the rounding of the Newton-Euler recursion
    # (its rotations cancel to ~1e-29 N m; the Lagrange dU/dq gave an exact 0 by structure).
    assert abs(scara_model.joints[0].coupling_peak_j["gravity"]) < 1e-12 * scara_model.joints[2].coupling_peak_j["gravity"]


def test_torque_limits_follow_the_stated_rule(scara_model):
    lim = scara_model.limits
    need = np.maximum(lim.tau_m_peak_task, lim.tau_m_hold)
    assert np.all(lim.tau_m_max >= TORQUE_LIMIT_FACTOR * need * (1 - 1e-12))
    # Equal rotors, equal ratings; the binding motor has exactly the stated headroom.
    assert lim.tau_m_max[0] == lim.tau_m_max[1] == lim.tau_m_max[2]
    assert np.min(lim.tau_m_max / need) == pytest.approx(TORQUE_LIMIT_FACTOR, rel=1e-12)


def test_workspace_samples_are_seeded_and_within_limits(scara):
    a, b = sample_configurations(scara, 64, seed=3), sample_configurations(scara, 64, seed=3)
    assert np.array_equal(a, b)
    assert np.all(a >= scara.qlim[0]) and np.all(a <= scara.qlim[1])
    assert not np.array_equal(a, sample_configurations(scara, 64, seed=4))


def test_torque_limit_stated_in_the_robot_file_overrides_the_rule(tmp_path):
    from model.loading import load_description
    from model.robot import Robot

    text = (Path(load_description("scara").path)).read_text()
    marker = "gear_ratio = 107.815\n"
    assert marker in text
    path = tmp_path / "scara_rated.toml"
    path.write_text(text.replace(marker, marker + "torque_limit = 7.5\n"))
    robot = Robot(load_description(path))
    lim = torque_limits(robot, reference_task(robot), sample_configurations(robot, 16, seed=0))
    assert lim.tau_m_max[1] == 7.5
    assert lim.tau_m_max[0] != 7.5


@pytest.mark.parametrize("plant", PLANTS.values(), ids=PLANTS.keys())
def test_python_control_views_of_a_loop(plant):
    """The plant's transfer function is 1/(J s^2 + B s); the closed-loop StateSpace's r -> theta_m
    channel is Kp / (J s^2 + (B + Kd) s + Kp) (a step reference: the derivative acts on the angle).
    Tolerance 1e-9 relative: a 2-state complex solve at frequencies within 3 decades of w_n."""
    loop = design_joint(plant, "pd", bandwidth=40.0, damping=0.7)
    num, den = (np.ravel(a) for a in control.tfdata(plant.transfer_function()))
    np.testing.assert_allclose(den / den[0], [1.0, plant.B_m / plant.J_m, 0.0], rtol=1e-12)
    np.testing.assert_allclose(num / den[0], [1.0 / plant.J_m], rtol=1e-12)
    cl = loop.closed_loop()
    assert cl.input_labels == ["r", "d_m"] and cl.output_labels == ["theta_m", "e", "tau_m"]
    s = 1j * np.array([1.0, 40.0, 300.0])
    Kp, Kd = loop.gains.Kp, loop.gains.Kd
    ours = np.array([cl(x)[0, 0] for x in s])
    np.testing.assert_allclose(ours, Kp / (plant.J_m * s**2 + (plant.B_m + Kd) * s + Kp), rtol=1e-9)
