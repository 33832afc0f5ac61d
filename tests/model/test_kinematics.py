"""Forward kinematics and Jacobians against Pinocchio, the Robotics Toolbox and finite differences.

Tolerances
----------
* ``TOL_REF = 1e-12`` against Pinocchio and the toolbox: all three compute the
  same products of at most 7 (n <= 6) homogeneous transforms with O(1) entries
  and link lengths of a few metres in double precision, so they may differ by
  a few tens of machine epsilons times the reach (observed <= 1e-15); 1e-12
  is far below any modelling error (a wrong sign or offset moves entries by O(1)).
* Central differences of fkine with step ``H_FD``: truncation <= h^2/6 |f'''|,
  with |f'''| <= the reach L for positions (a revolute joint moves a point on a
  circle of radius <= L; a prismatic joint moves it linearly) and <= 1 for
  rotation-matrix entries; rounding <= ~eps |f| / h. :func:`_fd_tol` adds both.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import model
from model import load_robot
from model.robot import Robot
from tests.support.references import dh_constant_placement, pinocchio_model, rtb_robot

pytestmark = pytest.mark.filterwarnings("ignore::model.description.InertiaConsistencyWarning")

TOL_REF = 1e-12
H_FD = 1e-5  # balances h^2 L / 6 against eps L / h for L of a few metres: both ~1e-10
EPS = np.finfo(float).eps
N_CONFIGS = 8
SEED = 7


def _reach(robot: Robot, q: np.ndarray) -> float:
    """Upper bound on |p| of every frame origin: sum of |a|, |d| and prismatic |q|, m."""
    links = robot.description.links
    return float(sum(abs(lk.a) + abs(lk.d) + (0.0 if lk.is_revolute else abs(qi)) for lk, qi in zip(links, q))) + 1.0


def _fd_tol(third: float, scale: float, h: float = H_FD) -> float:
    return h * h / 6.0 * third + 8.0 * EPS * scale / h


def _configurations(robot: Robot) -> np.ndarray:
    """Seeded uniform configurations within qlim; [-pi, pi] rad or [-1, 1] m where qlim is infinite."""
    lo, hi = robot.qlim.copy()
    revolute = np.array([lk.is_revolute for lk in robot.description.links])
    box = np.where(revolute, np.pi, 1.0)
    lo = np.where(np.isfinite(lo), lo, -box)
    hi = np.where(np.isfinite(hi), hi, box)
    rng = np.random.default_rng([SEED, robot.n])
    return rng.uniform(lo, hi, size=(N_CONFIGS, robot.n))


@pytest.fixture(scope="module", params=model.BUILTIN_ROBOTS)
def robot(request) -> Robot:
    return load_robot(request.param)


def _vee(W: np.ndarray) -> np.ndarray:
    """Axial vector of the skew-symmetric part of a 3x3 matrix."""
    return 0.5 * np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]])


def test_shapes(robot):
    q = _configurations(robot)[0]
    assert robot.fkine(q).shape == (4, 4)
    assert robot.fkine_all(q).shape == (robot.n + 1, 4, 4)
    assert robot.jacob0(q).shape == (6, robot.n)
    assert robot.jacobe(q).shape == (6, robot.n)
    np.testing.assert_array_equal(robot.fkine_all(q)[0], np.eye(4))


def test_against_pinocchio(robot):
    desc = robot.description
    pmodel = pinocchio_model(desc, armature=False)
    data = pmodel.createData()
    tool = pmodel.getFrameId("tool")
    worst = 0.0
    for q in _configurations(robot):
        pin.forwardKinematics(pmodel, data, q)
        pin.updateFramePlacements(pmodel, data)
        pin.computeJointJacobians(pmodel, data, q)
        frames = [np.eye(4)] + [
            (data.oMi[i] * dh_constant_placement(desc.links[i - 1])).homogeneous for i in range(1, robot.n + 1)
        ]
        errors = [
            np.abs(robot.fkine(q) - data.oMf[tool].homogeneous).max(),
            np.abs(robot.fkine_all(q) - np.array(frames)).max(),
            np.abs(robot.jacob0(q) - pin.getFrameJacobian(pmodel, data, tool, pin.LOCAL_WORLD_ALIGNED)).max(),
            np.abs(robot.jacobe(q) - pin.getFrameJacobian(pmodel, data, tool, pin.LOCAL)).max(),
        ]
        worst = max(worst, *errors)
    assert worst <= TOL_REF, f"{robot.name}: max deviation from Pinocchio {worst:.3e}"


def test_against_robotics_toolbox(robot):
    ref = rtb_robot(robot.description)
    worst = 0.0
    for q in _configurations(robot):
        frames = np.array([X.A for X in ref.fkine_all(q)])
        assert frames.shape == (robot.n + 1, 4, 4)
        errors = [
            np.abs(robot.fkine(q) - ref.fkine(q).A).max(),
            np.abs(robot.fkine_all(q) - frames).max(),
            np.abs(robot.jacob0(q) - ref.jacob0(q)).max(),
            np.abs(robot.jacobe(q) - ref.jacobe(q)).max(),
        ]
        worst = max(worst, *errors)
    assert worst <= TOL_REF, f"{robot.name}: max deviation from the Robotics Toolbox {worst:.3e}"


def test_jacobians_against_central_differences(robot):
    for q in _configurations(robot)[:3]:
        T = robot.fkine(q)
        R = T[:3, :3]
        J0, Je = robot.jacob0(q), robot.jacobe(q)
        L = _reach(robot, q) + 2 * H_FD
        for i in range(robot.n):
            e = np.zeros(robot.n)
            e[i] = H_FD
            dT = (robot.fkine(q + e) - robot.fkine(q - e)) / (2 * H_FD)
            dp, dR = dT[:3, 3], dT[:3, :3]
            # Position: directly; rotation: Rdot R^T = [w_0]x (base axes), R^T Rdot = [w_E]x.
            assert np.abs(dp - J0[:3, i]).max() <= _fd_tol(L, L), (robot.name, i)
            assert np.abs(R.T @ dp - Je[:3, i]).max() <= _fd_tol(L, L), (robot.name, i)
            assert np.abs(_vee(dR @ R.T) - J0[3:, i]).max() <= 3 * _fd_tol(1.0, 1.0), (robot.name, i)
            assert np.abs(_vee(R.T @ dR) - Je[3:, i]).max() <= 3 * _fd_tol(1.0, 1.0), (robot.name, i)


@pytest.mark.parametrize("method", ["fkine", "fkine_all", "jacob0", "jacobe"])
def test_bad_q_raises_naming_q(robot, method):
    f = getattr(robot, method)
    with pytest.raises(ValueError, match=rf"q: expected {robot.n} joint values, got an array of shape \({robot.n + 1},\)"):
        f(np.zeros(robot.n + 1))
    with pytest.raises(ValueError, match=rf"q: expected {robot.n} joint values, got an array of shape \(2, {robot.n}\)"):
        f(np.zeros((2, robot.n)))
    bad = np.zeros(robot.n)
    bad[-1] = np.nan
    with pytest.raises(ValueError, match=r"q: expected finite values"):
        f(bad)
