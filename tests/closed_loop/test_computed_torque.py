"""Computed torque: outer-loop design, exact linearisation of the SCARA, model mismatch, the controller interface."""

from __future__ import annotations

import math

import numpy as np
import pytest

from control_design.computed_torque import ModelMismatch, design_outer_loops, plant_with_mismatch
from control_design.controllers import ComputedTorqueController, DecentralisedController
from control_design.errors import DesignSpecError
from control_design.loops import gains_arrays
from control_design.reference import Reference
from control_design.responses import closed_loop_bandwidth, margins, step_response
from closed_loop import simulate_tracking
from model.robot import load_robot
from model.trajectory import jtraj

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")


@pytest.fixture(scope="module")
def scara():
    return load_robot("scara")


def test_outer_loops_are_double_integrators_with_wn_squared_and_two_zeta_wn(scara):
    loops = design_outer_loops(scara, bandwidth=40.0, damping=1 / math.sqrt(2), rate_hz=1000.0)
    assert [lp.plant.unit for lp in loops] == ["rad", "rad", "m", "rad"]
    for lp in loops:
        assert (lp.plant.J_m, lp.plant.B_m, lp.plant.G) == (1.0, 0.0, 1.0)
        # zeta = 1/sqrt(2): bandwidth = wn exactly, Kp = wn^2, Kd = sqrt(2) wn.
        assert lp.gains.Kp == pytest.approx(1600.0, rel=1e-12)
        assert lp.gains.Kd == pytest.approx(math.sqrt(2) * 40.0, rel=1e-12)
        assert closed_loop_bandwidth(lp) == pytest.approx(40.0, rel=1e-8)
    m = margins(loops[0])
    # L = (Kd s + Kp) / s^2: |L| = 1 at w^4 = Kp^2 + Kd^2 w^2, PM = atan(w Kd / Kp).
    w = math.sqrt((2 * 1600 + math.sqrt(4 * 1600 ** 2 + 4 * 1600 ** 2)) / 2)
    assert m.w_gc == pytest.approx(w, rel=1e-9)
    assert m.pm == pytest.approx(math.degrees(math.atan(w * math.sqrt(2) * 40 / 1600)), abs=1e-7)
    st = step_response(loops[0])
    assert st.overshoot == pytest.approx(100 * math.exp(-math.pi), abs=1e-3)  # zeta = 1/sqrt 2: e^-pi


def test_exact_model_turns_the_arm_into_double_integrators(scara):
    rng = np.random.default_rng(7)
    loops = design_outer_loops(scara, bandwidth=30.0, damping=0.9)
    Kp, Kd, _ = gains_arrays(loops)
    ctrl = ComputedTorqueController(scara, Kp, Kd, rate_hz=1000.0)
    for _ in range(5):
        q = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(0, 3.5), rng.uniform(-3, 3)])
        qd, ref_q, ref_qd, ref_qdd = (rng.normal(size=4) for _ in range(4))
        tau_m = ctrl.update(0.0, q, qd, Reference(ref_q, ref_qd, ref_qdd))
        qdd = scara.accel(q, qd, scara.gear_ratio * tau_m)
        v = ref_qdd + Kd * (ref_qd - qd) + Kp * (ref_q - q)
        # rne then accel: B^-1 (B v + n - n) = v up to the conditioning of B (cond ~ 1e4 here).
        assert np.allclose(qdd, v, rtol=1e-9, atol=1e-9 * np.max(np.abs(v)))


