"""The linearisation against central finite differences of the forward dynamics.

Central differences with step h have truncation error ~h^2 |f'''| / 6 and
rounding error ~eps |f| / h; with h = 1e-5 (scaled) both are ~1e-10 of the
values here, so 1e-6 relative to the largest Jacobian entry is a safe bound
that a wrong derivative (off by a term, not by rounding) cannot meet.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from model import InertiaConsistencyWarning, load_robot
from model.linearise import linearise


def _robot(name, motor_model="reflected"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot(name, motor_model=motor_model)


def finite_difference_AB(robot, q0, qd0, u0, h=1e-5):
    n = robot.n
    G = robot.gear_ratio

    def f(x, u):
        return np.concatenate([x[n:], robot.accel(x[:n], x[n:], G * u)])

    x0 = np.concatenate([q0, qd0])
    A = np.zeros((2 * n, 2 * n))
    B = np.zeros((2 * n, n))
    for j in range(2 * n):
        dx = np.zeros(2 * n)
        dx[j] = h * max(1.0, abs(x0[j]))
        A[:, j] = (f(x0 + dx, u0) - f(x0 - dx, u0)) / (2 * dx[j])
    for j in range(n):
        du = np.zeros(n)
        du[j] = h * max(1.0, abs(u0[j]))
        B[:, j] = (f(x0, u0 + du) - f(x0, u0 - du)) / (2 * du[j])
    return A, B


@pytest.mark.parametrize("name,motor_model", [("planar2r", "full"), ("scara", "reflected"), ("puma560", "reflected")])
def test_linearisation_matches_central_differences(name, motor_model):
    robot = _robot(name, motor_model)
    rng = np.random.default_rng(51)
    n = robot.n
    q0 = robot.q_rest + rng.uniform(-0.5, 0.5, n)
    qd0 = rng.uniform(0.2, 1.0, n) * rng.choice([-1, 1], n)  # away from 0: Coulomb friction is locally constant
    u0 = rng.uniform(-0.5, 0.5, n)
    sys = linearise(robot, q0, qd0, u0, outputs=["q", "qm"])
    A_fd, B_fd = finite_difference_AB(robot, q0, qd0, u0)
    np.testing.assert_allclose(sys.A, A_fd, rtol=0, atol=1e-6 * np.abs(A_fd).max())
    np.testing.assert_allclose(sys.B, B_fd, rtol=0, atol=1e-6 * np.abs(B_fd).max())
    np.testing.assert_array_equal(sys.C, np.vstack([np.hstack([np.eye(n), np.zeros((n, n))]),
                                                    np.hstack([np.diag(robot.gear_ratio), np.zeros((n, n))])]))
    assert np.all(sys.D == 0)
    assert sys.state_labels == [f"q[{i}]" for i in range(1, n + 1)] + [f"qd[{i}]" for i in range(1, n + 1)]
    assert sys.input_labels == [f"u[{i}]" for i in range(1, n + 1)]
    assert sys.output_labels[n] == "qm[1]"


def test_default_input_holds_the_arm_and_viscous_friction_damps():
    robot = _robot("planar2r")
    q0 = robot.q_rest + np.array([0.3, 0.2])
    sys = linearise(robot, q0, outputs="qd")
    u0 = robot.rne(q0, np.zeros(2), np.zeros(2)) / robot.gear_ratio
    np.testing.assert_allclose(robot.accel(q0, np.zeros(2), robot.gear_ratio * u0), 0.0, atol=1e-12)
    G = robot.gear_ratio
    Fv = np.diag(np.array([lk.viscous_friction for lk in robot.description.links]) * G**2)
    np.testing.assert_allclose(sys.A[2:, 2:], -np.linalg.solve(robot.inertia(q0), Fv), rtol=1e-10)


def test_output_matrix_and_bad_outputs():
    robot = _robot("planar2r")
    C = np.array([[1.0, -1.0, 0.0, 0.0]])
    sys = linearise(robot, robot.q_rest, outputs=C)
    np.testing.assert_array_equal(sys.C, C)
    assert sys.output_labels == ["y[1]"]
    with pytest.raises(ValueError, match=r"^outputs: expected kinds from"):
        linearise(robot, robot.q_rest, outputs="tau")
    with pytest.raises(ValueError, match=r"^outputs: expected a \(ny, 4\) output matrix"):
        linearise(robot, robot.q_rest, outputs=np.ones((2, 3)))
    with pytest.raises(ValueError, match=r"^q0: expected 2 joint values"):
        linearise(robot, np.zeros(3))


def test_the_plant_jacobians_are_built_once_per_robot_and_follow_the_parameters():
    """Robot.linearise equals the free function; the second call reuses the Jacobians and still reads p.

    Equality is exact: the same cached Function evaluated at the same point.
    """
    from model.linearise import _linearisation

    robot = _robot("scara")
    q0 = robot.q_rest + 0.2
    first = linearise(robot, q0, outputs=["q", "qd"])
    built = _linearisation(robot)
    again = robot.linearise(q0, outputs=["q", "qd"])
    assert _linearisation(robot) is built
    np.testing.assert_array_equal(again.A, first.A)
    np.testing.assert_array_equal(again.B, first.B)
    np.testing.assert_array_equal(again.C, first.C)
    assert again.state_labels == first.state_labels and again.output_labels == first.output_labels
    loaded = robot.with_parameters(robot.parameters.with_payload(3.0, (0.0, 0.0, 0.05)))
    heavy = loaded.linearise(q0)
    assert _linearisation(loaded) is built  # the same model: the Jacobians are shared, p is an input
    fresh = _robot("scara")
    fresh = fresh.with_parameters(fresh.parameters.with_payload(3.0, (0.0, 0.0, 0.05)))
    reference = linearise(fresh, q0)
    assert _linearisation(fresh) is not built
    assert np.abs(heavy.B - first.B).max() > 1e-3 * np.abs(first.B).max()  # the payload changed B
    np.testing.assert_array_equal(heavy.A, reference.A)
    np.testing.assert_array_equal(heavy.B, reference.B)


def test_linearisation_is_the_plants_in_the_modes_it_states():
    """At rest the default is the sliding modes (+1): the joint that moves, what the designs use (A and B those of
    the sliding law, robot.accel: the central differences above); a 0 in ``modes`` is the stuck joint, whose rows
    of A and B vanish (it does not move under small inputs) while the other joints keep theirs."""
    from model import InputError

    robot = _robot("puma560")
    n = robot.n
    q0 = robot.q_rest + 0.1
    sliding = linearise(robot, q0)
    A_fd, B_fd = finite_difference_AB(robot, q0, np.zeros(n), robot.rne(q0, np.zeros(n), np.zeros(n)) / robot.gear_ratio)
    np.testing.assert_allclose(sliding.B, B_fd, rtol=0, atol=1e-6 * np.abs(B_fd).max())
    modes = np.ones(n)
    modes[1] = 0.0
    stuck = linearise(robot, q0, modes=modes)
    assert np.all(stuck.A[[1, n + 1], :] == 0) and np.all(stuck.B[[1, n + 1], :] == 0)
    assert np.abs(stuck.B[n]).max() > 1e-3 and not np.allclose(stuck.B[n], sliding.B[n])  # joint 1 sees 2 held
    with pytest.raises(InputError, match="modes: expected -1, 0 or \\+1 per joint, 0 only where qd0 = 0"):
        linearise(robot, q0, qd0=np.full(n, 0.1), modes=modes)
