"""Checks a robot has to pass before it is exported: the FMU must not divide by a singular inertia.

The FMU computes ``qdd = B(q)^-1 (tau - ...)``. A joint that moves no mass
and has no motor inertia (a massless link, or a link with no inertia about
its own axis and nothing beyond it) gives a singular ``B(q)``: the FMU would
return non-finite derivatives at the first call. :func:`check_inertia` finds
that at export time, at a few seeded configurations, and names the joint.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from model.description import RobotDescriptionError
from model.dynamics.singular import INERTIA_RTOL, singular_joint

__all__ = ["SingularInertiaError", "INERTIA_RTOL", "check_inertia"]


class SingularInertiaError(RobotDescriptionError):
    """The joint-space inertia matrix B(q) of a robot is singular: the robot cannot be simulated."""


def _sample_configurations(robot: Any, count: int, seed: int) -> np.ndarray:
    """``q_rest`` and ``count`` seeded configurations within the joint limits (+-pi, or +-0.5 m, where none)."""
    lo, hi = np.array(robot.qlim, dtype=float)
    revolute = np.array([lk.is_revolute for lk in robot.description.links])
    default = np.where(revolute, np.pi, 0.5)
    lo = np.where(np.isfinite(lo), lo, -default)
    hi = np.where(np.isfinite(hi), hi, default)
    rng = np.random.default_rng(seed)
    return np.vstack([robot.q_rest, lo + (hi - lo) * rng.random((count, robot.n))])


def check_inertia(robot: Any, count: int = 4, seed: int = 0) -> None:
    """Raise :class:`SingularInertiaError` naming the joint if ``B(q)`` is singular at a sampled ``q``.

    Parameters
    ----------
    robot
        A :class:`model.Robot` (its ``inertia(q)`` includes the motor inertia).
    count
        Seeded random configurations checked besides the rest configuration.
    seed
        Seed of those configurations.

    Raises
    ------
    SingularInertiaError
        One line: the file, the joint (number and name), the smallest eigenvalue and ``q``.
    """
    where = robot.description.path or robot.name
    for q in _sample_configurations(robot, count, seed):
        found = singular_joint(robot.inertia(q))  # the joint the null direction of B moves most
        if found is None:
            continue
        i, smallest, scale = found
        link = robot.description.links[i]
        name = f" ({link.name})" if link.name else ""
        unit = "kg m^2" if link.is_revolute else "kg"
        raise SingularInertiaError(
            f"{where}, link {i + 1}{name}: the inertia matrix B(q) is singular (smallest eigenvalue "
            f"{smallest:.3g} {unit} against {scale:.3g} at q = {np.round(q, 3).tolist()}): joint {i + 1} moves "
            "no mass and has no motor inertia; give the link a mass and inertia about its axis, or a motor_inertia")
