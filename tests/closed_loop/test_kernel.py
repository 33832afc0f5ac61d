"""The compiled closed loop (closed_loop/kernel.py) against the Python loop (closed_loop/simulate.py).

Both run the same generated law and the one plant (model/plant.py) with the same fixed-step rule
(model/dynamics/c/plant_step.c), sub-steps and reference samples, so the samples agree to rounding:
~1e-17 rad observed on the SCARA (the kernel's plant is built with a link-mass scale parameter, whose
expression graph orders a few operations differently; a scale of s multiplies at run time what the
scaled description folds into constants). 1e-12
leaves four orders of magnitude for the 3 s runs here and still catches a different arithmetic: the
negative control (link masses 1e-8 heavier, relative) misses by ~6e-11 rad. Every controller kind, a one-period delay,
a plant mismatch (payload, friction, link masses) and a saturating PID (its anti-windup) are covered.
Cost: one kernel build per kind (~1 s each at -O1/-O2) and ~0.05 s of Python loop per case.
"""

from __future__ import annotations

import numpy as np
import pytest

from closed_loop.delay import OnePeriodDelay
from closed_loop.kernel import closed_loop_kernel
from closed_loop.schedule import Schedule
from closed_loop.simulate import simulate_tracking
from control_design.computed_torque import ModelMismatch, plant_with_mismatch
from control_design.controllers import DecentralisedController
from control_design.design import design_robot
from control_design.laws import LAW_KINDS
from control_design.reference import task_trajectory
from model.robot import load_robot

T_FINAL = 3.0  # s of the 15 s pick-and-place: the first move and a pause
TOL = 1e-12  # rad, rad/s, N m: see the module docstring


@pytest.fixture(scope="module")
def scara():
    return load_robot("scara")


@pytest.fixture(scope="module")
def task(scara):
    return task_trajectory(scara, "pick-and-place")


def _compare(kernel_run, ref, tol=TOL):
    r = kernel_run.result
    assert r is not None and not kernel_run.diverged
    np.testing.assert_array_equal(r.t, ref.t)
    for a, b in ((r.q, ref.q), (r.qd, ref.qd), (r.tau_m, ref.tau_m)):
        np.testing.assert_allclose(a, b, rtol=0, atol=tol)
    met = ref.metrics()
    np.testing.assert_allclose(kernel_run.max_error, met.max_error, rtol=0, atol=tol)
    np.testing.assert_allclose(kernel_run.rms_error, met.rms_error, rtol=0, atol=tol)
    np.testing.assert_allclose(kernel_run.peak_motor_torque, met.peak_motor_torque, rtol=0, atol=tol)
    np.testing.assert_allclose(kernel_run.peak_motor_velocity, met.peak_motor_velocity, rtol=0, atol=tol)
    np.testing.assert_array_equal(kernel_run.saturated_fraction, met.saturated_fraction)
    # the metrics of the recorded samples are the ones the kernel accumulated
    np.testing.assert_allclose(r.metrics().rms_error, kernel_run.rms_error, rtol=1e-13, atol=0)


def _run_both(plant, robot, controller, task, *, scale=1.0, delay=False, substeps=None):
    ref = simulate_tracking(plant, OnePeriodDelay(controller) if delay else controller, task, t_final=T_FINAL,
                            substeps=substeps)
    sched = Schedule.build(plant, task, controller.dt, rate_hz=controller.rate_hz, t_final=T_FINAL,
                           substeps=ref.substeps)
    kernel = closed_loop_kernel(robot, controller.kind)
    run = kernel.run(controller, sched, plant.parameters, link_mass_scale=scale, delay=delay, record=True)
    return run, ref


@pytest.mark.parametrize("kind", LAW_KINDS)
def test_kernel_equals_the_python_loop_for_every_controller(scara, task, kind):
    controller = design_robot(scara, kind, rate_hz=1000.0, analyse=False).controller(1000.0)
    run, ref = _run_both(scara, scara, controller, task)
    _compare(run, ref)


