"""Each control law is written once (control_design.laws) and every user runs that one definition.

Three comparisons on seeded random states and references, errors drawn
log-uniformly between 1e-6 and 1e-1 so that the torques fall on both sides of
the limits, several steps in a row (the PID integrator carries over):

* the Python controller (the law compiled through model.codegen) against the
  output Function of the controller FMU's spec (the Function generated into the
  FMU's C), evaluated by CasADi: 1e-12 relative to ``1 + |tau_m|``, the round-off
  of the same operations compiled with other flags (seen: 0);
* the Python controller against the law re-stated here in NumPy from its
  formula (the written specification, an independent statement): 1e-12 relative
  (the same operations in the same order; 'ct' goes through the compiled
  ``rne`` instead of the law's inlined copy);
* for PID, which has a state and no FMU yet: the compiled controller against
  the law's Function evaluated step by step by CasADi's virtual machine.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from closed_loop import controller_spec
from control_design import LAW_KINDS, design_robot
from control_design.reference import Reference
from model import InertiaConsistencyWarning, load_robot

RATE = 1000.0
STEPS = 40


@pytest.fixture(scope="module")
def robot():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot("scara")


def _samples(n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(STEPS):
        qr, qdr, qddr = rng.uniform(-2, 2, n), rng.uniform(-2, 2, n), rng.uniform(-20, 20, n)
        scale = 10.0 ** rng.uniform(-6.0, -1.0)
        q, qd = qr + scale * rng.uniform(-1, 1, n), qdr + 10.0 * scale * rng.uniform(-1, 1, n)
        yield q, qd, Reference(qr, qdr, qddr)


def _numpy_law(controller, q, qd, ref, z):
    """The laws as the module docstring of control_design.laws states them, with the saturation and anti-windup."""
    kind, G = controller.kind, controller.G
    limit = controller.tau_m_max
    if kind == "ct":
        v = ref.qdd + controller.Kd * (ref.qd - qd) + controller.Kp * (ref.q - q)
        return np.clip(controller.model.rne(q, qd, v) / G, -limit, limit), z
    e_m, ed_m = G * (ref.q - q), G * (ref.qd - qd)
    tau = controller.Kp * e_m + controller.Kd * ed_m
    if kind == "pd-ff":
        tau = tau + controller.J_ff_m * G * ref.qdd + controller.B_ff_m * G * ref.qd
    elif kind == "pd-g":
        tau = tau + controller.gravity_model.gravload(q) / G
    elif kind == "pid":
        tau = tau + controller.Ki * z
    out = np.clip(tau, -limit, limit)
    if kind == "pid":
        winding = (out != tau) & (np.sign(e_m) == np.sign(tau))
        z = z + np.where(winding, 0.0, controller.dt * e_m)
    return out, z


@pytest.mark.parametrize("kind", LAW_KINDS)
def test_the_python_controller_is_the_stated_law(kind, robot):
    controller = design_robot(robot, kind, analyse=False).controller(RATE)
    controller.reset()
    z = np.zeros(robot.n)
    saturated = worst = 0.0
    for k, (q, qd, ref) in enumerate(_samples(robot.n, 11)):
        tau = controller.update(k * controller.dt, q, qd, ref)
        expected, z = _numpy_law(controller, q, qd, ref, z)
        worst = max(worst, float(np.max(np.abs(tau - expected) / (1.0 + np.abs(expected)))))
        saturated += float(np.mean(np.abs(expected) >= controller.tau_m_max))
    assert worst <= 1e-12
    assert 0.05 < saturated / STEPS < 0.95  # both sides of the limits exercised
    if kind == "pid":
        assert np.any(controller._z != 0.0) and np.array_equal(controller._z, z)


@pytest.mark.parametrize("kind", ["pd", "pd-g", "pd-ff", "ct"])
def test_the_controller_fmu_runs_the_python_controllers_function(kind, robot):
    controller = design_robot(robot, kind, analyse=False).controller(RATE)
    spec = controller_spec(controller, robot)
    names = [v.name for v in spec.inputs]
    for k, (q, qd, ref) in enumerate(_samples(robot.n, 12)):
        signals = {"q_ref": ref.q, "qd_ref": ref.qd, "qdd_ref": ref.qdd, "q": q, "qd": qd}
        u = np.array([signals[name.split("[")[0]][int(name.split("[")[1][:-1]) - 1] for name in names])
        fmu_tau = np.array(spec.out(np.zeros(0), u, spec.p_start)).ravel()
        tau = controller.update(k * controller.dt, q, qd, ref)
        np.testing.assert_allclose(fmu_tau, tau, rtol=0, atol=1e-12 * (1.0 + np.max(np.abs(tau))))


def test_pid_steps_are_the_laws_function_step_by_step(robot):
    controller = design_robot(robot, "pid", analyse=False).controller(RATE)
    f = controller.function  # the law and the saturation, as the controller compiled them
    values = controller.parameter_values()
    controller.reset()
    z = np.zeros(robot.n)
    for k, (q, qd, ref) in enumerate(_samples(robot.n, 13)):
        signals = {"q": q, "qd": qd, "q_d": ref.q, "qd_d": ref.qd, "z": z}
        args = [signals[f.name_in(i)] if f.name_in(i) in signals else values[f.name_in(i)] for i in range(f.n_in())]
        tau_ref, z_next = (np.array(v).ravel() for v in f(*args))
        tau = controller.update(k * controller.dt, q, qd, ref)
        np.testing.assert_allclose(tau, tau_ref, rtol=0, atol=1e-12 * (1.0 + np.max(np.abs(tau_ref))))
        z = z_next
    np.testing.assert_allclose(controller._z, z, rtol=0, atol=1e-15)
    assert np.any(z != 0.0)


def test_a_controller_without_limits_clips_nothing(robot):
    controller = design_robot(robot, "pd", analyse=False).controller(RATE, saturate=False)
    q, qd, ref = next(_samples(robot.n, 14))
    ref = Reference(ref.q + 1.0, ref.qd, ref.qdd)  # a huge error: any limit would clip it
    G = controller.G
    expected = controller.Kp * (G * (ref.q - q)) + controller.Kd * (G * (ref.qd - qd))
    np.testing.assert_array_equal(controller.update(0.0, q, qd, ref), expected)
