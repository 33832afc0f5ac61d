"""Physical invariants of the model: B symmetric positive definite, Bdot - 2C skew, energy conserved, payload.

Symbolic checks use CasADi evaluation of the model Functions; the energy and
payload checks use the compiled numeric API.
"""

from __future__ import annotations

import warnings

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model import InertiaConsistencyWarning, load_description, load_robot
from model.dynamics import MOTOR_MODELS, build_functions, parameter_layout
from tests.support.references import available_robots, pinocchio_model, symmetric_from_upper

CASES = [(r, m) for r in available_robots() for m in MOTOR_MODELS]


def _desc(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_description(name)


def _robot(name, motor_model="reflected"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot(name, motor_model=motor_model)


@pytest.mark.parametrize("name,motor_model", CASES)
def test_inertia_symmetric_positive_definite(name, motor_model):
    desc = _desc(name)
    f = build_functions(desc, motor_model)
    p = parameter_layout(desc).defaults
    rng = np.random.default_rng(31)
    for _ in range(20):
        B = np.array(f.inertia(rng.uniform(-np.pi, np.pi, desc.n), p))
        np.testing.assert_allclose(B, B.T, rtol=0, atol=1e-14 * np.abs(B).max())  # rounding of sums in different order
        assert np.linalg.eigvalsh(B).min() > 0


@pytest.mark.parametrize("name,motor_model", CASES)
def test_bdot_minus_2c_is_skew_symmetric(name, motor_model):
    """Bdot from the exact symbolic time derivative dB/dq . qd; tolerance: rounding, 1e-12 of |Bdot| + |C|."""
    desc = _desc(name)
    f = build_functions(desc, motor_model)
    q, qd = ca.SX.sym("q", desc.n), ca.SX.sym("qd", desc.n)
    p = parameter_layout(desc).defaults
    Bdot = ca.Function("Bdot", [q, qd], [ca.jtimes(f.inertia(q, p), q, qd)])
    rng = np.random.default_rng(32)
    for _ in range(10):
        qv, qdv = rng.uniform(-2, 2, (2, desc.n))
        N = np.array(Bdot(qv, qdv)) - 2 * np.array(f.coriolis(qv, qdv, p))
        scale = max(1.0, np.abs(N).max())
        np.testing.assert_allclose(N + N.T, 0.0, atol=1e-12 * scale)
        assert np.abs(N).max() > 0 or desc.n == 1  # the test is not vacuous where C is nonzero


ENERGY_CASES = [("planar2r", "reflected"), ("planar2r", "full"), ("scara", "reflected"), ("scara", "full"),
                ("puma560", "reflected")]


@pytest.mark.parametrize("name,motor_model", ENERGY_CASES)
def test_energy_is_conserved_without_friction_and_torque(name, motor_model):
    """10 s of free motion, DOP853 with rtol 1e-11 / atol 1e-11.

    Tolerance 1e-9 of the energy scale (max kinetic energy + potential swing):
    with local errors ~1e-11 the drift measured over 250-5000 function
    evaluations is <= 1e-10 of that scale, so 1e-9 leaves a 10x margin; scaling
    the Coriolis term by 1.001 already drifts by 5e-9 (scara) to 1e-4 (puma560).
    """
    robot = _robot(name, motor_model)
    n = robot.n
    robot = robot.with_parameters(robot.parameters.with_friction(np.zeros(n), np.zeros(n), np.zeros(n)))
    energy = robot.dynamics.functions.energy
    p = robot.parameters.vector
    rng = np.random.default_rng(33)
    x0 = np.concatenate([robot.q_rest + rng.uniform(-0.5, 0.5, n), rng.uniform(-1.0, 1.0, n)])
    zero = np.zeros(n)

    def rhs(_t, x):
        return np.concatenate([x[n:], robot.accel(x[:n], x[n:], zero)])

    sol = solve_ivp(rhs, (0.0, 10.0), x0, method="DOP853", rtol=1e-11, atol=1e-11, dense_output=False,
                    t_eval=np.linspace(0.0, 10.0, 201))
    assert sol.success
    T, U = [], []
    for x in sol.y.T:
        t_k, u_k = energy(x[:n], x[n:], p)
        T.append(float(t_k))
        U.append(float(u_k))
    E = np.array(T) + np.array(U)
    scale = max(T) + (max(U) - min(U))
    assert scale > 0
    assert np.abs(E - E[0]).max() < 1e-9 * scale


@pytest.mark.parametrize("name", ["scara", "puma560"])
def test_payload_changes_numbers_without_rebuild_and_matches_pinocchio(name):
    import pinocchio as pin  # mandatory reference
    base = _robot(name)
    dyn = base.dynamics
    n = base.n
    robot = base.with_parameters(base.parameters.with_friction(np.zeros(n), np.zeros(n), np.zeros(n)))
    rng = np.random.default_rng(34)
    q, qd, qdd = rng.uniform(-2, 2, (3, n))
    tau_without = robot.rne(q, qd, qdd)
    library = dyn._library
    info = dyn.build_info
    payload = (2.5, np.array([0.02, -0.01, 0.05]), np.array([0.01, 0.012, 0.008, 0.001, -0.002, 0.0005]))
    loaded = robot.with_parameters(robot.parameters.with_payload(*payload))
    tau_with = loaded.rne(q, qd, qdd)
    np.testing.assert_array_equal(robot.rne(q, qd, qdd), tau_without)  # the unloaded robot is unchanged
    assert dyn._library is library and dyn.build_info is info  # no rebuild, same compiled code
    assert np.abs(tau_with - tau_without).max() > 1e-3

    model = pinocchio_model(robot.description, payload=payload)
    data = model.createData()
    scale = max(1.0, np.abs(tau_with).max())
    np.testing.assert_allclose(tau_with, pin.rnea(model, data, q, qd, qdd), rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(loaded.inertia(q), symmetric_from_upper(pin.crba(model, data, q)), rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(loaded.gravload(q), pin.computeGeneralizedGravity(model, data, q), rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(loaded.accel(q, qd, tau_with), qdd, rtol=0, atol=1e-9 * max(1.0, np.abs(qdd).max()))


def test_with_payload_friction_gravity_reject_bad_values():
    p = _robot("planar2r").parameters
    with pytest.raises(ValueError, match=r"^mass: expected a finite number >= 0"):
        p.with_payload(-1.0)
    with pytest.raises(ValueError, match=r"^com: expected 3 values"):
        p.with_payload(1.0, com=(0.0, 0.0))
    with pytest.raises(ValueError, match=r"^inertia: expected a positive semi-definite"):
        p.with_payload(1.0, inertia=(-1.0, 0, 0, 0, 0, 0))
    with pytest.raises(ValueError, match=r"^coulomb_neg: expected values <= 0"):
        p.with_friction(coulomb_neg=[0.1, 0.0])
    with pytest.raises(ValueError, match=r"^viscous: expected 2 values"):
        p.with_friction(viscous=[0.1])
    with pytest.raises(ValueError, match=r"^gravity: expected 3 values"):
        p.with_gravity([0.0, -9.81])
