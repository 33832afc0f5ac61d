"""Helpers of the identification tests: robots with random physical parameters, cached excitations, simulated logs.

* :func:`randomised`: a description with seeded random masses, centres of mass, physical inertias, rotor
  inertias, gear ratios and asymmetric friction on the same geometry (so ``Y pi = rne`` is checked for random
  ``pi``, not only for the file's values).
* :func:`excitation`: one optimised excitation per robot and setting, computed once per test session.
* :func:`inverse_dynamics_log`: samples along an excitation with the torques of the model's own inverse
  dynamics (``rne``, independent of the regressor), optionally with seeded white torque noise.
"""

from __future__ import annotations

import dataclasses
import warnings
from functools import lru_cache

import numpy as np

from model.description import InertiaConsistencyWarning, RobotDescription, pose_matrix, rpy_matrix
from model.loading import load_description
from model.robot import Robot

__all__ = ["EXCITATION_ITERATIONS", "excitation", "inverse_dynamics_log", "randomised", "robot", "with_friction",
           "with_poses"]

#: IPOPT iterations of the tests' excitations: enough for a condition number near 100 (a full run reaches
#: 70-80 on the Puma), a few seconds each.
EXCITATION_ITERATIONS = 40


def robot(name: str) -> Robot:
    """The built-in (or file) robot ``name``, its published inconsistent inertias accepted quietly."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InertiaConsistencyWarning)
        return Robot(load_description(name))


def _inertia(rng: np.random.Generator, mass: float) -> tuple[float, ...]:
    dims = rng.uniform(0.05, 0.4, 3)
    principal = mass / 12.0 * np.array([dims[1] ** 2 + dims[2] ** 2, dims[0] ** 2 + dims[2] ** 2,
                                        dims[0] ** 2 + dims[1] ** 2])
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    I = Q @ np.diag(principal) @ Q.T
    return (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2])


def randomised(desc: RobotDescription, seed: int) -> RobotDescription:
    """``desc`` with seeded random link and motor data (same geometry, limits and names)."""
    rng = np.random.default_rng(seed)
    links = []
    for lk in desc.links:
        mass = float(rng.uniform(0.5, 5.0))
        links.append(dataclasses.replace(
            lk, mass=mass, com=tuple(rng.uniform(-0.2, 0.2, 3)), inertia=_inertia(rng, mass),
            motor_inertia=float(rng.uniform(1e-5, 1e-4)), gear_ratio=float(rng.choice([-1, 1]) * rng.uniform(20, 100)),
            viscous_friction=float(rng.uniform(1e-5, 1e-3)),
            coulomb_friction=(float(rng.uniform(0.0, 0.05)), -float(rng.uniform(0.0, 0.05)))))
    return dataclasses.replace(desc, links=tuple(links))


def with_poses(desc: RobotDescription) -> RobotDescription:
    """``desc`` mounted on a tilted, shifted base, with a tool frame (both away from the identity)."""
    base, tool = np.eye(4), np.eye(4)
    base[:3, :3], base[:3, 3] = rpy_matrix([0.3, -0.5, 0.9]), [0.2, -0.1, 0.4]
    tool[:3, :3], tool[:3, 3] = rpy_matrix([0.1, 0.2, -0.3]), [0.0, 0.05, 0.1]
    as_tuple = lambda T: tuple(float(v) for v in T.ravel())  # noqa: E731
    out = dataclasses.replace(desc, base=as_tuple(base), tool=as_tuple(tool))
    assert not np.allclose(pose_matrix(out.base), np.eye(4))
    return out


@lru_cache(maxsize=None)
def excitation(name: str, periods: int = 2, rate_hz: float = 200.0, seed: int = 0):
    """``(ExcitationResult, t, q, qd, qdd)`` of robot ``name``: :data:`EXCITATION_ITERATIONS` IPOPT iterations,
    ``periods`` periods sampled at ``rate_hz``; once per session."""
    from model.identification import optimise_excitation

    result = optimise_excitation(robot(name), max_iter=EXCITATION_ITERATIONS, seed=seed)
    return (result, *result.trajectory.sample(rate_hz, periods))


def inverse_dynamics_log(rob: Robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, *, noise: float = 0.0,
                         seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``(tau, sigma)``: the robot's ``rne`` along the states, plus white noise of deviation ``sigma`` per joint
    (``noise`` times the joint's largest torque), seeded."""
    tau = rob.rne_batch(q, qd, qdd)
    sigma = noise * np.abs(tau).max(axis=0)
    rng = np.random.default_rng(seed)
    return tau + rng.standard_normal(tau.shape) * sigma, sigma


def with_friction(desc: RobotDescription) -> RobotDescription:
    """``desc`` with viscous and asymmetric Coulomb friction on every joint (joint side: 0.5 N m s/rad,
    +1.0 / -0.8 N m), for the robots whose files state none."""
    links = []
    for lk in desc.links:
        G = lk.gear_ratio
        links.append(dataclasses.replace(lk, viscous_friction=0.5 / G ** 2,
                                         coulomb_friction=(1.0 / abs(G), -0.8 / abs(G))))
    return dataclasses.replace(desc, links=tuple(links))
