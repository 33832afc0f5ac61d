"""Seeded random standard-DH chains of any length, for scaling tests and the build benchmark.

Every joint is revolute; consecutive joint axes alternate between parallel
(``alpha = 0``) and perpendicular (``alpha = +-pi/2``), link lengths and
offsets are drawn so that no two axes coincide, and each link gets a mass,
a centre of mass off every axis and a positive definite inertia that meets
the triangle inequality. The motors are geared (``G^2 Jm`` on the diagonal of
B) with viscous and Coulomb friction, so every term of the model is exercised.
"""

from __future__ import annotations

import numpy as np

from model.description import RobotDescription, description_from_dict

__all__ = ["random_chain"]


def _inertia(rng: np.random.Generator, mass: float, size: float) -> list[float]:
    """[Ixx Iyy Izz Ixy Iyz Ixz] of a random solid: principal moments from a box, randomly rotated."""
    dims = rng.uniform(0.3, 1.0, 3) * size
    principal = mass / 12.0 * np.array([dims[1] ** 2 + dims[2] ** 2, dims[0] ** 2 + dims[2] ** 2, dims[0] ** 2 + dims[1] ** 2])
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    I = Q @ np.diag(principal) @ Q.T
    return [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[1, 2], I[0, 2]]


def random_chain(n: int, seed: int = 0) -> RobotDescription:
    """An n-joint revolute chain with seeded random DH parameters, inertias and motor data.

    Parameters
    ----------
    n
        Number of joints (>= 1).
    seed
        Seed of :func:`numpy.random.default_rng`; the same (n, seed) gives the same robot.
    """
    if n < 1:
        raise ValueError(f"n: expected at least one joint, got {n}")
    rng = np.random.default_rng(seed)
    scale = 1.0 / np.sqrt(n)  # keeps the reach and the inertia matrix of a long chain moderate
    links = []
    for i in range(n):
        alpha = 0.0 if i % 2 else float(rng.choice([-1.0, 1.0])) * np.pi / 2
        a = float(rng.uniform(0.2, 0.6)) * scale
        d = float(rng.uniform(0.05, 0.3)) * scale
        mass = float(rng.uniform(1.0, 5.0)) * scale
        com = [float(x) for x in rng.uniform(-0.5, 0.5, 3) * a]
        links.append({
            "joint": "revolute", "a": a, "alpha": alpha, "d": d, "theta": float(rng.uniform(-0.5, 0.5)),
            "mass": mass, "com": com, "inertia": _inertia(rng, mass, a),
            "motor_inertia": float(rng.uniform(1e-5, 1e-4)), "gear_ratio": float(rng.uniform(20.0, 100.0)),
            "viscous_friction": float(rng.uniform(1e-4, 1e-3)), "coulomb_friction": [0.05, -0.04],
        })
    data = {"name": f"chain{n}", "description": f"random {n}-joint revolute chain (seed {seed})",
            "gravity": [0.0, 0.0, -9.81], "links": links}
    return description_from_dict(data, f"<random chain n={n} seed={seed}>")