def test_sampled_ct_loop_follows_its_linear_design(scara):
    """Hold still with an initial error: the nonlinear arm's error must follow the sampled design loop.

    The reference is constant, so the discrete closed loop ``e_k = e0 (1 - y_k)`` with ``y`` its unit
    step response is exact for the linear double integrator; the arm differs from it only through B(q)
    changing within a 1 ms hold, second order in the small error (tolerance 1e-4 of e0).
    """
    rate = 1000.0
    loops = design_outer_loops(scara, bandwidth=20.0, damping=1.0, rate_hz=rate)
    Kp, Kd, _ = gains_arrays(loops)
    q_hold = np.array([0.4, 1.0, 1.5, 0.2])
    traj = jtraj(q_hold, q_hold, T=0.5, dt=0.01)
    e0 = np.array([1e-3, -2e-3, 1e-3, 5e-4])
    res = simulate_tracking(scara, ComputedTorqueController(scara, Kp, Kd, rate), traj, q0=q_hold - e0)
    st = step_response(loops[0], discrete=True)
    k = min(res.t.size, st.t.size)
    predicted = np.outer(1.0 - st.theta_m[:k], e0)
    assert np.max(np.abs(res.error[:k] - predicted)) < 1e-4 * np.max(np.abs(e0))


def test_payload_mismatch_builds_a_separate_plant(scara):
    plant = plant_with_mismatch(scara, ModelMismatch(payload_mass=2.0))
    assert plant is not scara
    q = np.array([0.0, 0.0, 1.0, 0.0])
    # The quill carries the payload: 2 kg more weight on joint 3, nothing else changes; the model keeps none.
    assert plant.gravload(q)[2] - scara.gravload(q)[2] == pytest.approx(-2.0 * 9.81, rel=1e-12)
    assert scara.parameters.payload_mass == 0.0 and plant.parameters.payload_mass == 2.0
    assert plant.inertia(q)[2, 2] - scara.inertia(q)[2, 2] == pytest.approx(2.0, rel=1e-12)


def test_friction_and_mass_scaling_mismatch(scara):
    plant = plant_with_mismatch(scara, ModelMismatch(friction_scale=3.0, link_mass_scale=1.2))
    qd = np.array([0.5, -0.3, 0.2, 1.0])
    assert np.allclose(plant.friction(qd), 3.0 * scara.friction(qd), rtol=1e-12)
    q = np.array([0.2, 0.7, 1.0, 0.1])
    rotors = np.diag(scara.gear_ratio ** 2 * [lk.motor_inertia for lk in scara.description.links])
    # Links only scale; the reflected rotor inertia G^2 Jm stays.
    assert np.allclose(plant.inertia(q) - rotors, 1.2 * (scara.inertia(q) - rotors), rtol=1e-10, atol=1e-12)
    assert ModelMismatch(payload_mass=2.0, friction_scale=3.0).describe() == \
        "2 kg payload unknown to the controller, plant friction x3"
    with pytest.raises(DesignSpecError, match="payload: expected a finite value >= 0 kg, got -1"):
        ModelMismatch(payload_mass=-1.0)


def test_controllers_saturate_and_pid_does_not_wind_up(scara):
    G = scara.gear_ratio
    ref = Reference(np.ones(4), np.zeros(4), np.zeros(4))
    ctrl = DecentralisedController("pid", Kp=[10.0] * 4, Kd=[1.0] * 4, Ki=[100.0] * 4, gear_ratio=G,
                                   rate_hz=1000.0, tau_m_max=[0.5] * 4)
    q = np.zeros(4)
    for k in range(100):
        tau = ctrl.update(k * 1e-3, q, np.zeros(4), ref)
        assert np.all(np.abs(tau) <= 0.5)
    assert np.all(ctrl._z == 0.0)  # saturated in the direction of the error the whole time: no integration
    ct = ComputedTorqueController(scara, [1e4] * 4, [100.0] * 4, 1000.0, tau_m_max=[1.0, 1.0, 1.0, 0.1])
    tau = ct.update(0.0, q + np.array([0, 0, 1, 0]), np.zeros(4), ref)
    assert np.allclose(np.abs(tau), [1.0, 1.0, 1.0, 0.1])
    with pytest.raises(DesignSpecError, match="rate: expected a positive number of Hz, got 0"):
        ComputedTorqueController(scara, [1.0] * 4, [1.0] * 4, 0)
