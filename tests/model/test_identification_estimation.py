"""Identification on simulated data: the torques come from the model's own inverse dynamics (``rne``, Newton-Euler
with the file's parameters), never from the regressor being tested.

* Noise-free, through the whole log pipeline (filter, differentiation, parallel filtering, decimation) from
  positions and torques only: OLS and WLS recover the base parameters to 1e-8 of their norm on puma560, panda and
  ur5 (observed about 2e-12: the filter passes the excitation's band with a gain the parallel filtering cancels).
* White torque noise, seeded, three seeds per robot: the WLS errors divided by their stated standard deviations
  are standard normal if the deviations are right: their RMS over all parameters and seeds lies in [0.75, 1.25]
  and no |z| exceeds 4.5 (for ~190 normal draws P(max > 4.5) is 1e-3).
* The consistent fit: every link's pseudo-inertia has no eigenvalue below -1e-12 of its largest, friction and
  rotor inertias are >= 0, and its relative torque error is within 10 % of the least-squares one.
* A realistic log: the computed-torque loop tracking the excitation (the closed loop, sampled at 1 kHz, with
  encoder noise, torque noise, a torque-sensor bias and logger jitter).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.interpolate

from model.identification import Samples, identify, identify_log, standard_parameters
from model.identification.parameters import PER_JOINT, pseudo_inertia
from model.joint_table import JointTable
from model.robot import Robot
from tests.support.identification import excitation, inverse_dynamics_log, robot, with_friction

ROBOTS = ("puma560", "panda", "ur5")


def _robot(name: str) -> Robot:
    """The robot of the tests: the file's, with friction added where the file states none."""
    r = robot(name)
    return r if any(lk.viscous_friction for lk in r.description.links) else Robot(with_friction(r.description))


@pytest.mark.parametrize("name", ROBOTS)
def test_noise_free_log_recovers_the_base_parameters(name):
    rob = _robot(name)
    _, t, q, qd, qdd = excitation(name, 1, 1000.0)
    tau, _ = inverse_dynamics_log(rob, q, qd, qdd)
    table = JointTable(t=t, groups={"q": q, "tau": tau}, joint_names=rob.description.joint_names)
    result = identify_log(rob, table)
    assert result.preprocessing.differentiated == "qd, qdd"
    beta = result.base.beta(standard_parameters(rob.description))
    for method in ("ols", "wls"):
        err = result.fits[method].beta - beta
        assert np.linalg.norm(err) <= 1e-8 * np.linalg.norm(beta), method
        assert np.abs(err).max() <= 1e-8 * np.linalg.norm(beta), method
        assert result.errors[method].relative_error < 1e-8


@pytest.mark.parametrize("name", ROBOTS)
def test_noise_lies_within_the_stated_standard_deviations(name):
    rob = _robot(name)
    _, t, q, qd, qdd = excitation(name)
    beta_true = None
    z_all = []
    for seed in (1, 2, 3):
        tau, sigma = inverse_dynamics_log(rob, q, qd, qdd, noise=0.01, seed=seed)
        result = identify(rob, Samples(t, q, qd, qdd, tau), consistent=seed == 1)
        if beta_true is None:
            beta_true = result.base.beta(standard_parameters(rob.description))
        wls = result.fits["wls"]
        assert not result.fixed
        z_all.append((wls.beta - beta_true) / wls.std)
        # the per-joint noise deviations are estimated, to 15 % (about 1400 equations per joint)
        np.testing.assert_allclose(result.sigma, sigma, rtol=0.15)
        if seed == 1:
            _check_consistent(result, rob)
    z = np.concatenate(z_all)
    assert 0.75 <= np.sqrt(np.mean(z ** 2)) <= 1.25
    assert np.abs(z).max() < 4.5


def _check_consistent(result, rob):
    cons = result.fits["consistent"]
    pi = cons.pi
    for i in range(rob.n):
        lam = np.linalg.eigvalsh(pseudo_inertia(pi[PER_JOINT * i:PER_JOINT * i + 10]))
        assert lam.min() >= -1e-12 * lam.max(), f"link {i + 1}: {lam}"
    for k in (10, 11, 12):  # Ia, fv, fc
        assert np.all(pi[k::PER_JOINT] >= 0)
    assert result.errors["consistent"].relative_error <= 1.1 * result.errors["wls"].relative_error
    assert result.errors["consistent"].relative_error_holdout <= 1.1 * result.errors["wls"].relative_error_holdout


def test_the_published_puma_is_not_consistent_but_its_fit_is():
    """Negative control of the feasibility check: the file's own Puma parameters fail it (links 1 and 3)."""
    pi = standard_parameters(robot("puma560").description)
    bad = [i for i in range(6) if np.linalg.eigvalsh(pseudo_inertia(pi[PER_JOINT * i:PER_JOINT * i + 10])).min() < 0]
    assert bad == [0, 2]


def test_a_torque_sensor_bias_goes_into_the_offset():
    rob = _robot("ur5")
    _, t, q, qd, qdd = excitation("ur5")
    tau, _ = inverse_dynamics_log(rob, q, qd, qdd)
    bias = np.array([0.0, 1.5, 0.0, -0.4, 0.0, 0.0])
    result = identify(rob, Samples(t, q, qd, qdd, tau + bias))
    names = result.base.base_names
    expected = result.base.beta(standard_parameters(rob.description))
    for j in (1, 3):
        k = names.index(f"off_{j + 1}")
        assert result.fits["wls"].beta[k] == pytest.approx(expected[k] + bias[j], abs=1e-9)
    assert result.errors["wls"].relative_error < 1e-10


