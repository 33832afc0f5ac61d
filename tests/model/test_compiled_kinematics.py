"""Compiled kinematics against CasADi's evaluation and the Robotics Toolbox; the batch forms; the fallback.

Tolerances
----------
* Compiled against symbolic (CasADi's own evaluation of the same Functions): ``TOL_SYM = 8 eps``
  times the reach. The generated C performs the same operations in the same order, compiled with
  ``-ffp-contract=off`` (no fused multiply-add), and calls the same libm ``sin``/``cos``, so the two
  agree to the bit here; the bound allows a libm that rounds a last bit differently.
* Against the Robotics Toolbox: ``TOL_REF = 1e-12`` as in ``test_kinematics.py`` (products of at most
  8 homogeneous transforms with O(1) entries: rounding ~1e-15; a wrong term moves entries by O(1)).
* A batch against the single-point calls: exactly equal (the same compiled function at the same inputs).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from model import load_robot
from model.compiled_kinematics import CompiledKinematics
from model.dynamics import NoCompilerWarning
from model.robot import Robot
from tests.support.references import rtb_robot

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

ROBOTS = ("puma560", "scara", "ur5", "panda", "spherical", "planar3r")
TOL_REF = 1e-12
TOL_SYM = 8 * np.finfo(float).eps
N = 16


def _configurations(robot: Robot, rng: np.random.Generator, count: int = N) -> np.ndarray:
    lo, hi = robot.qlim
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)
    return rng.uniform(lo, hi, size=(count, robot.n))


def _reach(robot: Robot) -> float:
    return 1.0 + sum(abs(lk.a) + abs(lk.d) for lk in robot.description.links) + 2.0


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request) -> Robot:
    return load_robot(request.param)


def test_compiled_matches_symbolic(robot):
    Q = _configurations(robot, np.random.default_rng(1))
    f = robot.kinematics
    assert robot.compiled_kinematics.compile().library.is_file()
    scale = _reach(robot)
    for q in Q[:4]:
        np.testing.assert_allclose(robot.fkine(q), np.array(f.fkine(q)), rtol=0, atol=TOL_SYM * scale)
        np.testing.assert_allclose(robot.fkine_all(q), np.array(f.fkine_all(q)).reshape(robot.n + 1, 4, 4),
                                   rtol=0, atol=TOL_SYM * scale)
        np.testing.assert_allclose(robot.jacob0(q), np.array(f.jacob0(q)), rtol=0, atol=TOL_SYM * scale)
        np.testing.assert_allclose(robot.jacobe(q), np.array(f.jacobe(q)), rtol=0, atol=TOL_SYM * scale)


def test_batches_against_the_robotics_toolbox(robot):
    ref = rtb_robot(robot.description)
    Q = _configurations(robot, np.random.default_rng(2))
    T = robot.fkine_batch(Q)
    J = robot.jacob0_batch(Q)
    assert T.shape == (N, 4, 4) and J.shape == (N, 6, robot.n)
    T_ref = np.array([X.A for X in ref.fkine(Q)])  # the toolbox's own batch form: an SE3 of N values
    J_ref = np.array([ref.jacob0(q) for q in Q])
    assert np.abs(T - T_ref).max() <= TOL_REF
    assert np.abs(J - J_ref).max() <= TOL_REF
    ck = robot.compiled_kinematics
    np.testing.assert_array_equal(T, np.array([robot.fkine(q) for q in Q]))
    np.testing.assert_array_equal(J, np.array([robot.jacob0(q) for q in Q]))
    np.testing.assert_array_equal(ck.jacobe_batch(Q), np.array([robot.jacobe(q) for q in Q]))
    np.testing.assert_array_equal(ck.fkine_all_batch(Q), np.array([robot.fkine_all(q) for q in Q]))


@pytest.mark.parametrize("name", ["scara", "puma560", "planar3r"])  # 3 robots: each compiles its dynamics
def test_dynamics_batches_equal_the_single_point_calls(name):
    robot = load_robot(name)
    Q = _configurations(robot, np.random.default_rng(3), 6)
    p = robot.parameters.with_payload(1.5, [0.01, 0.0, 0.05])
    B = robot.inertia_batch(Q, p)
    g = robot.gravload_batch(Q)
    assert B.shape == (6, robot.n, robot.n) and g.shape == (6, robot.n)
    np.testing.assert_array_equal(B, np.array([robot.inertia(q, p) for q in Q]))
    np.testing.assert_array_equal(g, np.array([robot.gravload(q) for q in Q]))
    assert np.abs(B - B.transpose(0, 2, 1)).max() == 0.0  # B is mirrored from its lower triangle: exactly symmetric


def test_batch_shapes_and_errors():
    robot = load_robot("planar2r")
    assert robot.fkine_batch(np.zeros((0, 2))).shape == (0, 4, 4)
    assert robot.jacob0_batch(np.zeros((0, 2))).shape == (0, 6, 2)
    assert robot.inertia_batch(np.zeros((0, 2))).shape == (0, 2, 2)
    assert robot.gravload_batch(np.zeros((0, 2))).shape == (0, 2)
    assert robot.fkine_batch(np.zeros((1, 2))).shape == (1, 4, 4)  # one row stays a batch
    with pytest.raises(ValueError, match=r"Q: expected an \(N, 2\) array, got shape \(2,\)"):
        robot.fkine_batch(np.zeros(2))
    with pytest.raises(ValueError, match=r"Q: expected an \(N, 2\) array, got shape \(3, 3\)"):
        robot.jacob0_batch(np.zeros((3, 3)))
    Q = np.zeros((4, 2))
    Q[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"Q: expected finite values; rows \[2\] are not"):
        robot.inertia_batch(Q)


def test_second_robot_loads_the_cached_library():
    first = load_robot("arm4").compiled_kinematics.compile()
    second = load_robot("arm4").compiled_kinematics.compile()
    assert second.cached and second.library == first.library


def test_without_compiler_falls_back_to_casadi_with_one_warning(monkeypatch, tmp_path):
    monkeypatch.setenv("MANIP_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "/nonexistent/cc")
    desc = load_robot("scara").description
    kin = CompiledKinematics(desc)
    q = np.array([0.3, -0.5, 0.2, 0.1])
    with pytest.warns(NoCompilerWarning, match="CC: no C compiler found.*evaluating the kinematics with CasADi"):
        T = kin.fkine(q)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # once only
        J = kin.jacob0(q)
        TB = kin.fkine_batch(np.tile(q, (3, 1)))
    np.testing.assert_array_equal(T, np.array(kin.functions.fkine(q)))
    np.testing.assert_array_equal(J, np.array(kin.functions.jacob0(q)))
    np.testing.assert_array_equal(TB, np.tile(T, (3, 1, 1)))
    assert repr(kin).endswith("casadi)") and not list(tmp_path.glob("*.so"))


def test_reference_comparison_catches_a_one_millimetre_change():
    """Negative control: a Puma with a2 longer by 1 mm is compiled to its own library and misses the
    toolbox's Puma by about a millimetre, far above TOL_REF."""
    puma = load_robot("puma560")
    links = list(puma.description.links)
    links[1] = dataclasses.replace(links[1], a=links[1].a + 1e-3)
    altered = Robot(dataclasses.replace(puma.description, links=tuple(links)))
    ref = rtb_robot(puma.description)
    Q = _configurations(puma, np.random.default_rng(4), 4)
    miss = np.abs(altered.fkine_batch(Q) - np.array([X.A for X in ref.fkine(Q)])).max()
    assert 1e-4 < miss <= 1.1e-3 and altered.compiled_kinematics.build_info.library != \
        puma.compiled_kinematics.compile().library
