"""The single-call fast path (model/point_call.py, model/c/point_call.c): same numbers, same errors.

References: the checked path it bypasses (``Dynamics.rne`` ... and ``CompiledKinematics.fkine`` ...,
which evaluate the same generated functions through ``PointEvaluator``), compared bit for bit (both
call the same machine code on the same doubles, so any difference is a bug of the fast path), and
Pinocchio (tolerance 1e-10 relative to max(1, |reference|), as tests/model/test_dynamics_pinocchio.py
states: double precision through O(100) operations differs by ~1e-14; any wrong term is >= 1e-3).
"""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin  # a mandatory reference: a missing Pinocchio fails, never skips
import pytest

from model import InertiaConsistencyWarning, load_robot
from model.errors import InputError
from model.point_call import extension
from model.robot import _FAST_CALLS, _no_call
from tests.support.references import friction_reference, pinocchio_model, symmetric_from_upper

ROBOTS = ("puma560", "ur5", "panda", "scara")
ARGS = {"fkine": 1, "jacob0": 1, "inertia": 1, "coriolis": 2, "gravload": 1, "rne": 3, "accel": 3}


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return load_robot(request.param)


def checked(robot, name):
    """The checked path of ``name`` (the one the fast path falls back to)."""
    owner = robot.compiled_kinematics if name in ("fkine", "jacob0") else robot.dynamics
    return getattr(owner, name)


def test_the_extension_builds_here():
    assert extension() is not None  # a C compiler and Python's headers are a requirement of the suite


@pytest.mark.parametrize("name", sorted(_FAST_CALLS))
def test_fast_calls_equal_the_checked_path_bit_for_bit(robot, name):
    rng = np.random.default_rng(27)
    for _ in range(20):
        args = list(rng.uniform(-3.0, 3.0, (ARGS[name], robot.n)))
        fast = getattr(robot, name)(*args)
        assert robot._calls[name] is not _no_call  # the fast path exists and was taken
        old = checked(robot, name)(*args)
        assert fast.shape == old.shape and fast.dtype == old.dtype
        assert fast.flags.f_contiguous == old.flags.f_contiguous
        np.testing.assert_array_equal(fast, old)
        # other accepted forms: lists of floats and ints, a strided view, a read-only array, (n, 1)
        np.testing.assert_array_equal(getattr(robot, name)(*[a.tolist() for a in args]), old)
        wide = np.zeros((robot.n, 2))
        wide[:, 0] = args[0]
        view = wide[:, 0]
        frozen = args[-1].copy()
        frozen.flags.writeable = False
        np.testing.assert_array_equal(getattr(robot, name)(view, *args[1:-1], frozen) if len(args) > 1
                                      else getattr(robot, name)(view), old)
        np.testing.assert_array_equal(getattr(robot, name)(*[a.reshape(-1, 1) for a in args]), old)
    ints = [list(range(robot.n))] * ARGS[name]
    np.testing.assert_array_equal(getattr(robot, name)(*ints), checked(robot, name)(*[np.arange(robot.n, dtype=float)] * ARGS[name]))


def test_fast_calls_equal_pinocchio(robot):
    model = pinocchio_model(robot.description)
    data = model.createData()
    fid = model.getFrameId("tool")
    rng = np.random.default_rng(28)

    def close(actual, expected):
        np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-10 * max(1.0, float(np.abs(expected).max())))

    for _ in range(10):
        q, qd, qdd = rng.uniform(-2.0, 2.0, (3, robot.n))
        F = friction_reference(robot.description, qd)
        close(robot.rne(q, qd, qdd), pin.rnea(model, data, q, qd, qdd) + F)
        close(robot.accel(q, qd, robot.rne(q, qd, qdd)), qdd)
        close(robot.accel(q, qd, qdd), pin.aba(model, data, q, qd, qdd - F))
        close(robot.inertia(q), symmetric_from_upper(pin.crba(model, data, q)))
        close(robot.gravload(q), pin.computeGeneralizedGravity(model, data, q))
        pin.framesForwardKinematics(model, data, q)
        close(robot.fkine(q), data.oMf[fid].homogeneous)


@pytest.mark.parametrize("name", sorted(_FAST_CALLS))
def test_bad_input_raises_the_checked_paths_error(robot, name):
    n = robot.n
    good = [np.full(n, 0.3)] * ARGS[name]
    bad_values = [np.r_[np.nan, np.zeros(n - 1)], np.r_[np.zeros(n - 1), np.inf], np.zeros(n + 1), np.zeros((2, n)),
                  [0.0] * (n - 1), ["a"] * n, "q", None]
    for position in range(ARGS[name]):
        for bad in bad_values:
            args = list(good)
            args[position] = bad
            with pytest.raises((InputError, TypeError, ValueError)) as expected:
                checked(robot, name)(*args)
            with pytest.raises(type(expected.value)) as got:
                getattr(robot, name)(*args)
            assert str(got.value) == str(expected.value)
            assert getattr(got.value, "parameter", None) == getattr(expected.value, "parameter", None)


def test_non_finite_output_takes_the_checked_path(robot):
    """Finite but huge inputs overflow: the fast path hands them on and the result is the checked path's."""
    n = robot.n
    q, qd, qdd = np.zeros(n), np.full(n, 1e200), np.full(n, 1e308)
    np.testing.assert_array_equal(robot.rne(q, qd, qdd), robot.dynamics.rne(q, qd, qdd))
    assert robot._calls["rne"](q, qd, qdd) is None  # negative control: the fast call itself declines


def test_with_parameters_binds_its_own_parameter_vector(robot):
    heavy = robot.with_payload(3.0, (0.0, 0.0, 0.05))
    q, qd, qdd = np.random.default_rng(29).uniform(-2.0, 2.0, (3, robot.n))
    robot.rne(q, qd, qdd)  # the original's fast call exists first
    np.testing.assert_array_equal(heavy.rne(q, qd, qdd), robot.dynamics.rne(q, qd, qdd, heavy.parameters))
    assert not np.array_equal(heavy.rne(q, qd, qdd), robot.rne(q, qd, qdd))
    np.testing.assert_array_equal(heavy.gravload(q), robot.gravload(q, heavy.parameters))