def test_a_joint_that_does_not_move_keeps_the_file_values_of_what_only_it_shows():
    rob = _robot("puma560")
    ex, *_ = excitation("puma560")
    traj = ex.trajectory
    a, b = traj.a.copy(), traj.b.copy()
    a[5], b[5] = 0.0, 0.0  # joint 6 stays at its start
    still = dataclasses.replace(traj, a=a, b=b)
    t, q, qd, qdd = still.sample(200.0, 2)
    tau, _ = inverse_dynamics_log(rob, q, qd, qdd, noise=0.001, seed=4)
    result = identify(rob, Samples(t, q, qd, qdd, tau))
    fixed = {result.base.base_names[k] for k in result.fixed}
    assert {"fv_6", "fc_6", "off_6", "Ia_6"} <= fixed
    assert result.equations["fit"][5] == 0  # every joint-6 equation is at rest
    # what is fixed keeps the file's value; the rest is still fitted to the noise level
    beta_true = result.base.beta(standard_parameters(rob.description))
    for k in result.fixed:
        assert result.fits["wls"].beta[k] == beta_true[k]
    assert result.errors["wls"].relative_error < 0.01


def test_closed_loop_log_with_noise_bias_and_jitter():
    """The computed-torque loop (control_design, closed_loop) tracks two periods of the Puma's excitation at
    1 kHz; the log has the plant's positions at jittered instants (+-0.2 ms, interpolated from the 1 kHz
    simulation) with 1e-5 rad encoder noise, and the joint torques G tau_m (the zero-order-hold command,
    averaged over the two steps meeting at each instant, as a sensor behind the motor's current loop sees
    it) with 1 % white noise and a 0.3 N m bias on joint 2.

    Observed: cut-off about 24 Hz, 1.2 % relative error on the held-out data. The simulation integrates the
    sign(qd) friction across velocity reversals without locating them, so the log itself departs from the
    model there (its noise-free residual is 7e-4): the test asks for less than 2.5 % on the held-out data,
    the offset of joint 2 within 0.05 N m of the bias plus the Coulomb asymmetry, and the identified robot's
    inverse dynamics within 1 % of the true one along a motion it was not fitted on (the third period;
    observed 0.4 %).
    """
    from closed_loop import simulate_tracking
    from control_design import design_robot

    rob = robot("puma560")
    ex, *_ = excitation("puma560")
    design = design_robot(rob, "ct", 50.0, 0.7, rate_hz=1000.0, analyse=False)
    sim = simulate_tracking(rob, design.controller(1000.0, saturate=False), ex.trajectory.trajectory(1000.0, 2))
    rng = np.random.default_rng(5)
    N = sim.t.size
    t = np.sort(sim.t + rng.uniform(-2e-4, 2e-4, N))
    t[0] = sim.t[0]
    q = scipy.interpolate.CubicSpline(sim.t, sim.q, axis=0)(t) + 1e-5 * rng.standard_normal(sim.q.shape)
    tau_zoh = sim.tau_m * sim.G
    tau_zoh = np.vstack([tau_zoh[:1], 0.5 * (tau_zoh[1:] + tau_zoh[:-1])])
    tau = tau_zoh[np.clip(np.searchsorted(sim.t, t, side="right") - 1, 0, N - 1)]
    tau = tau + 0.01 * np.abs(tau).max(axis=0) * rng.standard_normal(tau.shape)
    tau[:, 1] += 0.3
    table = JointTable(t=t, groups={"q": q, "tau": tau}, joint_names=rob.description.joint_names)
    result = identify_log(rob, table)
    assert result.preprocessing.resampled
    assert 5.0 < result.preprocessing.cutoff_hz < 100.0
    assert result.errors["consistent"].relative_error_holdout < 0.025
    G = abs(rob.description.links[1].gear_ratio)
    tc = rob.description.links[1].coulomb_friction
    k = result.base.base_names.index("off_2")
    assert result.fits["consistent"].beta[k] == pytest.approx(0.3 + G * (tc[0] + tc[1]) / 2, abs=0.05)
    # the identified arm along the third period, against the true one. The robot file holds the symmetric
    # Coulomb friction; the true arm's asymmetry and the sensor's bias are in the fitted offsets.
    from model.identification import identified_description

    identified = Robot(identified_description(rob.description, result.pi))
    t3, q3, qd3, qdd3 = ex.trajectory.sample(100.0, 3)
    third = t3 >= 2 * ex.trajectory.period
    true = rob.rne_batch(q3[third], qd3[third], qdd3[third])
    offsets = result.pi[PER_JOINT - 1::PER_JOINT] - np.array([0.0, 0.3, 0.0, 0.0, 0.0, 0.0])
    predicted = identified.rne_batch(q3[third], qd3[third], qdd3[third]) + offsets
    validation = np.linalg.norm(predicted - true) / np.linalg.norm(true)
    assert validation < 0.01
    # negative control: the offsets matter (without them the torques of the fitted arm miss by more)
    assert np.linalg.norm(predicted - offsets - true) / np.linalg.norm(true) > validation