@pytest.mark.parametrize("kind", ["pd-g", "ct"])
def test_kernel_with_a_one_period_delay_equals_the_delayed_python_loop(scara, task, kind):
    controller = design_robot(scara, kind, rate_hz=500.0, analyse=False).controller(500.0)
    run, ref = _run_both(scara, scara, controller, task, delay=True)
    assert ref.substeps == 2  # 500 Hz: two RK4 sub-steps of 1 ms per period
    _compare(run, ref)
    undelayed = closed_loop_kernel(scara, kind).run(controller, Schedule.build(
        scara, task, controller.dt, t_final=T_FINAL, substeps=ref.substeps), scara.parameters)
    assert np.max(np.abs(undelayed.max_error - run.max_error)) > 1e-6  # the delay changed the run


def test_kernel_plant_mismatch_equals_the_python_loop_on_the_mismatched_plant(scara, task):
    """Payload, friction and link-mass scale are kernel inputs; the Python loop runs a rebuilt scaled robot."""
    mismatch = ModelMismatch(payload_mass=2.0, payload_com=(0.01, 0.0, 0.02), friction_scale=1.7, link_mass_scale=1.3)
    plant = plant_with_mismatch(scara, mismatch)
    controller = design_robot(scara, "ct", rate_hz=1000.0, analyse=False).controller(1000.0)
    run, ref = _run_both(plant, scara, controller, task, scale=1.3)
    _compare(run, ref)
    # negative control: a plant 1e-8 heavier (relative) misses by ~6e-11 rad: told apart at this tolerance
    sched = Schedule.build(plant, task, controller.dt, t_final=T_FINAL, substeps=ref.substeps)
    off = closed_loop_kernel(scara, "ct").run(controller, sched, plant.parameters, link_mass_scale=1.3 * (1 + 1e-8),
                                              record=True)
    assert np.max(np.abs(off.result.q - ref.q)) > 10 * TOL


def test_kernel_saturating_pid_with_anti_windup_equals_the_python_loop(scara, task):
    base = design_robot(scara, "pid", rate_hz=1000.0, analyse=False).controller(1000.0)
    controller = DecentralisedController("pid", base.Kp, base.Kd, base.Ki, base.G, 1000.0,
                                         tau_m_max=0.3 * base.tau_m_max)
    run, ref = _run_both(scara, scara, controller, task)
    assert np.max(run.saturated_fraction) > 0.01  # the limit is reached: the clipping and anti-windup are exercised
    _compare(run, ref)


def test_kernel_reports_divergence_where_the_python_loop_raises(scara, task):
    from control_design.errors import SimulationDivergedError

    base = design_robot(scara, "pd", rate_hz=1000.0, analyse=False).controller(1000.0)
    wild = DecentralisedController("pd", -50 * base.Kp, base.Kd, 0.0, base.G, 1000.0)  # positive feedback
    # the Python loop stops at its end-of-period check or, when the state turns non-finite inside a period,
    # at the dynamics' input check (a ValueError)
    with pytest.raises((SimulationDivergedError, ValueError)):
        simulate_tracking(scara, wild, task, t_final=T_FINAL)
    sched = Schedule.build(scara, task, wild.dt, t_final=T_FINAL)
    run = closed_loop_kernel(scara, "pd").run(wild, sched, scara.parameters)
    assert run.diverged and run.t_end < T_FINAL


def test_kernel_refuses_a_controller_of_another_kind(scara, task):
    from control_design.errors import DesignSpecError

    controller = design_robot(scara, "pd", rate_hz=1000.0, analyse=False).controller(1000.0)
    sched = Schedule.build(scara, task, controller.dt, t_final=T_FINAL)
    with pytest.raises(DesignSpecError, match="expected a 'ct' controller"):
        closed_loop_kernel(scara, "ct").run(controller, sched, scara.parameters)
